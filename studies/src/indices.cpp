// Sensitivity indices of stored studies (see indices.h): reading the runs, choosing the method,
// the estimators, the output status and the "until" rule. JSON and tables: indices_json.cpp.
#include "stickslip/studies/indices.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <utility>

#include "stickslip/common/text.h"
#include "stickslip/studies/outputs.h"
#include "stickslip/studies/sa_dgsm.h"
#include "stickslip/studies/sa_fast.h"
#include "stickslip/studies/sa_given.h"

namespace stickslip::studies {
namespace {

namespace sa = sensitivity;

OutputContext context_of(const StudySpec& spec) {
  return {spec.analytic_model(), spec.is_analytic() ? 1 : spec.base_config().stages.size()};
}

// ---------------------------------------------------------------------------- method and shape

std::string choose_method(DesignType type, const std::string& requested, const std::string& id) {
  const bool given = type == DesignType::kSobol || type == DesignType::kRandom ||
                     type == DesignType::kLhs || type == DesignType::kRbdFast;
  std::string own;
  switch (type) {
    case DesignType::kSobol: own = "sobol"; break;
    case DesignType::kMorris: own = "morris"; break;
    case DesignType::kEfast: own = "efast"; break;
    case DesignType::kDgsm: own = "dgsm"; break;
    case DesignType::kRbdFast: own = "rbd_fast"; break;
    case DesignType::kRandom:
    case DesignType::kLhs: own = "delta"; break;
    default:
      throw std::invalid_argument("study " + id + " has a '" + to_string(type) +
                                  "' design; sensitivity indices need a sampled design (sobol, "
                                  "morris, efast, rbd_fast, dgsm, random or lhs)");
  }
  if (requested.empty() || requested == own) return own;
  if (given && (requested == "rbd_fast" || requested == "delta" || requested == "pawn"))
    return requested;
  throw std::invalid_argument(
      "method '" + requested + "' does not apply to study " + id + " (a '" + to_string(type) +
      "' design): it supports '" + own + "'" +
      (given ? " and the given-data methods 'rbd_fast', 'delta', 'pawn'" : ""));
}

sa::SaltelliShape saltelli_shape(const Design& d, std::size_t n) {
  sa::SaltelliShape s;
  s.n = n;
  s.d = d.ranges.size();
  s.second_order = d.second_order;
  s.layout = d.sobol_rows_layout() ? sa::SaltelliLayout::kRows : sa::SaltelliLayout::kBlocks;
  return s;
}

/// The design's base size for `total` stored runs (a Sobol study with "until" grows).
std::size_t base_size(const Design& d, std::int64_t total) {
  if (d.type == DesignType::kSobol || d.type == DesignType::kDgsm)
    return static_cast<std::size_t>(total) / d.runs_per_row();
  return d.n;
}

/// The run indices a given-data method uses: a Sobol design's A and B rows, else every run.
std::vector<std::size_t> given_rows(const Design& d, std::size_t n, std::size_t runs) {
  std::vector<std::size_t> rows;
  if (d.type != DesignType::kSobol) {
    for (std::size_t i = 0; i < runs; ++i) rows.push_back(i);
    return rows;
  }
  const sa::SaltelliShape s = saltelli_shape(d, n);
  for (std::size_t j = 0; j < n; ++j) rows.push_back(s.run(j, 0));
  for (std::size_t j = 0; j < n; ++j) rows.push_back(s.run(j, 1));
  return rows;
}

sa::MethodIndices from_morris(const sa::MorrisIndices& m) {
  sa::MethodIndices r;
  r.method = "morris";
  r.per_parameter.push_back({"mu", m.mu, {}, {}});
  r.per_parameter.push_back({"mu_star", m.mu_star, m.mu_star_ci, {}});
  r.per_parameter.push_back({"sigma", m.sigma, {}, {}});
  return r;
}

struct Analysis {
  sa::MethodIndices indices;
  std::vector<sa::ConvergenceStep> convergence;
};

Analysis analyse(const std::string& method, const StudySpec& spec, std::size_t n,
                 const std::vector<double>& y, const IndicesOptions& o) {
  const Design& d = spec.design();
  sa::BootstrapOptions b{o.confidence, o.resamples, o.seed, o.keep_resamples};
  Analysis a;
  auto unit_rows = [&](const std::vector<std::size_t>& rows) {
    sa::Matrix x;
    for (std::size_t i : rows) x.push_back(spec.unit_point(i));
    return x;
  };
  if (method == "sobol") {
    a.indices = sa::sobol_analysis(y, saltelli_shape(d, n), b);
    if (o.convergence) a.convergence = sa::sobol_convergence(y, saltelli_shape(d, n), b);
  } else if (method == "efast") {
    sa::EfastShape s{d.n, d.ranges.size(), d.harmonics, d.replicates};
    a.indices = sa::efast_analysis(y, s, b);
  } else if (method == "dgsm") {
    std::vector<std::size_t> all(y.size());
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
    a.indices = sa::dgsm_analysis(unit_rows(all), y, n, d.ranges.size(),
                                  std::vector<double>(d.ranges.size(), sa::unit_uniform_poincare()), b);
  } else if (method == "morris") {
    std::vector<std::size_t> all(y.size());
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
    a.indices = from_morris(sa::morris_indices(unit_rows(all), y, d.trajectories,
                                               d.ranges.size(), o.confidence, o.resamples,
                                               o.seed));
  } else {
    const auto rows = given_rows(d, n, y.size());
    std::vector<double> yg;
    for (std::size_t i : rows) yg.push_back(y[i]);
    const sa::Matrix x = unit_rows(rows);
    a.indices = method == "rbd_fast" ? sa::rbd_fast_analysis(x, yg, b)
                : method == "delta"  ? sa::delta_analysis(x, yg, b)
                                     : sa::pawn_analysis(x, yg, b);
  }
  return a;
}

// ---------------------------------------------------------------------------- the runs

/// Every output's value per design index (NaN marks an offending point) and the offenders.
struct Gathered {
  std::vector<std::vector<double>> y;
  std::vector<std::vector<InvalidPoint>> bad;
  std::vector<std::size_t> bad_count;
  std::int64_t stored = 0, failed = 0;
  std::size_t missing = 0;
};

Gathered gather(store::Store& store, const std::string& id, std::size_t runs,
                const std::vector<OutputRef>& outputs, std::size_t stages, std::size_t listed) {
  Gathered g;
  const std::size_t k = outputs.size();
  g.y.assign(k, std::vector<double>(runs, std::nan("")));
  g.bad.resize(k);
  g.bad_count.assign(k, 0);
  std::vector<char> stored(runs, 0);
  auto note = [&](std::size_t o, InvalidPoint p) {
    ++g.bad_count[o];
    if (g.bad[o].size() < listed) g.bad[o].push_back(std::move(p));
  };
  for (std::int64_t after = -1;;) {
    const auto page = store.get_runs(id, after, 2000);
    if (page.empty()) break;
    for (const store::RunRecord& run : page) {
      after = run.design_index;
      if (run.design_index < 0 || static_cast<std::size_t>(run.design_index) >= runs) continue;
      const auto i = static_cast<std::size_t>(run.design_index);
      stored[i] = 1;
      ++g.stored;
      if (run.status != "ok") ++g.failed;
      for (std::size_t o = 0; o < k; ++o) {
        if (run.status != "ok") {
          note(o, {run.design_index, run.status, run.error});
          continue;
        }
        std::string why;
        const double v = output_value(outputs[o], run, stages, &why);
        if (std::isfinite(v)) g.y[o][i] = v;
        else note(o, {run.design_index, "ok", why.empty() ? "output is not finite" : why});
      }
    }
  }
  for (std::size_t i = 0; i < runs; ++i)  // missing runs, after the stored ones
    if (!stored[i]) {
      ++g.missing;
      for (std::size_t o = 0; o < k; ++o)
        note(o, {static_cast<std::int64_t>(i), "missing", "run not stored (study not finished?)"});
    }
  return g;
}

std::string invalid_reason(std::size_t bad, std::size_t runs, std::size_t failed,
                           std::size_t missing) {
  std::ostringstream r;
  r << "indices invalid: " << bad << " of " << runs << " design points unusable (";
  bool first = true;
  auto part = [&](std::size_t c, const char* what) {
    if (c == 0) return;
    r << (first ? "" : ", ") << c << ' ' << what;
    first = false;
  };
  part(failed, "failed runs");
  part(missing, "missing runs");
  part(bad - failed - missing, "outputs not defined at their point");
  r << "); the estimators need every point of the design";
  return r.str();
}

// ---------------------------------------------------------------------------- one output

/// Warnings of an output with variation: near-constant, or nearly all points at one value.
std::vector<std::string> warnings_for(const std::vector<double>& v, double mean, double var) {
  std::vector<std::string> w;
  char buf[256];
  const double sd = std::sqrt(var);
  if (mean != 0.0 && sd < 1e-4 * std::abs(mean)) {
    std::snprintf(buf, sizeof buf,
                  "near-constant output: variance %.3g (sd %.3g = %.2g of the mean %.6g); the "
                  "indices apportion differences this small, which may be numerical noise",
                  var, sd, sd / std::abs(mean), mean);
    w.push_back(buf);
  }
  std::map<double, std::size_t> counts;
  for (double e : v) ++counts[e];
  const auto top = std::max_element(counts.begin(), counts.end(),
                                    [](const auto& a, const auto& b) { return a.second < b.second; });
  if (10 * top->second >= 9 * v.size()) {
    std::snprintf(buf, sizeof buf,
                  "%zu of %zu points (%.1f %%) have the same value %.6g: the indices describe the "
                  "few points that differ (variance %.3g)",
                  top->second, v.size(), 100.0 * static_cast<double>(top->second) / v.size(),
                  top->first, var);
    w.push_back(buf);
  }
  return w;
}

OutputIndices analyse_output(const std::string& name, const std::string& method,
                             const StudySpec& spec, std::size_t n, const std::vector<double>& v,
                             const IndicesOptions& options) {
  OutputIndices out;
  out.output = name;
  double mean = 0.0;
  for (double e : v) mean += e - v.front();  // shifted: a constant has exactly zero deviation
  mean = v.front() + mean / static_cast<double>(v.size());
  double var = 0.0;
  for (double e : v) var += (e - mean) * (e - mean);
  out.mean = mean;
  out.variance = v.size() > 1 ? var / static_cast<double>(v.size() - 1) : 0.0;
  try {
    Analysis a = analyse(method, spec, n, v, options);
    if (!a.indices.defined) {
      out.status = "undefined";
      out.reason = a.indices.reason;
      return out;
    }
    out.status = "ok";
    out.warnings = warnings_for(v, mean, out.variance);
    if (method == "morris" && out.variance == 0.0)
      out.warnings.push_back("the output is constant: every elementary effect is 0");
    out.indices = std::move(a.indices);
    out.convergence = std::move(a.convergence);
  } catch (const std::invalid_argument& e) {
    out.status = "invalid";
    out.reason = std::string("indices invalid: ") + e.what();
  }
  return out;
}

}  // namespace

bool IndicesOptions::IsValid(std::vector<std::string>* errors) const {
  bool ok = true;
  auto fail = [&](const std::string& m) {
    ok = false;
    if (errors != nullptr) errors->push_back(m);
  };
  if (!(confidence > 0.0 && confidence < 1.0))
    fail("confidence must be in (0, 1), got " + std::to_string(confidence));
  if (resamples < 10) fail("resamples must be >= 10, got " + std::to_string(resamples));
  static const char* kMethods[] = {"", "sobol", "morris", "efast", "rbd_fast", "delta", "pawn", "dgsm"};
  if (std::find(std::begin(kMethods), std::end(kMethods), method) == std::end(kMethods))
    fail("method must be one of sobol, morris, efast, rbd_fast, delta, pawn, dgsm, got '" +
         method + "'");
  return ok;
}

bool StudyIndices::valid() const noexcept {
  return std::all_of(outputs.begin(), outputs.end(),
                     [](const OutputIndices& o) { return o.valid(); });
}

bool StudyIndices::complete() const noexcept {
  return std::none_of(outputs.begin(), outputs.end(),
                      [](const OutputIndices& o) { return o.status == "invalid"; });
}

std::vector<std::string> default_outputs(const StudySpec& spec) {
  return studies::default_outputs(context_of(spec));
}

std::string check_output(const StudySpec& spec, const std::string& output) {
  std::string why;
  return parse_output(context_of(spec), output, &why) ? std::string() : why;
}

StudySpec stored_spec(const store::StudyRecord& study) {
  Limits limits;
  limits.max_runs = std::numeric_limits<std::size_t>::max();
  ParseResult parsed = parse_study(study.spec_json, limits);
  if (!parsed.ok())
    throw std::invalid_argument("study " + study.id + ": its stored spec does not parse: " +
                                to_string(parsed.errors.front()));
  return std::move(*parsed.spec);
}

namespace {

/// compute_indices without the "until" status (which computes indices itself).
StudyIndices compute_core(store::Store& store, const std::string& study_id,
                          const std::vector<std::string>& outputs, const IndicesOptions& options) {
  if (std::vector<std::string> errors; !options.IsValid(&errors))
    throw std::invalid_argument("indices options: " + common::join(errors, "; "));
  const auto study = store.get_study(study_id);
  if (!study) throw store::StoreError("unknown study '" + study_id + "' in " + store.path().string());
  const StudySpec spec = stored_spec(*study);
  const Design& design = spec.design();
  StudyIndices r;
  r.method = choose_method(design.type, options.method, study_id);
  r.study_id = study->id;
  r.study_name = study->name;
  r.state = to_string(study->state);
  r.design = to_string(design.type);
  r.parameters = spec.variables();
  r.total_runs = study->total_runs;
  r.options = options;
  r.n = base_size(design, study->total_runs);
  r.trajectories = design.trajectories;
  r.levels = design.levels;
  r.replicates = design.type == DesignType::kEfast ? design.replicates : 0;
  r.harmonics = design.type == DesignType::kEfast ? design.harmonics : 0;
  r.second_order = design.second_order;
  const auto runs = static_cast<std::size_t>(study->total_runs);
  if (spec.F_S_below_F_C() == FsBelowFc::kRaiseToFc)
    for (std::size_t i = 0; i < runs; ++i) {
      try {
        if (spec.raises_F_S(spec.point(i))) ++r.F_S_raised_runs;
      } catch (const std::exception&) {  // another problem: an invalid run, counted as failed
      }
    }
  const std::vector<std::string> names = outputs.empty() ? default_outputs(spec) : outputs;
  std::vector<OutputRef> parsed;
  for (const auto& name : names) {
    std::string why;
    auto o = parse_output(context_of(spec), name, &why);
    if (!o) throw std::invalid_argument("study " + study_id + ": " + why);
    parsed.push_back(*o);
  }
  Gathered g = gather(store, study_id, runs, parsed, context_of(spec).stages, options.max_listed);
  r.stored_runs = g.stored;
  r.failed_runs = g.failed;
  for (std::size_t o = 0; o < names.size(); ++o) {
    if (g.bad_count[o] > 0) {
      OutputIndices out;
      out.output = names[o];
      out.invalid_count = g.bad_count[o];
      out.invalid_points = std::move(g.bad[o]);
      out.reason = invalid_reason(g.bad_count[o], runs, static_cast<std::size_t>(g.failed), g.missing);
      r.outputs.push_back(std::move(out));
      continue;
    }
    r.outputs.push_back(analyse_output(names[o], r.method, spec, r.n, g.y[o], options));
  }
  return r;
}

/// Widest ST interval over the ok outputs of r: its width and "output/parameter" (NaN: none).
std::pair<double, std::string> widest_st(const StudyIndices& r) {
  double widest = std::nan("");
  std::string at;
  for (const OutputIndices& o : r.outputs) {
    if (!o.valid() || !o.indices) continue;
    const sa::IndexValues* st = o.indices->find("ST");
    if (st == nullptr) continue;
    for (std::size_t p = 0; p < st->ci.size(); ++p) {
      const double w = st->ci[p].hi - st->ci[p].lo;
      if (std::isfinite(w) && !(w <= widest)) {
        widest = w;
        at = o.output + "/" + r.parameters[p];
      }
    }
  }
  return {widest, at};
}

}  // namespace

StudyIndices compute_indices(store::Store& store, const std::string& study_id,
                             const std::vector<std::string>& outputs,
                             const IndicesOptions& options) {
  StudyIndices r = compute_core(store, study_id, outputs, options);
  const auto study = store.get_study(study_id);
  if (study && stored_spec(*study).design().until) r.until = until_status(store, study_id);
  return r;
}

std::optional<UntilStatus> until_status(store::Store& store, const std::string& study_id) {
  const auto study = store.get_study(study_id);
  if (!study) throw store::StoreError("unknown study '" + study_id + "' in " + store.path().string());
  const StudySpec spec = stored_spec(*study);
  const Design& d = spec.design();
  if (!d.until) return std::nullopt;
  const SobolUntil& rule = *d.until;
  IndicesOptions o;
  o.confidence = rule.confidence;
  o.resamples = rule.resamples;
  o.method = "sobol";
  const StudyIndices r = compute_core(store, study_id, rule.outputs, o);
  UntilStatus u;
  u.max_st_width = rule.max_st_width;
  u.n = r.n;
  u.n_max = rule.n_max;
  std::tie(u.widest, u.widest_at) = widest_st(r);
  char buf[160];
  if (r.stored_runs < r.total_runs) {
    u.reason = "not all runs of N = " + std::to_string(u.n) + " are stored yet";
  } else if (std::isnan(u.widest)) {
    u.reason = "stopped: no judged output has defined Sobol indices (see their status)";
  } else if (u.widest <= u.max_st_width) {
    std::snprintf(buf, sizeof buf, "reached: widest ST interval %.4g <= %.4g (%s) at N = %zu",
                  u.widest, u.max_st_width, u.widest_at.c_str(), u.n);
    u.reason = buf;
  } else if (u.n >= u.n_max) {
    std::snprintf(buf, sizeof buf, "stopped at n_max = %zu: widest ST interval %.4g > %.4g (%s)",
                  u.n_max, u.widest, u.max_st_width, u.widest_at.c_str());
    u.reason = buf;
  } else {
    u.grow = true;
    u.next_n = std::min(2 * u.n, u.n_max);
    std::snprintf(buf, sizeof buf, "growing to N = %zu: widest ST interval %.4g > %.4g (%s)",
                  u.next_n, u.widest, u.max_st_width, u.widest_at.c_str());
    u.reason = buf;
  }
  return u;
}

nlohmann::json indices_json(store::Store& store, const std::string& study_id,
                            const std::vector<std::string>& outputs,
                            const IndicesOptions& options) {
  return indices_to_json(compute_indices(store, study_id, outputs, options));
}

}  // namespace stickslip::studies
