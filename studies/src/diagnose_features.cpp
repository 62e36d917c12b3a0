#include "diagnose_features.h"

#include <algorithm>
#include <cmath>

namespace stickslip::studies::diag {

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

double ramp_mean(const std::vector<double>& t, const std::vector<double>& F, double tk, double a,
                 double b, double rise, bool* ok) {
  double s = 0;
  int n = 0;
  auto it = std::lower_bound(t.begin(), t.end(), tk + a);
  for (std::size_t i = static_cast<std::size_t>(it - t.begin()); i < t.size() && t[i] <= tk + b; ++i) {
    s += F[i] - rise * (t[i] - tk);
    ++n;
  }
  *ok = n >= 3;
  return n ? s / n : 0.0;
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
      double s1 = 0, s2 = 0;
      int n = 0;
      for (std::size_t i = i0; i < t.size() && t[i] <= w.t1; ++i) {
        s1 += F[i];
        s2 += F[i] * F[i];
        ++n;
      }
      const double mu = n ? s1 / n : 0.0;
      f.mean.push_back(mu);
      f.sd.push_back(n ? std::sqrt(std::max(0.0, s2 / n - mu * mu)) : 0.0);
    }
    if (!w.cycles) {
      for (double b = w.t0; b + 0.25 <= w.t1 + 1e-9; b += 0.25) {
        double s = 0;
        int n = 0;
        for (std::size_t i = i0; i < t.size() && t[i] < b + 0.25; ++i)
          if (t[i] >= b) { s += F[i]; ++n; }
        f.blocks.back().push_back(n ? s / n : 0.0);
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

}  // namespace stickslip::studies::diag
