#include "stickslip/diagnosis/detail/diagnose_features.h"

#include <algorithm>
#include <cmath>

namespace stickslip::diagnosis::detail {

WindowSpec make_window(const std::vector<double>& t, const std::vector<double>& F, double t0,
                       double t1, bool still) {
  WindowSpec w;
  w.t0 = t0;
  w.t1 = t1;
  std::vector<double> v;
  // Level and peak-to-peak from the second half of the window: the first half may hold the
  // start-up ramp from F_d = 0 or the transient after the vibration is switched on.
  const double tm = 0.5 * (t0 + t1);
  for (std::size_t i = 0; i < t.size(); ++i)
    if (t[i] >= tm && t[i] <= t1) v.push_back(F[i]);
  if (v.size() < 10) return w;
  std::sort(v.begin(), v.end());
  const double lo = v[v.size() / 50], hi = v[v.size() - 1 - v.size() / 50];
  w.peak_to_peak = hi - lo;
  w.level = 0.5 * (hi + lo);
  w.hysteresis = 0.25 * w.peak_to_peak;
  w.cycles = still && w.peak_to_peak >= 1.0;
  return w;
}

namespace {

/// Integrals of F and F^2 over [lo, hi] clipped to [t.front(), t.back()], F linear between
/// samples (the trapezoid rule is exact for the interpolant; F^2 per segment is
/// (f0^2 + f0 f1 + f1^2) / 3 times its length). Every windowed statistic of the features is
/// taken from these rather than from the samples inside the window, so that it is continuous in
/// where the window lies on the samples. With plain sample means, each sample that crosses a
/// window's edge (a slip moving against its ramp window, or the simulated clock shifted to the
/// measured phase against the trace's grid) changed a statistic by a step: 3 mN on the first
/// block after the switch to vibration, where F_d falls from the stick peak (3 x 20 s benchmark).
/// Those steps made the feature objective a staircase on which Levenberg-Marquardt stopped
/// short (docs/diagnose.md, session 7).
struct Moments {
  double len = 0, s1 = 0, s2 = 0;  ///< covered length [s], integrals of F [N s] and F^2 [N^2 s]
  int inside = 0;                  ///< samples inside [lo, hi]
  double mean() const { return s1 / len; }
  double sd() const { return std::sqrt(std::max(0.0, s2 / len - mean() * mean())); }
};

Moments moments(const std::vector<double>& t, const std::vector<double>& F, double lo, double hi) {
  Moments m;
  if (t.size() < 2) return m;
  lo = std::max(lo, t.front());
  hi = std::min(hi, t.back());
  if (!(hi > lo)) return m;
  const auto first = std::upper_bound(t.begin(), t.end(), lo) - t.begin();  // t[first] > lo
  const auto last = std::upper_bound(t.begin(), t.end(), hi) - t.begin();   // t[last] > hi
  m.inside = static_cast<int>(last - first) + (t[static_cast<std::size_t>(first) - 1] == lo);
  auto at = [&](std::size_t i, double s) {  // the interpolant on [t[i], t[i + 1]]
    const double dt = t[i + 1] - t[i];
    return dt > 0 ? F[i] + (F[i + 1] - F[i]) * (s - t[i]) / dt : F[i + 1];
  };
  std::size_t i = static_cast<std::size_t>(first) - 1;  // t[i] <= lo < t[i + 1]
  double s0 = lo, f0 = at(i, lo);
  for (; i + 1 < t.size(); ++i) {
    const double s1 = std::min(t[i + 1], hi);
    const double f1 = s1 == t[i + 1] ? F[i + 1] : at(i, s1);
    m.s1 += 0.5 * (f0 + f1) * (s1 - s0);
    m.s2 += (f0 * f0 + f0 * f1 + f1 * f1) / 3.0 * (s1 - s0);
    if (s1 >= hi) break;
    s0 = s1;
    f0 = f1;
  }
  m.len = hi - lo;
  return m;
}

/// Mean of F(t) - rise (t - tk) over [tk + a, tk + b] (the whole interval within the samples,
/// at least three samples inside).
double ramp_mean(const std::vector<double>& t, const std::vector<double>& F, double tk, double a,
                 double b, double rise, bool* ok) {
  const double lo = tk + a, hi = tk + b;
  const Moments m = moments(t, F, lo, hi);
  *ok = m.inside >= 3 && t.front() <= lo && hi <= t.back();
  return *ok ? m.mean() - rise * (0.5 * (lo + hi) - tk) : 0.0;
}

}  // namespace

Features extract_features(const std::vector<double>& t, const std::vector<double>& F,
                          const std::vector<WindowSpec>& windows, double rise) {
  Features f;
  for (const WindowSpec& w : windows) {
    f.t.emplace_back();
    f.P.emplace_back();
    f.Q.emplace_back();
    f.blocks.emplace_back();
    const auto i0 = static_cast<std::size_t>(std::lower_bound(t.begin(), t.end(), w.t0) - t.begin());
    {
      const Moments m = moments(t, F, w.t0, w.t1);
      f.mean.push_back(m.inside ? m.mean() : 0.0);
      f.sd.push_back(m.inside ? m.sd() : 0.0);
    }
    if (!w.cycles) {
      for (double b = w.t0; b + 0.25 <= w.t1 + 1e-9; b += 0.25) {
        const Moments m = moments(t, F, b, b + 0.25);
        f.blocks.back().push_back(m.inside ? m.mean() : 0.0);
      }
      continue;
    }
    bool high = false, have_state = false;
    std::size_t last_above = i0;  // last sample with F >= level
    for (std::size_t i = i0; i < t.size() && t[i] <= w.t1; ++i) {
      if (F[i] >= w.level) last_above = i;
      if (F[i] > w.level + w.hysteresis) {
        high = true;
        have_state = true;
      } else if (F[i] < w.level - w.hysteresis) {
        if (have_state && high) {
          // Slip: the fall through the level between last_above and last_above + 1.
          const std::size_t j = last_above;
          if (j + 1 < t.size()) {
            const double fa = F[j], fb = F[j + 1];
            const double u = fa > fb ? std::clamp((fa - w.level) / (fa - fb), 0.0, 1.0) : 0.0;
            const double tk = t[j] + u * (t[j + 1] - t[j]);
            if (tk - 0.10 >= w.t0 && tk + 0.12 <= w.t1) {
              bool okp = false, okq = false;
              const double P = ramp_mean(t, F, tk, -0.10, -0.01, rise, &okp);
              const double Q = ramp_mean(t, F, tk, 0.05, 0.12, rise, &okq);
              if (okp && okq) {
                f.t.back().push_back(tk);
                f.P.back().push_back(P);
                f.Q.back().push_back(Q);
              }
            }
          }
        }
        high = false;
        have_state = true;
      }
    }
  }
  return f;
}

void feature_residuals(const Features& m, const Features& s, const std::vector<WindowSpec>& windows,
                       double rise, std::vector<double>* level_terms,
                       std::vector<double>* other_terms) {
  for (std::size_t w = 0; w < windows.size(); ++w) {
    // Fixed length (3 per measured slip + 1 + the measured blocks), so Gauss-Newton can use it.
    level_terms->push_back(m.mean[w] - s.mean[w]);  // twice: weight 2 (offset-consistent)
    level_terms->push_back(m.mean[w] - s.mean[w]);
    other_terms->push_back(2.0 * (m.sd[w] - s.sd[w]));
    const std::size_t nm = m.t[w].size(), ns = s.t[w].size();
    const double pp = windows[w].peak_to_peak;
    for (std::size_t k = 0; k < nm; ++k) {
      if (k < ns) {
        other_terms->push_back(rise * (m.t[w][k] - s.t[w][k]));
        level_terms->push_back(m.P[w][k] - s.P[w][k]);
        level_terms->push_back(m.Q[w][k] - s.Q[w][k]);
      } else {
        other_terms->push_back(pp);
        other_terms->push_back(pp);
        other_terms->push_back(pp);
      }
    }
    other_terms->push_back(ns > nm ? pp * std::sqrt(static_cast<double>(ns - nm)) : 0.0);
    for (std::size_t k = 0; k < m.blocks[w].size(); ++k)
      level_terms->push_back(k < s.blocks[w].size() ? m.blocks[w][k] - s.blocks[w][k] : pp);
  }
}

}  // namespace stickslip::diagnosis::detail
