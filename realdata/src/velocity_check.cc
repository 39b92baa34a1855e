#include "hexsim/realdata/velocity_check.h"

#include <cmath>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "hexsim/common/plausibility.h"
#include "hexsim/common/rotation.h"

namespace hexsim::realdata {
namespace {

constexpr double kSpan_s = 1.0;        // the comparison span
constexpr double kMinSpanShare = 0.8;  // a span shorter than this share of kSpan_s (a gap) is left out
constexpr double kMaxRowGap_s = 0.3;   // rows further apart break a span
constexpr size_t kMinSpans = 10;

}  // namespace

VelocityCheck CheckVelocityAgainstAccel(const logs::FlightLog& log, const std::vector<RowKind>& row_kind) {
  VelocityCheck out;
  for (const char* c : {"q_w", "q_x", "q_y", "q_z", "accel_x_mps2", "accel_y_mps2", "accel_z_mps2", "vel_N_mps",
                        "vel_E_mps", "vel_D_mps"}) {
    if (!log.Has(c)) return out;
  }
  const auto& t = log.Column("t_s");
  const size_t n = std::min(log.rows(), row_kind.size());
  // Per row: NED acceleration from the accelerometer (NaN when not usable) and the velocity.
  std::vector<Eigen::Vector3d> a_N(n), v_N(n);
  std::vector<char> ok(n, 0);
  for (size_t i = 0; i < n; ++i) {
    if (row_kind[i] != RowKind::kFlight) continue;
    const Eigen::Quaterniond q(log.Column("q_w")[i], log.Column("q_x")[i], log.Column("q_y")[i], log.Column("q_z")[i]);
    const Eigen::Vector3d f(log.Column("accel_x_mps2")[i], log.Column("accel_y_mps2")[i], log.Column("accel_z_mps2")[i]);
    v_N[i] = {log.Column("vel_N_mps")[i], log.Column("vel_E_mps")[i], log.Column("vel_D_mps")[i]};
    if (!q.coeffs().allFinite() || !(q.norm() > 0.5) || !f.allFinite() || !v_N[i].allFinite()) continue;
    a_N[i] = q.normalized() * f + Eigen::Vector3d(0, 0, kGravity_mps2);
    ok[i] = 1;
  }
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n;) {
    if (!ok[i]) {
      ++i;
      continue;
    }
    size_t j = i;
    Eigen::Vector3d integral = Eigen::Vector3d::Zero();
    while (j + 1 < n && ok[j + 1] && t[j + 1] - t[j] > 0 && t[j + 1] - t[j] < kMaxRowGap_s && t[j + 1] - t[i] <= kSpan_s + 1e-6) {
      integral += 0.5 * (a_N[j] + a_N[j + 1]) * (t[j + 1] - t[j]);
      ++j;
    }
    const double T = t[j] - t[i];
    if (T >= kMinSpanShare * kSpan_s) {
      const Eigen::Vector3d e = (v_N[j] - v_N[i] - integral) / T;
      sum += e;
      sum2 += e.cwiseAbs2();
      ++out.spans;
    }
    i = j > i ? j : i + 1;
  }
  if (out.spans < kMinSpans) return out;
  out.checked = true;
  const double ns = static_cast<double>(out.spans);
  const char* axis[3] = {"vel_N_mps", "vel_E_mps", "vel_D_mps"};
  int worst = -1;
  for (int a = 0; a < 3; ++a) {
    out.mismatch_mps2[a] = std::sqrt(std::max(0.0, sum2(a) / ns - (sum(a) / ns) * (sum(a) / ns)));
    if (!plausibility::IsPlausible("velocity_accel_mismatch_mps2", out.mismatch_mps2[a]) &&
        (worst < 0 || out.mismatch_mps2[a] > out.mismatch_mps2[worst])) {
      worst = a;
    }
  }
  if (worst >= 0) {
    out.ok = false;
    out.why = fmt::format("logged {} does not follow the accelerometer: its rate of change departs from the measured "
                          "acceleration by {:.2g} m/s^2 RMS over {} 1-s flight spans (N/E/D {:.2g}/{:.2g}/{:.2g}), "
                          "outside {}: the velocity is not a measurement of this aircraft's motion",
                          axis[worst], out.mismatch_mps2[worst], out.spans, out.mismatch_mps2[0], out.mismatch_mps2[1],
                          out.mismatch_mps2[2], plausibility::RangeText("velocity_accel_mismatch_mps2"));
  }
  return out;
}

}  // namespace hexsim::realdata
