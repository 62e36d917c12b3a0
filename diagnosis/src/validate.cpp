// Validation of a diagnosis on new runs (validate.h).
#include "stickslip/diagnosis/validate.h"

#include <omp.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "stickslip/common/gnuplot.h"
#include "stickslip/common/json_number.h"
#include "stickslip/diagnosis/detail/diagnose_adequacy.h"
#include "stickslip/diagnosis/detail/diagnose_holdout.h"
#include "stickslip/diagnosis/detail/diagnose_progress.h"
#include "stickslip/diagnosis/detail/diagnose_statfit.h"
#include "stickslip/diagnosis/validation_schema_data.h"
#include "diagnose_steps.h"

namespace stickslip::diagnosis {

using namespace detail;

bool ValidateOptions::IsValid(std::string* why) const {
  if (!(std::isfinite(rtol) && rtol > 0)) {
    if (why) *why = "rtol = " + std::to_string(rtol) + ": must be > 0";
    return false;
  }
  return true;
}

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// The model of a calibrated model's parameters (no fitted specs: FitModel::config sets nothing).
FitModel model_of(const CalibratedModel& c) {
  FitModel m;
  m.base = engine::SimConfig::seed(c.model, 0.0);
  m.base.extension.kind = c.effect;
  for (const auto& [name, value] : c.params) engine::set_parameter(m.base, name, value);
  std::vector<std::string> errors;
  if (!m.base.IsValid(&errors))
    throw std::invalid_argument("models: " + std::string(engine::to_string(c.model)) + ": " + errors.front());
  return m;
}

/// A run as the diagnosis' statistics scoring sees it, with every measured sample.
RunData run_data(const measured::MeasuredRun& mr) {
  RunData r;
  r.name = mr.name;
  r.cond = mr.conditions;
  r.rec = analyse_record(mr, 0.3);
  r.t = mr.t;
  r.y = mr.Fd;
  r.role.assign(r.t.size(), kHeld);
  plan_stats(r);
  return r;
}

RunReading reading_of(const RunData& r) {
  RunReading g = record_reading(r);
  g.scoring = r.rec.phase_locked ? "time_domain" : "statistics";
  g.burn_in = r.settle;
  return g;
}

double score_of(const SlipStats& m, const SlipStats& s, const StatsSpec& spec) {
  std::vector<double> res;
  stats_residuals(m, s, spec, &res);
  double ss = 0;
  for (double v : res) ss += v * v;
  return std::sqrt(ss / static_cast<double>(res.size()));
}

/// The statistics a model predicts for every stage of r.
std::vector<SlipStats> predicted_stats(const RunData& r, const FitModel& m, double rtol) {
  const engine::SimResult res = engine::simulate(stats_config(m, r, {}, rtol));
  if (res.status != engine::RunStatus::kOk || res.trace.size() < 4)
    throw std::runtime_error(std::string(to_string(res.status)) + " " + res.reason);
  return simulated_whole(r, res.trace);
}

void judge(StagePrediction* p) {
  const SlipStats &m = p->measured, &s = p->extended;
  p->mean_error = (s.mean - m.mean) / std::fabs(m.mean);
  const bool dm = m.regime != Regime::kCreep, ds = s.regime != Regime::kCreep;
  p->drop_error = dm && ds ? s.drop_median / m.drop_median - 1 : kNaN;
  p->rate_error = dm && ds ? s.rate / m.rate - 1 : kNaN;
  p->reproduced = std::fabs(p->mean_error) <= kMeanTolerance && dm == ds &&
                  (!dm || (std::fabs(p->drop_error) <= kDropTolerance && std::fabs(p->rate_error) <= kDropTolerance));
}

double rmse(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.empty() || a.size() != b.size()) return kNaN;
  double s = 0;
  for (std::size_t i = 0; i < a.size(); ++i) s += (a[i] - b[i]) * (a[i] - b[i]);
  return std::sqrt(s / static_cast<double>(a.size()));
}

RunValidation validate_run(const measured::MeasuredRun& mr, const FitModel& base, const FitModel& ext,
                           const Validation& v, double rtol) {
  RunValidation out;
  out.run = mr.name;
  out.conditions = mr.conditions;
  try {
    const RunData r = run_data(mr);
    out.reading = reading_of(r);
    const std::vector<SlipStats> pb = predicted_stats(r, base, rtol), pe = predicted_stats(r, ext, rtol);
    for (std::size_t j = 0; j < r.rec.whole.size() && j < pb.size() && j < pe.size(); ++j) {
      StagePrediction p;
      p.stage = static_cast<int>(j);
      p.measured = r.rec.whole[j];
      p.base = pb[j];
      p.extended = pe[j];
      const StatsSpec& spec = r.rec.windows[2 * j].spec;
      p.score_base = score_of(p.measured, p.base, spec);
      p.score_extended = score_of(p.measured, p.extended, spec);
      judge(&p);
      out.stages.push_back(p);
    }
    double shift = 0;
    out.t = mr.t;
    out.measured = mr.Fd;
    out.base = aligned_series(r, base, {}, rtol, r.t, &shift);
    out.extended = aligned_series(r, ext, {}, rtol, r.t, &shift);
    if (out.base.size() != out.t.size() || out.extended.size() != out.t.size())
      throw std::runtime_error("a simulation of the record failed");
    for (double& F : out.base) F += v.base.offset;
    for (double& F : out.extended) F += v.extended.offset;
    out.rmse_base = rmse(out.measured, out.base);
    out.rmse_extended = rmse(out.measured, out.extended);
  } catch (const std::exception& e) {
    out.status = std::string("failed: ") + e.what();
  }
  return out;
}

}  // namespace

Validation validate(const nlohmann::json& diagnosis, const measured::MeasuredDataset& data,
                    const ValidateOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  if (std::string why; !o.IsValid(&why)) throw std::invalid_argument(why);
  if (!diagnosis.is_object() || !diagnosis.contains("models"))
    throw std::invalid_argument("models: the diagnosis has no calibrated models (written by stickslip diagnose "
                                "from this version on)");
  Validation v;
  v.diagnosis_dataset = diagnosis.value("dataset", "");
  v.dataset = data.name;
  v.cause = diagnosis.value("cause", "none");
  v.verdict = diagnosis.value("verdict", "");
  v.base = calibrated_from_json(diagnosis.at("models").at("base"));
  v.extended = calibrated_from_json(diagnosis.at("models").at("extended"));
  const FitModel base = model_of(v.base), ext = model_of(v.extended);
  ProgressMeter meter(o.progress, 0.5);
  meter.phase("validation", static_cast<int>(data.runs.size()) * 4);
  v.runs.resize(data.runs.size());
  const int threads = o.threads > 0 ? o.threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (std::size_t k = 0; k < data.runs.size(); ++k) {
    if (o.stop_requested && o.stop_requested()) continue;
    ProgressItem item(&meter, data.runs[k].name);
    v.runs[k] = validate_run(data.runs[k], base, ext, v, o.rtol);
    for (int i = 0; i < 4; ++i) meter.tick();
  }
  if (o.stop_requested && o.stop_requested()) throw DiagnosisCancelled();
  meter.done();
  v.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return v;
}

std::string_view validation_schema_text() noexcept {
  // The file's $defs are those of diagnosis.schema.json (one source): merged in once.
  static const std::string text = [] {
    nlohmann::json v = nlohmann::json::parse(generated::kValidationSchemaJson);
    const nlohmann::json d = nlohmann::json::parse(diagnosis_schema_text());
    for (const char* name : {"num", "model", "slipstats", "reading", "calibrated"}) v["$defs"][name] = d["$defs"][name];
    return v.dump(2);
  }();
  return text;
}

}  // namespace stickslip::diagnosis
