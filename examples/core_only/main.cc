// The core libraries without any file: a hexacopter described in code (vehicle), its static
// alignment by the ESKF from level IMU and compass samples (nav), and the hover command of the
// cascaded controller mixed onto its six rotors (control).
// Exit 0 when the estimate is level with the compass' heading and the rotors share the weight.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "hexsim/control/controller.h"
#include "hexsim/control/mixer.h"
#include "hexsim/nav/estimator.h"
#include "hexsim/vehicle/vehicle_params.h"

int main() {
  namespace vehicle = hexsim::vehicle;
  namespace control = hexsim::control;
  namespace nav = hexsim::nav;
  constexpr double kPi = 3.14159265358979323846, kG_mps2 = 9.80665;
  vehicle::VehicleParams hex;
  hex.mass_kg = 2.0;
  std::vector<control::RotorGeometry> geometry;
  for (int i = 0; i < 6; ++i) {  // arms every 60 deg, 0.25 m, alternating spin
    vehicle::RotorParams r;
    r.position_B_m = 0.25 * Eigen::Vector3d(std::cos(i * kPi / 3), std::sin(i * kPi / 3), 0.0);
    r.spin = i % 2 == 0 ? 1 : -1;
    r.k_T_Nprps2 = 1.0e-5;
    r.k_Q_Nmprps2 = 1.6e-7;
    hex.rotors.push_back(r);
    geometry.push_back({r.position_B_m, r.axis_B, r.spin, r.k_Q_Nmprps2 / r.k_T_Nprps2});
  }
  // Static alignment: at rest, the accelerometer reads -g along down and the compass the field.
  nav::NavParams np;
  np.earth.B_N_uT = Eigen::Vector3d(25.0, -4.0, 45.0);
  auto eskf = nav::MakeEstimator("eskf", np);
  if (!eskf.ok()) return 1;
  nav::NavEstimate start;
  start.healthy = false;
  (*eskf)->Reset(start);
  for (int k = 1; k <= 2000; ++k) {  // 2 s of 1 kHz IMU, compass at 100 Hz
    const double t_s = k * 1e-3;
    (*eskf)->PredictImu({t_s, Eigen::Vector3d::Zero(), Eigen::Vector3d(0.0, 0.0, -kG_mps2)});
    if (k % 10 == 0) (*eskf)->FuseMag({t_s, np.earth.B_N_uT});
  }
  const nav::NavEstimate e = (*eskf)->Estimate();
  const double tilt_rad = std::acos(std::clamp((e.q_NB * Eigen::Vector3d::UnitZ()).z(), -1.0, 1.0));
  // Hover at the estimate: the collective thrust is the weight, shared by the six rotors.
  control::CascadedController controller(control::ControllerParams{}, {hex.mass_kg, hex.inertia_kgm2});
  control::NavState state;
  state.q_NB = e.q_NB;
  control::Setpoint sp;
  sp.yaw_rad = std::atan2(2 * (e.q_NB.w() * e.q_NB.z() + e.q_NB.x() * e.q_NB.y()),
                          1 - 2 * (e.q_NB.y() * e.q_NB.y() + e.q_NB.z() * e.q_NB.z()));
  const control::ControlOutput u = controller.Update(state, sp, 1e-3);
  auto mixer = control::Mixer::Create(geometry);
  if (!mixer.ok()) return 1;
  const control::MixResult mix = mixer->Mix(u.thrust_N, u.torque_B_Nm, 20.0);
  const double weight_N = hex.mass_kg * kG_mps2, share_N = weight_N / 6.0;
  std::printf("aligned: healthy %d, tilt %.2e rad; hover %.3f N of %.3f N, rotor 1 %.3f N\n", e.healthy ? 1 : 0,
              tilt_rad, mix.achieved(0), weight_N, mix.thrust_N(0));
  const bool ok = e.healthy && tilt_rad < 1e-3 && std::abs(mix.achieved(0) - weight_N) < 1e-3 * weight_N &&
                  (mix.thrust_N.array() - share_N).abs().maxCoeff() < 1e-2 * share_N;
  return ok ? 0 : 1;
}
