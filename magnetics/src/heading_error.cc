#include "hexsim/magnetics/heading_error.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "hexsim/common/format.h"
#include "hexsim/common/rotation.h"
#include "hexsim/magnetics/heading.h"

namespace hexsim::magnetics {

Status HeadingErrorOptions::IsValid() const {
  if (min_samples_per_turn < 3) return Status::BadInput("heading error: min_samples_per_turn must be >= 3");
  if (!(max_angle_gap_deg > 0.0 && max_angle_gap_deg <= 180.0)) return Status::BadInput("heading error: max_angle_gap_deg must be in (0, 180]");
  return Status::Ok();
}

double SampleHeadingErrorDeg(const Compensator& compensator, const MagSample& s) {
  const Eigen::Vector3d rpy = EulerFromQuat(s.q_NB);
  const Eigen::Vector3d m = compensator.Correct(s.mag_B_uT, CompensatorInput{s.control_u, s.current_A});
  const double psi_meas = MagneticHeadingRad(m, rpy(0), rpy(1));
  const double psi_true = MagneticHeadingRad(s.earth_B_uT, rpy(0), rpy(1));
  return WrapDeg180((psi_meas - psi_true) * kRadToDeg);
}

Result<std::vector<HeadingErrorRow>> EvaluateHeadingError(const Compensator& compensator,
                                                          const std::vector<MagSample>& samples,
                                                          const HeadingErrorOptions& o) {
  HEXSIM_RETURN_IF_ERROR(o.IsValid());
  std::map<double, std::vector<const MagSample*>> groups;
  for (size_t i = 0; i < samples.size(); ++i) {
    const MagSample& s = samples[i];
    if (s.plane != o.plane) continue;
    if (!s.mag_B_uT.allFinite() || !std::isfinite(s.control_u) || !std::isfinite(s.current_A)) {
      return Status::BadInput(Format("heading error: sample %zu is not finite", i));
    }
    if (!s.earth_B_uT.allFinite() || !(s.earth_B_uT.head<2>().norm() > 0.0)) {
      return Status::BadInput(Format("heading error: sample %zu has no true Earth field (earth_x/y/z_uT columns)", i));
    }
    groups[s.control_u].push_back(&s);
  }
  if (groups.empty()) return Status::BadInput("heading error: no samples in the " + o.plane + " plane");
  std::vector<HeadingErrorRow> rows;
  for (const auto& [u, g] : groups) {
    if (static_cast<int>(g.size()) < o.min_samples_per_turn) {
      return Status::BadInput(Format("heading error: control_u %s: %zu samples in the turn (need at least %d)",
                                     ShortestDouble(u).c_str(), g.size(), o.min_samples_per_turn));
    }
    // Full turn: the largest gap between consecutive table angles (cyclic) is small.
    std::vector<double> ang;
    for (const MagSample* s : g) {
      const double a = std::fmod(s->angle_deg, 360.0);
      ang.push_back(a < 0.0 ? a + 360.0 : a);
    }
    std::sort(ang.begin(), ang.end());
    double gap = 360.0 - ang.back() + ang.front();
    for (size_t i = 1; i < ang.size(); ++i) gap = std::max(gap, ang[i] - ang[i - 1]);
    if (gap > o.max_angle_gap_deg) {
      return Status::BadInput(Format("heading error: control_u %s: not a full turn (gap of %.1f deg between table angles, max %s)",
                                     ShortestDouble(u).c_str(), gap, ShortestDouble(o.max_angle_gap_deg).c_str()));
    }
    HeadingErrorRow row;
    row.control_u = u;
    row.num_samples = static_cast<int>(g.size());
    double ss = 0.0, sum = 0.0, sum_I = 0.0;
    for (const MagSample* s : g) {
      const double e = SampleHeadingErrorDeg(compensator, *s);
      row.max_abs_deg = std::max(row.max_abs_deg, std::abs(e));
      ss += e * e;
      sum += e;
      sum_I += s->current_A;
    }
    const double n = static_cast<double>(g.size());
    row.rms_deg = std::sqrt(ss / n);
    row.mean_deg = sum / n;
    row.mean_current_A = sum_I / n;
    rows.push_back(row);
  }
  return rows;
}

}  // namespace hexsim::magnetics
