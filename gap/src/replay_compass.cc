// Compass replay: the configured compass model driven by the log's attitude and currents, on the
// aligned time base of the timing scan, with the nuisance baseline and the candidate effects'
// regressors (CONTRACTS.md "Gap diagnosis", real-data keys).
//
// Timing: a compass sample stamped t measured the field at t − L (L: compass latency against the
// attitude); the current logged at t is the current of t − S (S: its staleness beyond the configured
// vehicle's own throttle-to-current response). The prediction uses the attitude at t − L and the
// aligned current I(t − L + S); the current-driven candidates' regressors come in members, the
// logged current and the current at each shift of the in-flight model's grid (realdata::
// CurrentShiftGrid, bounded by the staleness against the throttle), and the better member wins its
// family (the data decide how much of that staleness the field sees).
// Baseline (always fitted, never a finding by itself): r = β + M·R_NBᵀ·δB_N, a constant offset β in
// the sensor frame and a correction δB_N of the NED Earth field (WMM prior), which also absorbs a
// uniform scale of the sensor.
#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Geometry>
#include <Eigen/LU>

#include "channels.h"
#include "compass_sampler.h"
#include "hexsim/common/plausibility.h"
#include "hexsim/common/rotation.h"
#include "hexsim/magnetics/compass_model.h"
#include "hexsim/magnetics/flight_fit.h"
#include "replay_util.h"

namespace hexsim::gap::internal {

CompassMinimum CompassMinSamples(const ChannelData& ch) {
  int largest = 0;
  std::string which = "none";
  for (const Candidate& k : ch.candidates) {
    if (k.p() > largest) {
      largest = k.p();
      which = k.effect;
    }
  }
  CompassMinimum m;
  m.unknowns = ch.baseline.p() + largest;
  // Training share at the block floor: (G − 2)/G of the samples.
  constexpr int kTrainingBlocks = kMinAnalysisBlocks - 2;
  const int equations = magnetics::kEquationsPerUnknown * m.unknowns * kMinAnalysisBlocks;
  const int per_sample = magnetics::kEquationsPerSample * kTrainingBlocks;
  m.samples = (equations + per_sample - 1) / per_sample;
  m.why = fmt::format("{} unknowns (baseline {} + {} {}), {} equations each, {} per sample, in the CV training set's "
                      "{} of {} blocks",
                      m.unknowns, ch.baseline.p(), which, largest, magnetics::kEquationsPerUnknown,
                      magnetics::kEquationsPerSample, kTrainingBlocks, kMinAnalysisBlocks);
  return m;
}

namespace {

// ArduPilot's per-motor compensation scales each motor's field by output^exp (COMPASS_PMOT_EXP,
// default 0.65).
constexpr double kPerMotorExponent = 0.65;

// Per replayed sample, what the candidates' regressors are built from.
struct CompassRows {
  std::vector<Vec3> h;                     // predicted field before hard iron, sensor frame
  std::vector<Eigen::Matrix3d> Msens, Rt;  // R_SB·scale·K(I), R_NBᵀ
  std::vector<double> I_log, u, temp;
  std::vector<double> t_meas;              // when the field was measured (stamp − latency)
  std::vector<std::vector<double>> mu;     // per-motor outputs
  std::vector<magnetics::Currents> currents;
};

// The configured model at every wanted, locatable compass sample: the channel's residual, times,
// rows, current and throttle, and the rows' regressor inputs.
void SampleCompass(CompassSampler* sampler, const LogInputs& in, const CompassReplayOptions& o, ChannelData* ch,
                   CompassRows* rows) {
  sampler->Begin(o.latency_s, o.current_shift_s, o.LongestMemberShift_s());
  LocatedSample ls;
  for (const CompassSample& s : sampler->samples()) {
    if (o.row_kind && (*o.row_kind)[static_cast<size_t>(s.row)] != o.want) continue;
    if (!sampler->Locate(s, &ls)) continue;
    const Eigen::Matrix3d R_NB = ls.q.toRotationMatrix();
    const CompassSampler::Prediction p = sampler->Predict(s, ls, R_NB);
    double thr = std::nan("");
    std::vector<double> motors;
    if (!o.baseline_only) {
      for (auto* m : in.motor_u) motors.push_back(Lerp(*m, ls.i, ls.w));
    }
    if (in.control_u) {
      thr = Lerp(*in.control_u, ls.i, ls.w) / kThrottleFullScale;
    } else if (!in.motor_u.empty()) {
      thr = 0;
      for (auto* m : in.motor_u) thr += Lerp(*m, ls.i, ls.w) / static_cast<double>(in.motor_u.size());
    }
    ch->t.push_back(s.t);
    ch->y.emplace_back(s.m - p.pred);
    ch->row.push_back(s.row);
    ch->current_A.push_back(ls.currents.battery_A);
    ch->throttle.push_back(thr);
    rows->h.push_back(p.h);
    rows->Msens.push_back(p.M);
    rows->Rt.emplace_back(R_NB.transpose());
    rows->I_log.push_back(ls.i_logged);
    rows->t_meas.push_back(s.t - o.latency_s);
    rows->u.push_back(thr);
    if (!o.baseline_only) {
      rows->mu.push_back(std::move(motors));
      rows->temp.push_back(in.temp ? Lerp(*in.temp, ls.i, ls.w) : std::nan(""));
      rows->currents.push_back(ls.currents);
    }
  }
}

// Library-free set (detection): r = A·h + d_I·I + d_u·u, A any 3×3 matrix (scale, cross-coupling,
// misalignment of any form), linear in the current and the throttle (squares extrapolate wildly
// into a held-out block; a drift is left to the spectral test).
void AddLibraryFree(const CompassRows& rows, bool has_current, ChannelData* ch) {
  ch->flexible = MakeCandidate("library_free", {}, {}, "");
  for (size_t k = 0; k < ch->t.size(); ++k) {
    std::vector<double> f;
    if (has_current) f.push_back(rows.I_log[k]);
    if (std::isfinite(rows.u[k])) f.push_back(rows.u[k]);
    Mat3X x3 = Mat3X::Zero(3, 9 + 3 * static_cast<Eigen::Index>(f.size()));
    for (int r = 0; r < 3; ++r) x3.block(r, 3 * r, 1, 3) = rows.h[k].transpose();
    for (size_t j = 0; j < f.size(); ++j) x3.block(0, 9 + 3 * static_cast<Eigen::Index>(j), 3, 3) = Eigen::Matrix3d::Identity() * f[j];
    ch->flexible.X.push_back(x3);
  }
  // Every sample must carry the same columns.
  bool same = true;
  for (const auto& x : ch->flexible.X) same = same && x.cols() == ch->flexible.X.front().cols();
  if (!same || ch->flexible.X.empty()) ch->flexible.X.clear();
  for (Eigen::Index j = 0; !ch->flexible.X.empty() && j < ch->flexible.X.front().cols(); ++j) {
    ch->flexible.names.push_back(fmt::format("z{}", j));
    ch->flexible.scale.push_back(1.0);
  }
}

// The logged current at the measurement times shifted by shift_s (NaN outside the log).
std::vector<double> ShiftedCurrent(const std::vector<double>& t_row, const std::vector<double>& current,
                                   const std::vector<double>& t_meas, double shift_s) {
  std::vector<double> out(t_meas.size(), std::nan(""));
  RowCursor cur{t_row};
  double w = 0;
  for (size_t k = 0; k < t_meas.size(); ++k) {
    if (cur.Seek(t_meas[k] + shift_s, &w)) out[k] = Lerp(current, cur.i, w);
  }
  return out;
}

// current_hard_iron and current_soft_iron, each with the logged current (current_aligned 0) and
// the current aligned by each of the member shifts (current_aligned: the shift, s).
// The current-driven families' members: the logged current I(t − latency_s) (shift 0) and the
// current aligned by each member shift, without a shift that runs past the log's end (not every
// sample would have a current).
struct CurrentMember {
  double shift_s = 0.0;
  std::vector<double> I;
};
std::vector<CurrentMember> CurrentMembers(const CompassRows& rows, const CompassReplayOptions& o,
                                          const std::vector<double>& t_row, const std::vector<double>& current) {
  std::vector<CurrentMember> out;
  std::vector<double> shifts = {0.0};
  for (double shift : o.member_shifts_s) {
    if (shift != 0.0) shifts.push_back(shift);
  }
  if (!o.only_member_shifts_s.empty()) {
    const std::vector<double>& only = o.only_member_shifts_s;
    shifts.erase(std::remove_if(shifts.begin(), shifts.end(),
                                [&](double s) { return std::find(only.begin(), only.end(), s) == only.end(); }),
                 shifts.end());
  }
  for (double shift : shifts) {
    std::vector<double> I = shift == 0.0 ? rows.I_log : ShiftedCurrent(t_row, current, rows.t_meas, shift);
    bool finite = true;
    for (double x : I) finite = finite && std::isfinite(x);
    if (finite) out.push_back({shift, std::move(I)});
  }
  return out;
}

// The configured wiring field's per-motor shape at each sample, in the sensor frame: the field of
// the currents as split over the motors (the prediction's) less the field of the same motor current
// shared equally, which is in proportion to the battery current. With --sim the residual holds
// −shape where the aircraft's field does not follow the file's per-motor split (a wiring field the
// file models wrongly); the battery current cannot describe it, and a manoeuvre moves it (differential
// thrust follows the tilt). Empty where the file has no per-motor wiring or the shape stays under
// kWiringColumnFloor_uT RMS.
// A column built from the vehicle file's wiring field (the per-motor shape here, current_lag's
// configured-wiring member) under 0.05 µT RMS, 0.5 mG, is under a tenth of a compass's per-sample
// noise (0.2-0.4 µT): a column no flight resolves, not offered.
constexpr double kWiringColumnFloor_uT = 0.05;
std::vector<Vec3> MotorShape(const CompassSampler& sampler, const CompassRows& rows, const std::vector<double>& t) {
  const size_t n = rows.currents.size();
  std::vector<Vec3> shape(n, Vec3::Zero());
  if (n == 0 || n != t.size()) return {};
  magnetics::CurrentLagState lag;
  double energy = 0;
  for (size_t k = 0; k < n; ++k) {
    const double dt = k == 0 ? 0.0 : t[k] - t[k - 1];
    const magnetics::Currents& cur = magnetics::StepCurrentLag(sampler.wiring(), rows.currents[k], dt, &lag);
    if (cur.motor_A.empty()) return {};
    magnetics::Currents equal = cur;
    double motors = 0;
    for (double a : cur.motor_A) motors += a;
    std::fill(equal.motor_A.begin(), equal.motor_A.end(), motors / static_cast<double>(cur.motor_A.size()));
    shape[k] = rows.Msens[k] * (sampler.field()(cur) - sampler.field()(equal));
    energy += shape[k].squaredNorm();
  }
  if (!(std::sqrt(energy / static_cast<double>(n)) > kWiringColumnFloor_uT)) return {};
  return shape;
}

// current_hard_iron's members: d·I (the field in proportion to the battery current) and, where the
// file models a per-motor shape (MotorShape), d·I + a·shape, a the share of the modelled per-motor
// shape the aircraft shows beyond the file's: a + 1 is the aircraft's per-motor shape over the
// file's, −1 none of it (the field in proportion to the battery current), 0 the file's. Physical
// range [−3, 1]: an aircraft's ESC feeds at the compass carry up to twice the field of the file's
// typical layout, routed either way (log_30's internal compass against quad_x: −1.7 [−2.1, −1.4]).
// A form column: fitted and reported (gap.json params), not tested (Analyzer: magnitude_params) and
// not a verdict of its own; a member whose share falls outside the range describes no aircraft's
// per-motor field (an external compass's tiny modelled shape, scaled by 109, took a slow trend on a
// 14S log) and is not the family's (Candidate::form_ranges). Its magnitude is |d| alone (the gap's
// field per ampere); the held-out blocks decide between the members in range (ReportedMember).
constexpr double kMotorShapeShareLo = -3.0, kMotorShapeShareHi = 1.0;
void AddCurrentIron(const std::vector<CurrentMember>& members, const CompassRows& rows, const std::vector<Vec3>& shape,
                    ChannelData* ch) {
  for (const CurrentMember& mem : members) {
    const double shift = mem.shift_s;
    const std::vector<double>& I = mem.I;
    Candidate chi = MakeCandidate("current_hard_iron", {"d_x_uT_per_A", "d_y_uT_per_A", "d_z_uT_per_A"}, {1, 1, 1},
                                  "uT/A", "current_A");
    Candidate csi = MakeCandidate("current_soft_iron",
                                  {"dK_xx_per_A", "dK_xy_per_A", "dK_xz_per_A", "dK_yx_per_A", "dK_yy_per_A",
                                   "dK_yz_per_A", "dK_zx_per_A", "dK_zy_per_A", "dK_zz_per_A"},
                                  std::vector<double>(9, 1.0), "1/A", "current_A");
    chi.grid_name = csi.grid_name = "current_aligned";
    chi.grid_value = csi.grid_value = shift;
    for (size_t k = 0; k < ch->t.size(); ++k) {
      const double Ik = I[k];
      chi.X.push_back(Diag3(Ik));
      chi.regressor.push_back(Ik);
      Mat3X x = Mat3X::Zero(3, 9);
      for (int r = 0; r < 3; ++r) {
        for (int j = 0; j < 3; ++j) x(r, 3 * r + j) = Ik * rows.h[k][j];  // r_i = Σ_j E_ij·I·h_j
      }
      csi.X.push_back(x);
      csi.regressor.push_back(Ik);
    }
    ch->candidates.push_back(std::move(chi));
    ch->candidates.push_back(std::move(csi));
    if (!shape.empty()) {
      Candidate chs = MakeCandidate("current_hard_iron", {"d_x_uT_per_A", "d_y_uT_per_A", "d_z_uT_per_A", "motor_shape_share"},
                                    {1, 1, 1, 1}, "uT/A", "current_A");
      chs.magnitude_params = 3;
      chs.form_ranges.push_back({3, kMotorShapeShareLo, kMotorShapeShareHi});
      chs.grid_name = "current_aligned";
      chs.grid_value = mem.shift_s;
      for (size_t k = 0; k < ch->t.size(); ++k) {
        Mat3X x(3, 4);
        x << Diag3(I[k]), shape[k];
        chs.X.push_back(x);
        chs.regressor.push_back(I[k]);
      }
      ch->candidates.push_back(std::move(chs));
    }
  }
}

// reference_yaw: the attitude reference's heading error in proportion to the current, δψ = c·I (an
// estimator that fuses a compass the current disturbs). The predicted field is the Earth field
// rotated by the reference attitude; a heading error δψ about down turns it, so the compass reads
// r = M·R_NBᵀ·(ẑ × B_N)·δψ more than predicted (first order in δψ). One column per sample, c in
// deg/A (scale kRadToDeg), with the same current members as current_hard_iron: the reference sees
// the fused compass's field at that compass's timing. Unlike a current field at the compass, which
// is fixed in the body, this one is fixed in NED about down: it turns in the body as the vehicle yaws.
void AddReferenceYaw(const std::vector<CurrentMember>& members, const CompassRows& rows, ChannelData* ch) {
  const Vec3 turn_N = Vec3::UnitZ().cross(ch->field_N_uT);  // d(B_N)/dψ about down: (−B_E, B_N, 0)
  for (const CurrentMember& mem : members) {
    Candidate ry = MakeCandidate("reference_yaw", {"c_deg_per_A"}, {kRadToDeg}, "deg/A", "current_A");
    ry.grid_name = "current_aligned";
    ry.grid_value = mem.shift_s;
    for (size_t k = 0; k < ch->t.size(); ++k) {
      ry.X.emplace_back(Mat3X(rows.Msens[k] * rows.Rt[k] * turn_N * mem.I[k]));
      ry.regressor.push_back(mem.I[k]);
    }
    ch->candidates.push_back(std::move(ry));
  }
}

// current_lag: the configured wiring field arrives through a first-order lag τ instead of the
// configured one: r = a·M·(W(lp_τ(I)) − W(lp_τcfg(I))), a ≈ 1, τ profiled over a grid.
// The configured field W(I) is linear in the currents (exponent 1), so a first-order lag of the
// currents is the same lag of the field: W(lp_τ(I)) = lp_τ(W(I)). The field is then evaluated
// once per sample and lagged as a vector for each τ; the configured lag's field once.
void AddCurrentLag(const CompassSampler& sampler, const CompassRows& rows, ChannelData* ch) {
  const magnetics::CurrentFieldParams& wiring = sampler.wiring();
  const size_t n = ch->t.size();
  std::vector<Vec3> field(n), field_cfg(n);
  double wiring_energy = 0;
  {
    magnetics::CurrentLagState s_cfg;
    for (size_t k = 0; k < n; ++k) {
      const double dt = k == 0 ? 0.0 : ch->t[k] - ch->t[k - 1];
      field[k] = sampler.field()(rows.currents[k]);
      field_cfg[k] = sampler.field()(magnetics::StepCurrentLag(wiring, rows.currents[k], dt, &s_cfg));
      wiring_energy += field[k].squaredNorm();
    }
  }
  if (!(n > 0 && std::sqrt(wiring_energy / static_cast<double>(n)) > kWiringColumnFloor_uT)) {
    ch->not_available.emplace_back("current_lag's configured-wiring member (the wiring field here is too small to show a lag)");
    return;
  }
  const bool linear = wiring.exponent == 1.0;
  for (double tau : kLagGrid_s) {
    if (tau <= wiring.lag_tau_s) continue;
    magnetics::CurrentFieldParams lagged_wiring = wiring;
    lagged_wiring.lag_tau_s = tau;
    magnetics::CurrentLagState s_new;
    Candidate cl = MakeCandidate("current_lag", {"amplitude"}, {1.0}, "s", "current_A");
    cl.grid_value = tau;
    cl.grid_name = "tau_s";
    cl.X.reserve(n);
    cl.regressor.reserve(n);
    Vec3 a = Vec3::Zero();
    for (size_t k = 0; k < n; ++k) {
      const double dt = k == 0 ? 0.0 : ch->t[k] - ch->t[k - 1];
      if (!linear) {
        a = sampler.field()(magnetics::StepCurrentLag(lagged_wiring, rows.currents[k], dt, &s_new));
      } else if (k == 0) {
        a = field[0];  // steady state at the first sample, as StepCurrentLag starts
      } else {
        const double alpha = std::exp(-dt / tau);
        a = alpha * a + (1.0 - alpha) * field[k];
      }
      cl.X.emplace_back(rows.Msens[k] * (a - field_cfg[k]));
      cl.regressor.push_back(rows.currents[k].battery_A);
    }
    ch->candidates.push_back(std::move(cl));
  }
}

// throttle_hard_iron: d·throttle^r, r profiled over kThrottleExponents (replay_util.h: its physical range).
void AddThrottleIron(const CompassRows& rows, bool has_throttle, ChannelData* ch) {
  const size_t n = ch->t.size();
  bool throttle_ok = has_throttle && n > 0;
  for (double x : rows.u) throttle_ok = throttle_ok && std::isfinite(x);
  if (!throttle_ok) {
    ch->not_available.emplace_back("throttle_hard_iron (no control_u or motor_i_u)");
    return;
  }
  for (double r : kThrottleExponents) {
    Candidate thi = MakeCandidate("throttle_hard_iron", {"d_x_uT_per_throttle", "d_y_uT_per_throttle", "d_z_uT_per_throttle"},
                                  {1, 1, 1}, "uT/throttle", "throttle");
    thi.grid_name = "exponent";
    thi.grid_value = r;
    for (size_t k = 0; k < n; ++k) {
      thi.X.push_back(Diag3(std::pow(std::max(0.0, rows.u[k]), r)));
      thi.regressor.push_back(rows.u[k]);
    }
    ch->candidates.push_back(std::move(thi));
  }
}

// per_motor_current_hard_iron: B = Σ_i c_i·u_i^0.65 (ArduPilot's per-motor compensation form), 3
// parameters per motor.
void AddPerMotorIron(const CompassRows& rows, size_t n_motor, ChannelData* ch) {
  const size_t n = ch->t.size();
  if (!(n_motor > 0 && n > 0)) {
    ch->not_available.emplace_back("per_motor_current_hard_iron (no motor_i_u columns)");
    return;
  }
  std::vector<std::string> names;
  for (size_t m = 0; m < n_motor; ++m) {
    for (const char* a : {"x", "y", "z"}) names.push_back(fmt::format("c{}_{}_uT", m + 1, a));
  }
  Candidate pm = MakeCandidate("per_motor_current_hard_iron", names, std::vector<double>(names.size(), 1.0), "uT",
                               "throttle");
  bool finite = true;
  for (size_t k = 0; k < n; ++k) {
    Mat3X x(3, static_cast<Eigen::Index>(3 * n_motor));
    for (size_t m = 0; m < n_motor; ++m) {
      const double um = rows.mu[k][m];
      finite = finite && std::isfinite(um);
      x.block(0, static_cast<Eigen::Index>(3 * m), 3, 3) = Eigen::Matrix3d::Identity() * std::pow(std::max(0.0, um), kPerMotorExponent);
    }
    pm.X.push_back(x);
    pm.regressor.push_back(rows.u[k]);
  }
  if (finite) ch->candidates.push_back(std::move(pm));
}

// temperature_drift: B = d·(T − T_ref), where the temperature varies by more than 0.1 °C.
void AddTemperatureDrift(const CompassRows& rows, bool has_temp, ChannelData* ch) {
  const size_t n = ch->t.size();
  const std::vector<double>& temp = rows.temp;
  bool temp_ok = has_temp && n > 0;
  double tmean = 0;
  for (double x : temp) {
    temp_ok = temp_ok && std::isfinite(x);
    tmean += x;
  }
  if (temp_ok) {
    tmean /= static_cast<double>(n);
    double tvar = 0;
    for (double x : temp) tvar += (x - tmean) * (x - tmean);
    temp_ok = tvar / static_cast<double>(n) > 0.01;  // needs > 0.1 °C of variation
  }
  if (!temp_ok) {
    ch->not_available.emplace_back("temperature_drift (no imu_temp_C column with varying temperature)");
    return;
  }
  // T_ref the median of the first 10 samples (the sensor is taken as calibrated where the flight
  // starts; the baseline's offset holds any constant part).
  std::vector<double> first10(temp.begin(), temp.begin() + static_cast<std::ptrdiff_t>(std::min<size_t>(10, n)));
  std::nth_element(first10.begin(), first10.begin() + static_cast<std::ptrdiff_t>(first10.size() / 2), first10.end());
  const double tref = first10[first10.size() / 2];
  Candidate td = MakeCandidate("temperature_drift", {"d_x_uT_per_C", "d_y_uT_per_C", "d_z_uT_per_C"}, {1, 1, 1}, "uT/C",
                               "imu_temp_C");
  for (size_t k = 0; k < n; ++k) {
    td.X.push_back(Diag3(temp[k] - tref));
    td.regressor.push_back(temp[k]);
  }
  ch->candidates.push_back(std::move(td));
}

}  // namespace

ChannelData ReplayCompass(const logs::FlightLog& log, const vehicle::VehicleParams& v, size_t c, const LogInputs& in,
                          const Vec3& B_N_uT, const CompassReplayOptions& o) {
  const std::string pre = MagPrefix(c);
  CompassSampler sampler(log, v, c, in, B_N_uT, o.calibrated_log, o.share_exponent);

  ChannelData ch;
  ch.name = pre;
  ch.unit = "uT";
  ch.compass = true;
  ch.bias_nuisance = false;  // the baseline's offset holds any bias
  ch.field_N_uT = B_N_uT;
  ch.undone_compensation = sampler.undone_compensation();

  CompassRows rows;
  SampleCompass(&sampler, in, o, &ch, &rows);
  const size_t n = ch.t.size();
  const bool has_current = in.current != nullptr;
  const bool has_throttle = in.control_u != nullptr || !in.motor_u.empty();

  ch.baseline = MakeCandidate("baseline", {"offset_x_uT", "offset_y_uT", "offset_z_uT", "dB_N_uT", "dB_E_uT", "dB_D_uT"},
                              {1, 1, 1, 1, 1, 1}, "uT");
  for (size_t k = 0; k < n; ++k) {
    Mat3X x(3, 6);
    x << Eigen::Matrix3d::Identity(), rows.Msens[k] * rows.Rt[k];
    ch.baseline.X.push_back(x);
  }
  if (o.baseline_only) {
    if (has_current) {
      Candidate chi = MakeCandidate("current_hard_iron", {"d_x_uT_per_A", "d_y_uT_per_A", "d_z_uT_per_A"}, {1, 1, 1}, "uT/A");
      for (size_t k = 0; k < n; ++k) chi.X.push_back(Diag3(ch.current_A[k]));
      ch.candidates.push_back(std::move(chi));
    }
    return ch;
  }
  if (o.library_free) AddLibraryFree(rows, has_current, &ch);
  const auto want = [&o](Effect e) {
    return o.only_families.empty() || std::find(o.only_families.begin(), o.only_families.end(), e) != o.only_families.end();
  };
  if (want(Effect::kMisalignment)) {
    // Misalignment only (scale and latency are the baseline's and the timing scan's); on the compass
    // the reference fused, the tilt angles only (CompassReplayOptions::fused_by_reference).
    Candidate mis = o.fused_by_reference
                        ? MakeCandidate("misalignment", {"phi_x_deg", "phi_y_deg"}, {kRadToDeg, kRadToDeg}, "deg")
                        : MakeCandidate("misalignment", {"phi_x_deg", "phi_y_deg", "phi_z_deg"},
                                        {kRadToDeg, kRadToDeg, kRadToDeg}, "deg");
    const Eigen::Index angles = o.fused_by_reference ? 2 : 3;
    for (size_t k = 0; k < n; ++k) mis.X.emplace_back((-Skew(rows.h[k])).leftCols(angles));  // φ × h = −[h]×·φ
    ch.candidates.push_back(std::move(mis));
  }
  if (has_current) {
    const bool iron = want(Effect::kCurrentHardIron) || want(Effect::kCurrentSoftIron);
    const bool reference = o.reference_yaw && want(Effect::kReferenceYaw);
    const std::vector<CurrentMember> members =
        iron || reference ? CurrentMembers(rows, o, log.Column("t_s"), *in.current) : std::vector<CurrentMember>{};
    if (iron) AddCurrentIron(members, rows, MotorShape(sampler, rows, ch.t), &ch);
    using Form = LagMembers::Form;
    const Form lag = o.lag_members.form;
    if (want(Effect::kCurrentLag) && lag != Form::kFree) AddCurrentLag(sampler, rows, &ch);
    if (want(Effect::kCurrentLag) && lag != Form::kWiring) {
      AddLaggedCurrentField(&ch, lag == Form::kFree ? o.lag_members.exponent : std::nan(""));
    }
    if (reference) AddReferenceYaw(members, rows, &ch);
  } else {
    ch.not_available.emplace_back(std::string("current_hard_iron, current_soft_iron, current_lag") +
                                  (o.reference_yaw ? ", reference_yaw" : "") +
                                  (in.current_unusable_why.empty() ? " (no current_A column)"
                                                                   : " (" + in.current_unusable_why + ")"));
  }
  if (want(Effect::kThrottleHardIron)) AddThrottleIron(rows, has_throttle, &ch);
  if (want(Effect::kPerMotorCurrentHardIron)) AddPerMotorIron(rows, in.motor_u.size(), &ch);
  if (want(Effect::kTemperatureDrift)) AddTemperatureDrift(rows, in.temp != nullptr, &ch);
  return ch;
}

}  // namespace hexsim::gap::internal
