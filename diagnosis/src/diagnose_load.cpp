#include "stickslip/diagnosis/detail/diagnose_load.h"

#include <cmath>
#include <limits>

namespace stickslip::diagnosis::detail {

bool is_load_component(std::string_view name) {
  return name == kLoadInPhase || name == kLoadQuadrature;
}

void apply_load_components(engine::SimConfig& c, double eta_v, double eta_q) {
  engine::set_parameter(c, "load_eta", std::hypot(eta_v, eta_q));
  engine::set_parameter(c, "load_phi", std::atan2(eta_v, eta_q));
}

std::vector<ParamEstimate> derived_load_estimates(double eta_v, double eta_q,
                                                  const std::vector<double>& cov) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double eta = std::hypot(eta_v, eta_q), phi = std::atan2(eta_v, eta_q);
  double se_eta = nan, se_phi = nan;
  if (cov.size() == 4 && eta > 0) {
    // Gradients: d eta = (v dv + q dq) / eta; d phi = (q dv - v dq) / eta^2.
    const double ge[2] = {eta_v / eta, eta_q / eta};
    const double gp[2] = {eta_q / (eta * eta), -eta_v / (eta * eta)};
    auto quad = [&](const double* g) {
      return g[0] * g[0] * cov[0] + 2 * g[0] * g[1] * cov[1] + g[1] * g[1] * cov[3];
    };
    const double ve = quad(ge), vp = quad(gp);
    if (std::isfinite(ve) && ve >= 0) se_eta = std::sqrt(ve);
    if (std::isfinite(vp) && vp >= 0) se_phi = std::sqrt(vp);
  }
  return {{"load_eta", eta, se_eta}, {"load_phi", phi, se_phi}};
}

void append_load_estimates(const std::vector<double>& theta, std::size_t nb,
                           const std::vector<double>& cov, std::vector<ParamEstimate>* params) {
  if (theta.size() != nb + 2) return;
  const std::size_t k = theta.size();
  std::vector<double> c2;
  if (cov.size() == k * k)
    c2 = {cov[nb * k + nb], cov[nb * k + nb + 1], cov[(nb + 1) * k + nb], cov[(nb + 1) * k + nb + 1]};
  for (auto& e : derived_load_estimates(theta[nb], theta[nb + 1], c2)) params->push_back(e);
}

}  // namespace stickslip::diagnosis::detail
