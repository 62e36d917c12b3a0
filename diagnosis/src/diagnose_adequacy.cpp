// The adequacy verdict (diagnose_adequacy.h).
#include "stickslip/diagnosis/detail/diagnose_adequacy.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "stickslip/diagnosis/detail/diagnose_statfit.h"

namespace stickslip::diagnosis::detail {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double score_of(const SlipStats& m, const SlipStats& s, const StatsSpec& spec) {
  std::vector<double> r;
  stats_residuals(m, s, spec, &r);
  double ss = 0;
  for (double v : r) ss += v * v;
  return std::sqrt(ss / static_cast<double>(r.size()));
}

std::string window_name(const StatsComparison& c) {
  return c.run + " stage " + std::to_string(c.stage + 1) + (c.held ? " (held out)" : "");
}

std::string fmt(const char* f, double a, double b = 0, double c = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, f, a, b, c);
  return buf;
}

}  // namespace

void judge_window(const StatsComparison& c, const StatsSpec& spec, double run_level,
                  std::vector<std::string>* missing) {
  const SlipStats &m = c.measured, &s = c.base;
  Regime rm, rs;
  const std::string at = window_name(c) + ": ";
  if (clear_regime(m, spec, &rm) && clear_regime(s, spec, &rs) && rm != rs) {
    missing->push_back(at + "regime " + to_string(rm) + " measured, " + to_string(rs) + " predicted" +
                       (rs == Regime::kCreep ? " (no oscillation)" : ""));
    return;
  }
  if (m.regime != Regime::kCreep && s.regime != Regime::kCreep) {
    const double fd = s.drop_median / m.drop_median, fr = s.rate / m.rate;
    if (fd > kAdequateFactor || fd < 1 / kAdequateFactor)
      missing->push_back(at + fmt("drop size off by a factor %.2f (%.3g N predicted, %.3g N measured)", fd,
                                  s.drop_median, m.drop_median));
    if (fr > kAdequateFactor || fr < 1 / kAdequateFactor)
      missing->push_back(at + fmt("drop rate off by a factor %.2f (%.3g /s predicted, %.3g /s measured)",
                                  fr, s.rate, m.rate));
  }
  // In per cent of the larger of the window's mean and the run's level (a vibrating stage's mean
  // may nearly vanish).
  const double dm = (s.mean - m.mean) / std::max(std::fabs(m.mean), std::fabs(run_level));
  if (std::fabs(dm) > kAdequateMean)
    missing->push_back(at + fmt("mean level off by %+.0f %% of the level (%.4g N predicted, %.4g N measured)",
                                100 * dm, s.mean, m.mean));
}

double run_level(const std::vector<StatsComparison>& cmp, const std::string& run) {
  double level = 0;
  for (const StatsComparison& c : cmp)
    if (c.run == run && !c.held && std::isfinite(c.measured.mean))
      level = std::max(level, std::fabs(c.measured.mean));
  return level;
}

bool clear_regime(const SlipStats& s, const StatsSpec& spec, Regime* regime) {
  *regime = s.regime;
  if (s.drops == 0) return true;
  return s.drops >= 2 * kMinDrops && s.drop_median >= kClearThresholds * spec.threshold;
}

std::vector<StatsComparison> compare_stats(const Problem& P, const Evaluation& base,
                                           const Evaluation* ext) {
  std::vector<StatsComparison> out;
  for (std::size_t k = 0; k < P.runs.size(); ++k) {
    const RunData& r = P.runs[k];
    for (std::size_t j = 0; j < r.rec.windows.size(); ++j) {
      const WindowStats& w = r.rec.windows[j];
      if (k >= base.stats.size() || j >= base.stats[k].size()) continue;
      StatsComparison c;
      c.run = r.name;
      c.stage = w.stage;
      c.held = w.held;
      c.measured = w.stats;
      c.base = base.stats[k][j];
      const bool have_ext = ext && k < ext->stats.size() && j < ext->stats[k].size();
      c.extended = have_ext ? ext->stats[k][j] : c.base;
      c.score_base = score_of(c.measured, c.base, w.spec);
      c.score_extended = score_of(c.measured, c.extended, w.spec);
      out.push_back(c);
    }
  }
  return out;
}

double noise_floor(const Problem& P) {
  double s2 = 0;
  for (const RunData& r : P.runs) s2 += r.rec.noise.sigma * r.rec.noise.sigma;
  return P.runs.empty() ? kNaN : std::sqrt(s2 / static_cast<double>(P.runs.size()));
}

double noise_inflation(const Problem& P) {
  double rho = 0;
  for (const RunData& r : P.runs) rho += r.rec.noise.rho;
  rho = P.runs.empty() ? 0.0 : std::clamp(rho / static_cast<double>(P.runs.size()), 0.0, 0.99);
  return (1 + rho) / (1 - rho);
}

double gain_over_noise(double rmse_base, double rmse_ext, double sigma, std::size_t n_held, double inflation) {
  const double s2 = sigma * sigma, excess0 = rmse_base * rmse_base - s2;
  const double n_eff = static_cast<double>(n_held) / std::max(inflation, 1.0);
  if (!(std::isfinite(excess0) && std::isfinite(rmse_ext)) || n_eff < 1 || excess0 <= 3.0 * s2 * std::sqrt(2.0 / n_eff))
    return 0.0;
  return 1.0 - std::sqrt(std::max(rmse_ext * rmse_ext - s2, 0.0) / excess0);
}

Adequacy judge_adequacy(const Problem& P, const BaseFit& base, const std::vector<StatsComparison>& cmp) {
  Adequacy a;
  a.noise_floor = noise_floor(P);
  // A constant per run: its fitted samples' mean, scored on its held-out samples.
  double sse = 0;
  std::size_t n = 0;
  for (const RunData& r : P.runs) {
    double s = 0;
    std::size_t m = 0;
    for (std::size_t i = 0; i < r.y.size(); ++i)
      if (r.role[i] == kFit) s += r.y[i], ++m;
    if (m == 0) continue;
    const double c = s / static_cast<double>(m);
    for (std::size_t i = 0; i < r.y.size(); ++i)
      if (r.role[i] == kHeld) sse += (r.y[i] - c) * (r.y[i] - c), ++n;
  }
  a.rmse_constant_heldout = rms(sse, n);
  a.rmse_base_heldout = base.cal.rmse_heldout;
  double sf, sh;
  std::size_t nf, nh;
  constant_stats_score(P, &sf, &nf, &sh, &nh);
  a.score_constant_heldout = rms(sh, nh);
  a.score_base_heldout = base.cal.score_heldout;
  if (!P.stats && a.rmse_base_heldout >= a.rmse_constant_heldout)
    a.missing.push_back(fmt("predicts the held-out samples worse than a constant per run (RMSE %.3g N "
                            "against %.3g N)", a.rmse_base_heldout, a.rmse_constant_heldout));
  if (!(a.score_base_heldout < a.score_constant_heldout))
    a.missing.push_back(fmt("predicts the held-out statistics no better than no stick-slip (score %.3g "
                            "against %.3g)", a.score_base_heldout, a.score_constant_heldout));
  for (const StatsComparison& c : cmp) {
    if (c.held) continue;  // the fitted part: what the base was made to reproduce
    for (const RunData& r : P.runs)
      if (r.name == c.run)
        for (const WindowStats& w : r.rec.windows)
          if (w.stage == c.stage && w.held == c.held)
            judge_window(c, w.spec, run_level(cmp, c.run), &a.missing);
  }
  a.verdict = a.missing.empty() ? "adequate" : "inadequate";
  return a;
}

namespace {

/// The best usable base among those with ok(i) true; -1: none.
template <class Ok>
int lowest(const std::vector<BaseChoice>& c, Ok ok) {
  int best = -1;
  for (std::size_t i = 0; i < c.size(); ++i)
    if (std::isfinite(c[i].heldout) && ok(c[i]) && (best < 0 || c[i].heldout < c[static_cast<std::size_t>(best)].heldout))
      best = static_cast<int>(i);
  return best;
}

/// "lugre (held-out RMSE 0.0312 N)".
std::string held_text(const BaseChoice& b, bool stats) {
  return b.model + (stats ? fmt(" (held-out score %.4g)", b.heldout) : fmt(" (held-out RMSE %.4g N)", b.heldout));
}

}  // namespace

int pick_base(const std::vector<BaseChoice>& c, bool candidates_asked, bool stats, std::string* note) {
  note->clear();
  const auto any = [](const BaseChoice&) { return true; };
  const auto adequate = [](const BaseChoice& b) { return b.adequate; };
  const int top = lowest(c, any);
  if (top < 0) return -1;
  const int top_adequate = lowest(c, adequate);
  const int best = top_adequate >= 0 ? top_adequate : top;
  const BaseChoice& b = c[static_cast<std::size_t>(best)];
  if (best != top)
    *note = held_text(c[static_cast<std::size_t>(top)], stats) + " fits best but is inadequate (" +
            c[static_cast<std::size_t>(top)].first_miss + "); the base is the best adequate model, " +
            held_text(b, stats);
  if (!candidates_asked || b.effects) return best;
  const std::string pre = best == top ? held_text(b, stats) + " fits best but takes no catalogue effect"
                                      : *note + ", which takes no catalogue effect";
  const int u = lowest(c, [](const BaseChoice& x) { return x.adequate && x.effects; });
  if (u >= 0) {
    *note = pre + "; the candidates are tested on the best base that does, " + held_text(c[static_cast<std::size_t>(u)], stats);
    return u;
  }
  const int e = lowest(c, [](const BaseChoice& x) { return x.effects; });
  *note = pre + (e < 0 ? ", and no calibrated base that does: no candidate is tested"
                       : "; the best that does, " + held_text(c[static_cast<std::size_t>(e)], stats) +
                             ", is inadequate");
  return best;
}

int pick_carrier(const std::vector<BaseChoice>& c, int base) {
  if (base >= 0 && static_cast<std::size_t>(base) < c.size() && c[static_cast<std::size_t>(base)].effects &&
      std::isfinite(c[static_cast<std::size_t>(base)].heldout))
    return base;
  int best = -1;
  for (std::size_t i = 0; i < c.size(); ++i)
    if (c[i].effects && std::isfinite(c[i].heldout) && std::isfinite(c[i].stats_score) &&
        (best < 0 || c[i].stats_score < c[static_cast<std::size_t>(best)].stats_score))
      best = static_cast<int>(i);
  return best;
}

}  // namespace stickslip::diagnosis::detail
