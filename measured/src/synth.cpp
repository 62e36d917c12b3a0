#include "stickslip/measured/synth.h"

#include <boost/random/mersenne_twister.hpp>
#include <boost/random/normal_distribution.hpp>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "stickslip/common/text.h"
#include "stickslip/engine/simulate.h"

namespace stickslip::measured {
namespace {
std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}
}  // namespace

bool SynthOptions::IsValid(std::vector<std::string>* errors) const {
  bool ok = true;
  auto fail = [&](const std::string& m) {
    ok = false;
    if (errors != nullptr) errors->push_back(m);
  };
  const bool rate_ok = std::isfinite(rate) && rate > 0;
  if (!rate_ok) fail("rate = " + num(rate) + ": must be > 0");
  if (!(std::isfinite(noise_sigma) && noise_sigma >= 0))
    fail("noise = " + num(noise_sigma) + ": must be >= 0");
  if (!(std::isfinite(noise_rho) && noise_rho >= 0 && noise_rho < 1))
    fail("noise_ar = " + num(noise_rho) + ": must be in [0, 1)");
  if (!std::isfinite(offset)) fail("offset = " + num(offset) + ": must be finite");
  if (!(std::isfinite(rtol) && rtol > 0)) fail("rtol = " + num(rtol) + ": must be > 0");
  if (runs.empty()) fail("runs: at least one run is needed");
  for (std::size_t i = 0; rate_ok && i < runs.size(); ++i) {  // the sample count needs the rate
    const auto& c = runs[i];
    if (!(c.duration * rate >= static_cast<double>(kMinMeasuredSamples)))
      fail("duration = " + num(c.duration) + ": run " + std::to_string(i + 1) +
           " gives fewer than " + std::to_string(kMinMeasuredSamples) + " samples");
  }
  return ok;
}

MeasuredDataset synthesize(const SynthOptions& o) {
  if (std::vector<std::string> errors; !o.IsValid(&errors))
    throw std::invalid_argument(common::join(errors, "; "));
  MeasuredDataset data;
  data.name = o.name;
  boost::random::mt19937_64 gen(o.seed);
  boost::random::normal_distribution<double> normal(0.0, 1.0);
  for (std::size_t i = 0; i < o.runs.size(); ++i) {
    engine::SimConfig cfg = o.model;
    apply_conditions(o.runs[i], cfg);
    cfg.integrator.kind = engine::IntegratorKind::kAdaptive;
    cfg.integrator.rtol = o.rtol;
    cfg.integrator.atol = o.rtol;
    cfg.trace.rate = o.rate;
    cfg.Validate();  // throws naming the field and the value
    const engine::SimResult r = engine::simulate(cfg);
    if (r.status != engine::RunStatus::kOk)
      throw std::runtime_error("synth run " + std::to_string(i + 1) + ": " + to_string(r.status) +
                               ": " + r.reason);
    MeasuredRun run;
    char name[64];
    std::snprintf(name, sizeof name, "run%zu_va%g", i + 1, o.runs[i].va);
    run.name = name;
    run.file = run.name + ".csv";
    run.conditions = o.runs[i];
    double e = 0.0;
    const double innov = std::sqrt(1.0 - o.noise_rho * o.noise_rho);
    for (std::size_t k = 0; k < r.trace.size(); ++k) {
      const double w = normal(gen);
      e = k == 0 ? o.noise_sigma * w : o.noise_rho * e + innov * o.noise_sigma * w;
      if (r.trace[k].t > o.runs[i].duration) break;
      run.t.push_back(r.trace[k].t);
      run.Fd.push_back(r.trace[k].F_d + o.offset + e);
    }
    data.runs.push_back(std::move(run));
  }
  return data;
}

std::filesystem::path write_dataset(const MeasuredDataset& data,
                                    const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  nlohmann::ordered_json m;
  m["name"] = data.name;
  m["runs"] = nlohmann::ordered_json::array();
  for (const auto& r : data.runs) {
    const auto& c = r.conditions;
    m["runs"].push_back({{"name", r.name},
                         {"file", r.file},
                         {"conditions",
                          {{"m", c.m}, {"kd", c.kd}, {"vd", c.vd}, {"f", c.f}, {"va", c.va},
                           {"t_on", c.t_on}, {"duration", c.duration}}}});
    std::ofstream csv(dir / r.file);
    if (!csv) throw std::runtime_error("cannot write " + (dir / r.file).string());
    csv << "t,Fd\n";
    char line[96];
    for (std::size_t k = 0; k < r.t.size(); ++k) {
      std::snprintf(line, sizeof line, "%.9g,%.9g\n", r.t[k], r.Fd[k]);
      csv << line;
    }
    if (!csv) throw std::runtime_error("failed writing " + (dir / r.file).string());
  }
  const auto path = dir / "manifest.json";
  std::ofstream out(path);
  out << m.dump(2) << "\n";
  if (!out) throw std::runtime_error("failed writing " + path.string());
  return path;
}

}  // namespace stickslip::measured
