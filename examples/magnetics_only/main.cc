// A magnetics-only program against the installed package: the WMM field at a place and date, a
// compass reading distorted by hard and soft iron (H = K·B + β), and the compensator that undoes it.
// Exit 0 when the corrected reading is the field again and the field is Earth-sized.
#include <cstdio>

#include "hexsim/magnetics/compensators.h"
#include "hexsim/magnetics/wmm.h"

int main() {
  namespace mag = hexsim::magnetics;
  const auto field = mag::EvaluateWmm(mag::GeodeticPoint{43.88, 125.35, 220.0}, 2026.5);  // Changchun
  if (!field.ok()) {
    std::fprintf(stderr, "WMM: %s\n", field.status().message().c_str());
    return 1;
  }
  // Earth's surface field is 22-67 uT.
  if (!(field->total_uT > 22.0 && field->total_uT < 67.0)) return 1;
  Eigen::Matrix3d K;
  K << 1.05, 0.02, 0.0, 0.02, 0.97, 0.01, 0.0, 0.01, 1.01;
  const Eigen::Vector3d beta_uT(12.0, -4.0, 7.5);
  const Eigen::Vector3d raw_uT = K * field->B_N_uT + beta_uT;
  const mag::EllipsoidCompensator comp("traditional", K, beta_uT);
  const Eigen::Vector3d corrected_uT = comp.Correct(raw_uT, mag::CompensatorInput{});
  const double error_uT = (corrected_uT - field->B_N_uT).norm();
  std::printf("%s: |B| %.2f uT, declination %.2f deg, corrected to within %.1e uT\n", field->model.c_str(),
              field->total_uT, field->declination_deg, error_uT);
  return error_uT < 1e-9 ? 0 : 1;
}
