// Waviness starting values from the measured stick-slip peaks against position (diagnose_starts.h).
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "stickslip/diagnosis/detail/diagnose_starts.h"

namespace stickslip::diagnosis::detail {

std::vector<std::vector<double>> waviness_peak_starts(const Problem& p, double offset,
                                                      const std::vector<ParamSpec>& wave_specs,
                                                      int n_starts) {
  std::vector<std::vector<double>> out;
  if (wave_specs.size() != 3) return out;
  // (x_k, P_k) of every measured slip: while stuck x is constant and F_d = k_d (v_d t - x), so
  // the stick position is x_k = v_d t_k - (P_k - offset) / k_d at the slip time t_k.
  std::vector<double> xs, ps;
  for (const RunData& r : p.runs)
    for (std::size_t w = 0; w < r.features.P.size(); ++w)
      for (std::size_t k = 0; k < r.features.P[w].size(); ++k) {
        const double P = r.features.P[w][k] - offset;
        xs.push_back(r.cond.vd * r.features.t[w][k] - P / r.cond.kd);
        ps.push_back(P);
      }
  const auto n = static_cast<Eigen::Index>(xs.size());
  {  // 3 coefficients need clearly more than 3 distinct stick positions (runs with the same
     // still stage repeat the same positions)
    std::vector<double> sx = xs;
    std::sort(sx.begin(), sx.end());
    int distinct = sx.empty() ? 0 : 1;
    for (std::size_t i = 1; i < sx.size(); ++i) distinct += sx[i] - sx[i - 1] > 2e-5;
    if (distinct < 5) return out;
  }
  const double xmin = *std::min_element(xs.begin(), xs.end());
  const double X = *std::max_element(xs.begin(), xs.end()) - xmin;
  if (!(X > 0)) return out;
  double mean = 0, sst = 0;
  for (double v : ps) mean += v / static_cast<double>(n);
  for (double v : ps) sst += (v - mean) * (v - mean);
  const double lam_lo = std::max(wave_specs[1].lo, 2.0 * X / static_cast<double>(n));
  const double lam_hi = std::min(wave_specs[1].hi, 2.0 * X);
  if (!(lam_hi > lam_lo)) return out;
  std::vector<double> lam, drop, eps, phi;
  for (double nu = 1.0 / lam_hi; nu <= 1.0 / lam_lo + 1e-12; nu += 1.0 / (8.0 * X)) {
    Eigen::MatrixXd A(n, 3);
    Eigen::VectorXd y(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      const double ph = 2.0 * M_PI * nu * xs[static_cast<std::size_t>(i)];
      A(i, 0) = 1.0;
      A(i, 1) = std::sin(ph);
      A(i, 2) = std::cos(ph);
      y(i) = ps[static_cast<std::size_t>(i)];
    }
    // A wavelength at which the stick positions all fall near the same phase (a slip jump that
    // is a multiple of lambda: clean stick-slip repeats nearly the same jump) makes sin / cos
    // nearly constant, collinear with c0; the fit is then meaningless (an unbounded eps).
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(A);
    const auto& sv = svd.singularValues();
    if (!(sv(2) > 0.05 * sv(0))) continue;
    const Eigen::VectorXd c = A.colPivHouseholderQr().solve(y);
    if (!(c(0) > 0)) continue;
    lam.push_back(1.0 / nu);
    drop.push_back(sst - (A * c - y).squaredNorm());
    // P = c0 (1 + eps sin(2 pi x / lambda + phi)): a sin + b cos = eps c0 sin(. + phi).
    eps.push_back(std::hypot(c(1), c(2)) / c(0));
    phi.push_back(std::atan2(c(2), c(1)));
  }
  std::vector<std::size_t> peaks;
  for (std::size_t i = 0; i < lam.size(); ++i) {
    const bool left = i == 0 || drop[i] >= drop[i - 1];
    const bool right = i + 1 == lam.size() || drop[i] >= drop[i + 1];
    if (left && right && drop[i] > 0) peaks.push_back(i);
  }
  std::sort(peaks.begin(), peaks.end(), [&](std::size_t a, std::size_t b) { return drop[a] > drop[b]; });
  if (peaks.size() > static_cast<std::size_t>(std::max(n_starts, 0))) peaks.resize(static_cast<std::size_t>(std::max(n_starts, 0)));
  for (std::size_t i : peaks)
    out.push_back({std::clamp(eps[i], 0.003, 0.25), lam[i], phi[i]});
  return out;
}

}  // namespace stickslip::diagnosis::detail
