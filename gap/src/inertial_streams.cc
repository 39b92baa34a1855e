// Gyro and accel channels on the log's native-rate streams (issue 18; CONTRACTS: no stream is
// interpolated). Used when the log carries an `imu` stream; otherwise replay.cc's row-based
// channels run.
//   gyro:  between consecutive attitude samples k, k+1 the IMU rates are integrated, each sample j
//          acting over its own interval (t_{j−1}, t_j] clipped to (t_k, t_{k+1}]:
//            q_gyro = Π_j exp(w_j·Δt_j),   measured = Log(q_gyro)/Δt,   predicted = Log(q_k⁻¹ ⊗ q_{k+1})/Δt
//          so both sides are the mean body rate over the same interval; pairs inside flight windows only.
//   accel: every IMU sample in flight against the thrust model driven by RCOU at its own rate:
//            f_B = (Σ_i k_T·ω_i²·a_i + F_drag(R_NBᵀ·v_N)) / m,
//          ω_i from the configured powertrain stepped through the RCOU samples (each command held
//          until the next, as the ESC sees it) at the latest logged bus voltage; v_N and R_NB are the
//          latest EKF/attitude samples at or before the IMU sample; flight windows only (realdata).
#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "channels.h"
#include "hexsim/common/plausibility.h"
#include "replay_util.h"
#include "hexsim/common/rotation.h"
#include "hexsim/realdata/velocity_check.h"
#include "hexsim/realdata/windows.h"
#include "hexsim/vehicle/powertrain.h"

namespace hexsim::gap::internal {
namespace {

constexpr double kMaxAttitudeGap_s = 0.25;  // attitude pairs further apart are not compared
constexpr double kImuGapFactor = 3.0;       // an IMU interval longer than this × the median breaks coverage
constexpr double kSubstep_s = 0.001;        // powertrain integration step
constexpr double kMaxCommandGap_s = 0.2;    // RCOU gaps longer than this restart the rotors at steady state
constexpr double kMinHeight_m = 0.15;       // CG above the take-off point: clear of the ground

Mat3X Identity3() { return Mat3X(Eigen::Matrix3d::Identity()); }

bool HasFinite(const logs::FlightLog& s, const std::string& c) {
  return s.Has(c) && std::any_of(s.Column(c).begin(), s.Column(c).end(), [](double x) { return std::isfinite(x); });
}

double MedianStep_s(const std::vector<double>& t) {
  std::vector<double> d;
  for (size_t i = 1; i < t.size(); ++i) d.push_back(t[i] - t[i - 1]);
  if (d.empty()) return 0.0;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

// Index of the latest sample at or before `t_s` in ascending `t` (advancing `*i`), or false.
bool Held(const std::vector<double>& t, double t_s, size_t* i) {
  while (*i + 1 < t.size() && t[*i + 1] <= t_s) ++*i;
  return !t.empty() && t[*i] <= t_s;
}

Eigen::Quaterniond RowQuat(const logs::FlightLog& log, size_t r) {
  return Eigen::Quaterniond(log.Column("q_w")[r], log.Column("q_x")[r], log.Column("q_y")[r], log.Column("q_z")[r]);
}

// Shared tail of both channels: bias (unless a nuisance), misalignment, scale, latency; the native
// time stamps leave no sample hold to remove.
void FinishChannel(const std::vector<Vec3>& h, ChannelData* ch) {
  ch->known_hold_s = 0.0;
  ch->known_hold_max_s = 0.0;
  if (!ch->bias_nuisance) {
    Candidate off = MakeCandidate("bias", {"b_x", "b_y", "b_z"}, {1, 1, 1}, ch->unit);
    off.X.assign(ch->t.size(), Identity3());
    ch->candidates.push_back(std::move(off));
  }
  AddAxisCandidates(ch->t, h, ch->unit, ch);
}

}  // namespace

bool ReplayGyroStream(const logs::FlightLog& log, const vehicle::VehicleParams& v,
                      const std::vector<realdata::RowKind>& row_kind, ReplayResult* out) {
  const logs::FlightLog* imu = log.Stream("imu");
  if (imu == nullptr || !HasFinite(*imu, "gyro_x_radps")) return false;
  const auto& ti = imu->Column("t_s");
  const auto &gx = imu->Column("gyro_x_radps"), &gy = imu->Column("gyro_y_radps"), &gz = imu->Column("gyro_z_radps");
  const auto& t = log.Column("t_s");
  const double max_imu_step_s = kImuGapFactor * MedianStep_s(ti);
  ChannelData ch;
  ch.name = "gyro";
  ch.unit = "rad/s";
  ch.bias_nuisance = v.sensors.gyro.noise.bias_std > 0 || v.sensors.gyro.noise.bias_walk_per_sqrt_s > 0;
  std::vector<Vec3> h;
  size_t j = 0;  // first IMU sample with t_j > t_k
  for (size_t k = 0; k + 1 < log.rows(); ++k) {
    const double t0 = t[k], t1 = t[k + 1], dt = t1 - t0;
    const bool flight = row_kind[k] == realdata::RowKind::kFlight && row_kind[k + 1] == realdata::RowKind::kFlight;
    if (!(dt > 0) || dt > kMaxAttitudeGap_s || !flight) continue;
    const Eigen::Quaterniond qa = RowQuat(log, k), qb = RowQuat(log, k + 1);
    if (!qa.coeffs().allFinite() || !qb.coeffs().allFinite()) continue;
    while (j < ti.size() && ti[j] <= t0) ++j;
    // Coverage: a sample before t0 starts the first interval, one at or after t1 ends the last.
    if (j == 0 || j >= ti.size()) continue;
    Eigen::Quaterniond q_gyro = Eigen::Quaterniond::Identity();
    bool ok = true;
    size_t s = j;
    for (; s < ti.size() && ti[s - 1] < t1; ++s) {
      const double a = std::max(ti[s - 1], t0), b = std::min(ti[s], t1);
      const Vec3 w(gx[s], gy[s], gz[s]);
      if (!w.allFinite() || ti[s] - ti[s - 1] > max_imu_step_s) {
        ok = false;
        break;
      }
      q_gyro = q_gyro * QuatExp(w * (b - a));
    }
    if (!ok || s > ti.size() || ti[s - 1] < t1) continue;
    const Vec3 pred = QuatLog(qa.normalized().conjugate() * qb.normalized()) / dt;
    const Vec3 meas = QuatLog(q_gyro) / dt;
    ch.t.push_back(0.5 * (t0 + t1));
    ch.y.emplace_back(meas - pred);
    ch.row.push_back(static_cast<int>(k));
    h.push_back(pred);
  }
  ch.note = fmt::format("native-rate gyro: IMU at {:.0f} Hz integrated between attitude samples",
                        MedianStep_s(ti) > 0 ? 1.0 / MedianStep_s(ti) : 0.0);
  FinishChannel(h, &ch);
  out->channels.push_back(std::move(ch));
  return true;
}

bool ReplayAccelStream(const logs::FlightLog& log, const vehicle::VehicleParams& v,
                       const std::vector<realdata::RowKind>& row_kind, ReplayResult* out) {
  const logs::FlightLog* imu = log.Stream("imu");
  const logs::FlightLog* rcou = log.Stream("rcou");
  const logs::FlightLog* batt = log.Stream("batt");
  if (imu == nullptr || !HasFinite(*imu, "accel_x_mps2")) return false;
  const size_t n_rot = v.rotors.size();
  std::string missing;
  if (rcou == nullptr) missing = "an rcou stream";
  for (size_t m = 0; rcou && m < n_rot; ++m) {
    if (!HasFinite(*rcou, fmt::format("motor_{}_u", m + 1))) missing = fmt::format("motor_{}_u in the rcou stream", m + 1);
  }
  if (batt == nullptr || !HasFinite(*batt, "voltage_V")) missing = "a batt stream with voltage_V";
  if (!HasFinite(log, "vel_N_mps") || !HasFinite(log, "pos_D_m")) missing = "vel_N/E/D_mps and pos_D_m";
  if (n_rot == 0) missing = "rotors in the vehicle";
  if (!missing.empty()) {
    out->not_diagnosed.emplace_back("accel", "thrust model driven by RCOU needs " + missing);
    return true;
  }
  if (const realdata::VelocityCheck vc = realdata::CheckVelocityAgainstAccel(log, row_kind); !vc.ok) {
    out->not_diagnosed.emplace_back("accel", vc.why + " (it drives the drag of the thrust model)");
    return true;
  }
  const auto& ti = imu->Column("t_s");
  const auto &ax = imu->Column("accel_x_mps2"), &ay = imu->Column("accel_y_mps2"), &az = imu->Column("accel_z_mps2");
  const auto& tr = rcou->Column("t_s");
  std::vector<const std::vector<double>*> mu;
  for (size_t m = 0; m < n_rot; ++m) mu.push_back(&rcou->Column(fmt::format("motor_{}_u", m + 1)));
  const auto& tb = batt->Column("t_s");
  // A logged voltage whose median is no battery bus (no power monitor connected) is replaced by the
  // configured battery's open-circuit voltage (as the dynamics channel does), and the note says so.
  const double median_V = MedianFinite(batt->Column("voltage_V"));
  const bool V_usable = plausibility::IsPlausible("bus_voltage_V", median_V);
  const std::vector<double> volt =
      V_usable ? batt->Column("voltage_V")
               : std::vector<double>(batt->rows(), v.battery.OpenCircuitVoltage_V(v.battery.initial_soc));
  const auto& t = log.Column("t_s");
  const auto &vn = log.Column("vel_N_mps"), &ve = log.Column("vel_E_mps"), &vd = log.Column("vel_D_mps");
  const auto& pd = log.Column("pos_D_m");
  double pd0 = std::nan("");
  for (double x : pd) {
    if (std::isfinite(x)) {
      pd0 = x;
      break;
    }
  }

  vehicle::VehicleParams stiff = v;  // the ESCs run at the logged bus voltage
  stiff.battery.internal_resistance_ohm = 0.0;
  stiff.battery.cells_series = 1;
  stiff.battery.ocv_soc = {0.0, 1.0};
  vehicle::PowertrainState ps = vehicle::InitialPowertrainState(stiff);
  std::vector<double> cmd(n_rot, 0.0);
  ChannelData ch;
  ch.name = "accel";
  ch.unit = "m/s^2";
  ch.bias_nuisance = v.sensors.accel.noise.bias_std > 0 || v.sensors.accel.noise.bias_walk_per_sqrt_s > 0;
  std::vector<Vec3> h;
  size_t ir = 0, ib = 0, row = 0;
  double t_state = std::nan("");  // time the rotor state stands at
  const double m_kg = v.mass_kg + v.payload.mass_kg;
  for (size_t k = 0; k < ti.size(); ++k) {
    const double tk = ti[k];
    const size_t ir_prev = ir;
    if (!Held(tr, tk, &ir) || !Held(tb, tk, &ib) || !Held(t, tk, &row) || !(volt[ib] > 0)) continue;
    // Step the rotors from t_state to tk through every RCOU sample in between (each held).
    bool restart = !std::isfinite(t_state) || tk - t_state > kMaxCommandGap_s;
    for (size_t r = ir_prev; !restart && r <= ir; ++r) {
      const double a = std::max(t_state, tr[r]), b = r + 1 <= ir ? tr[r + 1] : tk;
      if (b <= a) continue;
      for (size_t m = 0; m < n_rot; ++m) cmd[m] = (*mu[m])[r];
      if (!std::all_of(cmd.begin(), cmd.end(), [](double x) { return std::isfinite(x); })) {
        restart = true;
        break;
      }
      stiff.battery.ocv_cell_V = {volt[ib], volt[ib]};
      const int sub = std::max(1, static_cast<int>(std::ceil((b - a) / kSubstep_s - 1e-9)));
      for (int s = 0; s < sub; ++s) vehicle::StepPowertrain(stiff, cmd, (b - a) / sub, &ps);
    }
    t_state = tk;
    bool flying = true;
    for (size_t m = 0; m < n_rot; ++m) {
      cmd[m] = (*mu[m])[ir];
      flying = flying && cmd[m] > 0;
    }
    if (restart) {
      for (size_t m = 0; m < n_rot; ++m) {
        ps.omega_radps[m] = cmd[m] > 0 ? vehicle::SteadyOmega_radps(v, m, v.esc.Duty(cmd[m]) * volt[ib]) : 0.0;
      }
    }
    // Ground contact is not in the model: airborne samples only.
    if (!flying || !(pd0 - pd[row] > kMinHeight_m) || row_kind[row] != realdata::RowKind::kFlight) continue;
    const Vec3 meas(ax[k], ay[k], az[k]);
    const Vec3 vel(vn[row], ve[row], vd[row]);
    const Eigen::Quaterniond q = RowQuat(log, row);
    if (!meas.allFinite() || !vel.allFinite() || !q.coeffs().allFinite()) continue;
    const Eigen::Matrix3d R_BN = q.normalized().toRotationMatrix().transpose();
    const Vec3 vb = R_BN * vel;
    const Vec3 drag = -(v.drag.linear_Nspm.cwiseProduct(vb) +
                        v.drag.quadratic_Ns2pm2.cwiseProduct(vb.cwiseAbs().cwiseProduct(vb)));
    const Vec3 pred = (vehicle::RotorWrench(v, ps.omega_radps).force_B_N + drag) / m_kg;
    ch.t.push_back(tk);
    ch.y.emplace_back(meas - pred);
    ch.row.push_back(static_cast<int>(row));
    h.push_back(pred);
  }
  ch.note = fmt::format("native-rate accel: IMU at {:.0f} Hz against the thrust model driven by RCOU at {:.0f} Hz",
                        MedianStep_s(ti) > 0 ? 1.0 / MedianStep_s(ti) : 0.0,
                        MedianStep_s(tr) > 0 ? 1.0 / MedianStep_s(tr) : 0.0);
  if (!V_usable) {
    ch.note += fmt::format("; logged voltage_V (median {:.3g} V) is outside {}: no power monitor, the configured "
                           "battery's open-circuit voltage is used", median_V, plausibility::RangeText("bus_voltage_V"));
  }
  FinishChannel(h, &ch);
  ch.not_available.emplace_back("rotor_drag, ground_effect, battery_sag, motor_time_constant, wind: see the "
                                "'dynamics' channel");
  out->channels.push_back(std::move(ch));
  return true;
}

}  // namespace hexsim::gap::internal
