#include "support/calib_synth.h"

#include <cmath>

#include "hexsim/common/rotation.h"

namespace hexsim::magnetics::testing {

Eigen::Matrix3d TestSoftIron() {
  Eigen::Matrix3d S;
  S << 1.06, 0.03, -0.02,  //
      0.03, 0.95, 0.04,    //
      -0.02, 0.04, 1.01;
  return S / std::cbrt(S.determinant());
}

Eigen::Quaterniond TableAttitude(const std::string& plane, double angle_deg) {
  const double a = angle_deg * kDegToRad;
  if (plane == "yz") return Eigen::Quaterniond(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()));
  if (plane == "xz") return Eigen::Quaterniond(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()));
  return Eigen::Quaterniond(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()));
}

std::vector<MagSample> Turntable(const SynthRig& rig, RngStream& rng) {
  std::vector<MagSample> out;
  const int steps = static_cast<int>(std::lround(360.0 / rig.angle_step_deg));
  for (double u : rig.controls_u) {
    for (const auto& plane : rig.planes) {
      for (int k = 0; k < steps; ++k) {
        MagSample s;
        s.plane = plane;
        s.control_u = u;
        s.current_A = rig.Current(u);
        s.angle_deg = k * rig.angle_step_deg;
        s.q_NB = TableAttitude(plane, s.angle_deg);
        s.earth_B_uT = s.q_NB.conjugate() * rig.earth_N_uT;
        s.mag_B_uT = rig.soft_iron * s.earth_B_uT + rig.HardIron(u) + rng.Normal3(rig.noise_uT);
        out.push_back(s);
      }
    }
  }
  return out;
}

}  // namespace hexsim::magnetics::testing
