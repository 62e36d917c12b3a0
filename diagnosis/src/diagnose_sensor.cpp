#include "diagnose_sensor.h"

#include <cstddef>

namespace stickslip::diagnosis::detail {

void sensor_profile_starts(const Problem& P, const FitModel& base,
                           const std::vector<double>& base_theta, const DiagnoseOptions& o,
                           const RecordScales& scales, std::vector<std::vector<double>>* starts,
                           std::vector<std::vector<double>>* held_starts, int* evals) {
  const std::size_t nb = base_theta.size();
  std::size_t iv = nb;
  for (std::size_t j = 0; j < nb; ++j)
    if (base.specs[j].name == "v_s") iv = j;
  if (iv == nb) return;  // a base model without a Stribeck velocity
  const double v_s0 = base.specs[iv].init;
  constexpr double kZeta = 0.7;
  for (double tau0 : {1e-3, 3e-3, 1e-2}) {  // [s] at Table 1's scale, half-decade steps
    const double tau = scaled_extension_value("sensor_tau", tau0, scales);
    FitModel hm = base;
    hm.base.extension.kind = engine::ExtensionKind::kSensorDynamics;
    engine::set_parameter(hm.base, "sensor_tau", tau);
    engine::set_parameter(hm.base, "sensor_zeta", kZeta);
    engine::set_parameter(hm.base, "v_s", v_s0);
    hm.specs.erase(hm.specs.begin() + static_cast<std::ptrdiff_t>(iv));
    std::vector<double> h0 = base_theta;
    h0.erase(h0.begin() + static_cast<std::ptrdiff_t>(iv));
    const FitResult hr = fit(P, hm, {h0}, Span::kFeatures, 0, o.max_evals_profile);
    *evals += hr.evals;
    if (!hr.ok) continue;
    std::vector<double> th = hr.theta;
    th.insert(th.begin() + static_cast<std::ptrdiff_t>(iv), v_s0);
    th.push_back(tau);
    th.push_back(kZeta);
    starts->push_back(th);
    held_starts->push_back(th);
  }
}

}  // namespace stickslip::diagnosis::detail
