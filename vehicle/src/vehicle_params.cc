#include "hexsim/vehicle/vehicle_params.h"

#include <algorithm>

#include "hexsim/common/rotation.h"

namespace hexsim::vehicle {

double MotorParams::Kv_radps_per_V() const { return kv_rpm_per_V * 2.0 * kPi / 60.0; }
double MotorParams::Kt_Nm_per_A() const { return 1.0 / Kv_radps_per_V(); }

double BatteryParams::OpenCircuitVoltage_V(double soc) const {
  HEXSIM_CHECK(ocv_soc.size() >= 2 && ocv_soc.size() == ocv_cell_V.size());
  double cell_V;
  if (soc <= ocv_soc.front()) {
    cell_V = ocv_cell_V.front();
  } else if (soc >= ocv_soc.back()) {
    cell_V = ocv_cell_V.back();
  } else {
    const size_t hi = static_cast<size_t>(std::upper_bound(ocv_soc.begin(), ocv_soc.end(), soc) - ocv_soc.begin());
    const size_t lo = hi - 1;
    const double f = (soc - ocv_soc[lo]) / (ocv_soc[hi] - ocv_soc[lo]);
    cell_V = ocv_cell_V[lo] + f * (ocv_cell_V[hi] - ocv_cell_V[lo]);
  }
  return cell_V * cells_series;
}

}  // namespace hexsim::vehicle
