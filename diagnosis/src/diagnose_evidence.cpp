// The evidence in a model's residuals (diagnose_evidence.h).
#include "stickslip/diagnosis/detail/diagnose_evidence.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace stickslip::diagnosis::detail {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kSlidingSpeed = 1e-4;  ///< |x'| above this counts as sliding [m/s]
constexpr int kScanPoints = 240;        ///< periods per sine scan
constexpr int kProfileBins = 20;        ///< bins per residual profile

double corr(const std::vector<double>& a, const std::vector<double>& b) {
  const double n = static_cast<double>(a.size());
  if (a.size() < 3) return 0;
  const double ma = std::accumulate(a.begin(), a.end(), 0.0) / n;
  const double mb = std::accumulate(b.begin(), b.end(), 0.0) / n;
  double sab = 0, saa = 0, sbb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  return saa > 0 && sbb > 0 ? sab / std::sqrt(saa * sbb) : 0.0;
}

/// Mean residual per run and stage, run-major, and the stage's v_a (0 for a still first stage).
void stage_means(const Problem& p, const Evaluation& e, std::vector<double>* mean,
                 std::vector<double>* va) {
  for (std::size_t k = 0; k < p.runs.size(); ++k) {
    const RunData& r = p.runs[k];
    const RunSim& s = e.sims[k];
    for (std::size_t j = 0; j < r.stage_start.size(); ++j) {
      double sum = 0;
      int n = 0;
      for (std::size_t i = 0; i < s.F.size(); ++i)
        if (r.stage[i] == static_cast<int>(j)) {
          sum += r.y[i] - s.F[i] - e.offset;
          ++n;
        }
      mean->push_back(n ? sum / n : kNaN);
      if (va) va->push_back(j == 0 && r.stage_start.size() > 1 ? 0.0 : r.cond.va);
    }
  }
}

/// The time scan's grid: from 2.5 sample spacings (just above the Nyquist period of the
/// decimated samples) up to half the longest run, at most a ratio of 1e4.
void time_grid(const Problem& p, double* lo, double* ratio) {
  double dt = std::numeric_limits<double>::infinity(), span = 0;
  for (const RunData& r : p.runs) {
    if (r.t.size() < 2) continue;
    dt = std::min(dt, (r.t.back() - r.t.front()) / static_cast<double>(r.t.size() - 1));
    span = std::max(span, r.t.back() - r.t.front());
  }
  *lo = std::isfinite(dt) ? 2.5 * dt : 1e-2;
  *ratio = std::clamp(0.5 * span / *lo, 2.0, 1e4);
}

/// Equal-count bins of var over the samples with keep[i]: mean var, mean residual of each model.
ResidualProfile profile(std::string name, const std::vector<double>& var,
                        const std::vector<double>& res_base, const std::vector<double>* res_ext,
                        const std::vector<bool>& keep) {
  ResidualProfile out;
  out.variable = std::move(name);
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < var.size(); ++i)
    if (keep[i]) idx.push_back(i);
  if (idx.size() < static_cast<std::size_t>(2 * kProfileBins)) return out;
  std::sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) { return var[a] < var[b]; });
  for (int b = 0; b < kProfileBins; ++b) {
    const std::size_t from = idx.size() * b / kProfileBins, to = idx.size() * (b + 1) / kProfileBins;
    double sv = 0, sb = 0, se = 0;
    for (std::size_t j = from; j < to; ++j) {
      sv += var[idx[j]];
      sb += res_base[idx[j]];
      if (res_ext) se += (*res_ext)[idx[j]];
    }
    const double n = static_cast<double>(to - from);
    out.center.push_back(sv / n);
    out.base.push_back(sb / n);
    out.extended.push_back(res_ext ? se / n : kNaN);
    out.count.push_back(static_cast<int>(to - from));
  }
  return out;
}

}  // namespace

ResidualColumns residual_columns(const Problem& p, const Evaluation& e) {
  ResidualColumns c;
  for (std::size_t k = 0; k < p.runs.size(); ++k) {
    const RunData& r = p.runs[k];
    const RunSim& s = e.sims[k];
    double last_slide = 0;
    for (std::size_t i = 0; i < s.F.size(); ++i) {
      if (std::fabs(s.v[i]) > kSlidingSpeed) last_slide = r.t[i];
      c.t.push_back(r.t[i]);
      c.res.push_back(r.y[i] - s.F[i] - e.offset);
      c.x.push_back(s.x[i]);
      c.v.push_back(s.v[i]);
      c.stick.push_back(r.t[i] - last_slide);
    }
  }
  return c;
}

SineScan sine_scan(const std::vector<double>& res, const std::vector<double>& coord, double lo,
                   double ratio, int n) {
  SineScan w;
  for (int i = 0; i < n; ++i) {
    const double lam = lo * std::pow(ratio, i / (n - 1.0));
    double ss = 0, sc = 0, s2 = 0, c2 = 0, sc2 = 0;
    for (std::size_t j = 0; j < res.size(); ++j) {
      const double ph = 2 * M_PI * coord[j] / lam, s = std::sin(ph), c = std::cos(ph);
      ss += res[j] * s;
      sc += res[j] * c;
      s2 += s * s;
      c2 += c * c;
      sc2 += s * c;
    }
    const double det = s2 * c2 - sc2 * sc2;
    double a = 0, b = 0;  // res ~ a sin + b cos
    // sin and cos nearly collinear (a period at the sampling's Nyquist limit, where the sine
    // vanishes at every sample): no amplitude.
    const double nn = static_cast<double>(res.size());
    if (det > 1e-9 * nn * nn) {
      a = (ss * c2 - sc * sc2) / det;
      b = (sc * s2 - ss * sc2) / det;
    }
    w.period.push_back(lam);
    w.amplitude.push_back(std::hypot(a, b));
    w.phase.push_back(std::atan2(b, a));
  }
  return w;
}

std::size_t scan_peak(const SineScan& s, double* power_over_median) {
  std::size_t imax = 0;
  for (std::size_t i = 0; i < s.amplitude.size(); ++i)
    if (s.amplitude[i] > s.amplitude[imax]) imax = i;
  std::vector<double> pw;
  for (double a : s.amplitude) pw.push_back(a * a);
  *power_over_median = 0;
  if (pw.empty()) return 0;
  std::nth_element(pw.begin(), pw.begin() + pw.size() / 2, pw.end());
  const double med = pw[pw.size() / 2];
  *power_over_median = med > 0 ? s.amplitude[imax] * s.amplitude[imax] / med : 0;
  return imax;
}

double lag1(const Problem& p, const Evaluation& e) {
  double num = 0, den = 0;
  for (std::size_t k = 0; k < p.runs.size(); ++k) {
    const RunData& r = p.runs[k];
    double prev = 0;
    bool have = false;
    for (std::size_t i = 0; i < e.sims[k].F.size(); ++i) {
      if (r.role[i] != kFit) {
        have = false;
        continue;
      }
      const double res = r.y[i] - e.sims[k].F[i] - e.offset;
      den += res * res;
      if (have) num += res * prev;
      prev = res;
      have = true;
    }
  }
  return den > 0 ? std::clamp(num / den, 0.0, 0.99) : 0.0;
}

Evidence base_evidence(const Problem& p, const Evaluation& e, std::size_t n_fit, SineScan* x_scan) {
  Evidence ev;
  const ResidualColumns c = residual_columns(p, e);
  stage_means(p, e, &ev.stage_mean_residual, &ev.stage_va);
  double ss = 0;
  for (double r : c.res) ss += r * r;
  ev.residual_rms = c.res.empty() ? kNaN : std::sqrt(ss / static_cast<double>(c.res.size()));
  ev.rho = lag1(p, e);
  ev.n = static_cast<double>(n_fit);
  ev.n_eff = std::max(ev.n * (1 - ev.rho) / (1 + ev.rho), 10.0);
  ev.corr_velocity = corr(c.res, c.v);
  ev.corr_position = corr(c.res, c.x);
  ev.corr_stick_time = corr(c.res, c.stick);
  if (!c.x.empty()) {
    const double mx = std::accumulate(c.x.begin(), c.x.end(), 0.0) / c.x.size();
    double sxy = 0, sxx = 0;
    for (std::size_t i = 0; i < c.x.size(); ++i) {
      sxy += (c.x[i] - mx) * c.res[i];
      sxx += (c.x[i] - mx) * (c.x[i] - mx);
    }
    ev.trend_per_m = sxx > 0 ? sxy / sxx : 0;
  }
  // Wavelengths 0.2 to 20 mm: the waviness candidate's bounds (extension_specs).
  *x_scan = sine_scan(c.res, c.x, 2e-4, 100.0, kScanPoints);
  const std::size_t ix = scan_peak(*x_scan, &ev.wavelength_ratio);
  ev.wavelength = x_scan->period[ix];
  ev.wavelength_amplitude = x_scan->amplitude[ix];
  ev.wavelength_phase = x_scan->phase[ix];
  return ev;
}

void add_residual_views(const Problem& p, const Evaluation& base, const Evaluation* ext,
                        Evidence* ev) {
  const ResidualColumns b = residual_columns(p, base);
  ResidualColumns x;
  if (ext) x = residual_columns(p, *ext);
  const std::vector<double>* xres = ext && x.res.size() == b.res.size() ? &x.res : nullptr;

  std::vector<bool> all(b.res.size(), true), sliding(b.res.size());
  for (std::size_t i = 0; i < b.v.size(); ++i) sliding[i] = std::fabs(b.v[i]) > kSlidingSpeed;
  ev->profiles = {profile("velocity", b.v, b.res, xres, sliding),
                  profile("stick_time", b.stick, b.res, xres, all),
                  profile("position", b.x, b.res, xres, all)};

  // Spectra on the base model's coordinates (the measured samples' x and t under the base).
  auto spectrum = [&](const std::vector<double>& coord, double lo, double ratio) {
    ResidualSpectrum s;
    const SineScan sb = sine_scan(b.res, coord, lo, ratio, kScanPoints);
    s.period = sb.period;
    s.base = sb.amplitude;
    if (xres) s.extended = sine_scan(*xres, coord, lo, ratio, kScanPoints).amplitude;
    return s;
  };
  ev->x_spectrum = spectrum(b.x, 2e-4, 100.0);
  double lo = 0, ratio = 0;
  time_grid(p, &lo, &ratio);
  ev->t_spectrum = spectrum(b.t, lo, ratio);
  SineScan tb{ev->t_spectrum.period, ev->t_spectrum.base, {}};
  const std::size_t it = scan_peak(tb, &ev->frequency_ratio);
  ev->frequency = 1.0 / tb.period[it];
  ev->frequency_amplitude = tb.amplitude[it];

  ev->stage_mean_residual_extended.clear();
  if (ext && xres) stage_means(p, *ext, &ev->stage_mean_residual_extended, nullptr);
}

}  // namespace stickslip::diagnosis::detail
