// Open-loop dynamics replay: the log's motor commands, bus voltage, attitude and velocity drive the
// configured powertrain (rotor speeds integrated with vehicle::StepPowertrain from the logged
// battery: its EMF V + R_int·I, the bus solved from the replay's own current; BatteryRows)
// and airframe drag to predict the body specific force the accelerometer measures:
//   f_B = (Σ_i k_T·ω_i²·a_i + F_drag(v_B)) / m,   v_B = R_NBᵀ·v_N (no wind configured)
// and the residual accel − f_B is explained by the rotor/airframe candidates:
//   rotor_drag           −k·(Σω)·(v_x, v_y, 0)/m                         k  [N/((rad/s)(m/s))]
//   ground_effect        Σ_i T_i·a_i/m·(1/(1 − R²/(16 z_i²)) − 1)          R  [m] (Cheeseman–Bennett per rotor, z_i ≥ R/2)
//   battery_sag          (F_T at V − ΔR·I) − F_T, per unit ΔR (secant)    ΔR [Ω]
//   motor_time_constant  F_T with rotor inertia ×(1 + Δτ/τ_hover) − F_T   Δτ [s] (slower rotors)
//   wind                 (F_drag(v_B − R_NBᵀ w) − F_drag(v_B))/m          w_N, w_E [m/s]
//   thrust_scale         s·F_T/m            (k_T or mass wrong)           s  [1]
// ground_effect, motor_time_constant and wind are nonlinear in their parameter: a Gauss–Newton fit gives a working
// point and the candidate's regressor is the secant through it, so the linear coefficient equals
// the physical parameter at the fit (intervals from the same cluster-robust covariance).
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <fmt/format.h>

#include "channels.h"
#include "replay_util.h"
#include "hexsim/common/plausibility.h"
#include "hexsim/common/rotation.h"
#include "hexsim/realdata/velocity_check.h"
#include "hexsim/sim/simulation.h"
#include "hexsim/vehicle/powertrain.h"

namespace hexsim::gap::internal {
namespace {

constexpr double kSubstep_s = 0.001;       // powertrain integration step between log rows
constexpr double kMaxRowGap_s = 0.1;       // larger gaps restart the rotors at steady state
constexpr double kMinHeight_m = 0.15;      // CG height above the take-off point: clear of the ground

bool HasData(const logs::FlightLog& log, const std::string& name) {
  if (!log.Has(name)) return false;
  for (double v : log.Column(name)) {
    if (std::isfinite(v)) return true;
  }
  return false;
}

// Airframe drag of the configured vehicle, body axes.
Vec3 DragForce_B(const vehicle::DragParams& d, const Vec3& v_air_B) {
  return -(d.linear_Nspm.cwiseProduct(v_air_B) + d.quadratic_Ns2pm2.cwiseProduct(v_air_B.cwiseAbs().cwiseProduct(v_air_B)));
}

// The configured vehicle with a battery of EMF emf_V and internal resistance r_ohm: StepPowertrain
// then solves the bus voltage the ESCs see from the replay's own current at every step, as the
// simulator's powertrain does (a command step sags the bus in the same step, not one row later).
void SetBattery(double emf_V, double r_ohm, double max_current_A, vehicle::VehicleParams* p) {
  p->battery.internal_resistance_ohm = r_ohm;
  // The battery limit puts the bus at emf − r·I_max; where that is not above 0 V the bus collapses
  // before the current reaches the limit, which then never binds.
  p->battery.max_current_A =
      std::isfinite(max_current_A) && !(emf_V - r_ohm * max_current_A > 0.0) ? std::numeric_limits<double>::infinity()
                                                                            : max_current_A;
  p->battery.cells_series = 1;
  p->battery.ocv_soc = {0.0, 1.0};
  p->battery.ocv_cell_V = {emf_V, emf_V};
}

// 1-D or 2-D Gauss–Newton: minimise Σ|y_k − (g_k(θ) − mean g)|², g_k from `model` (value, Jacobian).
template <typename Model>
Eigen::VectorXd GaussNewton(const std::vector<Vec3>& y, bool demean, int p, const Model& model,
                            const Eigen::VectorXd& lo, const Eigen::VectorXd& hi) {
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(p);
  const size_t n = y.size();
  if (n == 0) return theta;
  for (int it = 0; it < 12; ++it) {
    std::vector<Vec3> g(n);
    std::vector<Mat3X> J(n);
    Vec3 mg = Vec3::Zero(), my = Vec3::Zero();
    Mat3X mJ = Mat3X::Zero(3, p);
    for (size_t k = 0; k < n; ++k) {
      model(k, theta, &g[k], &J[k]);
      mg += g[k];
      mJ += J[k];
      my += y[k];
    }
    if (demean) {
      mg /= static_cast<double>(n);
      mJ /= static_cast<double>(n);
      my /= static_cast<double>(n);
    } else {
      mg.setZero();
      mJ.setZero();
      my.setZero();
    }
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(p, p);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(p);
    for (size_t k = 0; k < n; ++k) {
      const Mat3X Jk = J[k] - mJ;
      const Vec3 r = (y[k] - my) - (g[k] - mg);
      A.noalias() += Jk.transpose() * Jk;
      b.noalias() += Jk.transpose() * r;
    }
    if (!(A.trace() > 0)) break;
    const Eigen::VectorXd step =
        (A + Eigen::MatrixXd::Identity(p, p) * (1e-9 * A.trace() / p)).ldlt().solve(b);
    if (!step.allFinite()) break;
    theta = (theta + step).cwiseMax(lo).cwiseMin(hi);
    if (step.norm() < 1e-9 * (1.0 + theta.norm())) break;
  }
  return theta;
}

}  // namespace

double HoverRotorTimeConstant_s(const vehicle::VehicleParams& v) {
  if (v.rotors.empty() || !(v.rotors.front().k_T_Nprps2 > 0) || !(v.motor.winding_resistance_ohm > 0)) return 0.0;
  const auto& r = v.rotors.front();
  // k_T·ω_h² = m·g/n;  τ = J/(K_t²/R + 2·k_Q·ω_h) (linearised rotor speed dynamics while driven).
  const double omega_h = std::sqrt(v.mass_kg * kGravity_mps2 / (static_cast<double>(v.rotors.size()) * r.k_T_Nprps2));
  const double Kt = v.motor.Kt_Nm_per_A();
  return v.RotorInertia_kgm2(0) / (Kt * Kt / v.motor.winding_resistance_ohm + 2.0 * r.k_Q_Nmprps2 * omega_h);
}

Eigen::MatrixXd BiasWalkCov(const ChannelData& ch, const Candidate& c) {
  const size_t n = ch.t.size();
  const int p = c.p();
  if (!(ch.bias_walk_per_sqrt_s > 0) || !ch.bias_nuisance || p == 0 || c.X.size() != n || n < 2) return {};
  Mat3X mean = Mat3X::Zero(3, p);
  for (const Mat3X& x : c.X) mean += x;
  mean /= static_cast<double>(n);
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(p, p), V = Eigen::MatrixXd::Zero(p, p);
  Mat3X tail = Mat3X::Zero(3, p);  // T_j, summed from the last sample back
  for (size_t j = n; j-- > 0;) {
    const Mat3X x = c.X[j] - mean;
    A.noalias() += x.transpose() * x;
    tail += x;
    if (j > 0 && ch.t[j] > ch.t[j - 1]) V.noalias() += (ch.t[j] - ch.t[j - 1]) * (tail.transpose() * tail);
  }
  const Eigen::FullPivLU<Eigen::MatrixXd> lu(A);
  if (!lu.isInvertible()) return {};
  const Eigen::MatrixXd Ai = lu.inverse();
  return ch.bias_walk_per_sqrt_s * ch.bias_walk_per_sqrt_s * Ai * V * Ai;
}

}  // namespace hexsim::gap::internal

namespace hexsim::gap {
double HoverRotorTimeConstant_s(const vehicle::VehicleParams& v) { return internal::HoverRotorTimeConstant_s(v); }
}  // namespace hexsim::gap

namespace hexsim::gap::internal {
namespace {

// "" when the log holds every column the replay reads, else what it lacks.
std::string MissingInputs(const logs::FlightLog& log, size_t n_rot) {
  std::vector<std::string> missing;
  for (const char* c : {"accel_x_mps2", "accel_y_mps2", "accel_z_mps2"}) {
    if (!HasData(log, c)) missing.emplace_back(c);
  }
  for (const char* c : {"vel_N_mps", "vel_E_mps", "vel_D_mps"}) {
    if (!HasData(log, c)) missing.emplace_back(c);
  }
  for (size_t m = 0; m < n_rot; ++m) {
    if (!HasData(log, fmt::format("motor_{}_u", m + 1))) missing.push_back(fmt::format("motor_{}_u", m + 1));
  }
  if (!HasData(log, "voltage_V") && !HasData(log, "current_A")) {
    missing.emplace_back("voltage_V (or current_A to model the battery)");
  }
  if (n_rot == 0) missing.emplace_back("rotors in the vehicle");
  std::string list;
  for (const auto& m : missing) list += (list.empty() ? "" : ", ") + m;
  return list;
}

// The log columns the replay reads (pointers into the log), and what the battery monitor is worth.
struct DynamicsInputs {
  const std::vector<double>*t, *vn, *ve, *vd, *ax, *ay, *az;
  const std::vector<double>* q[4];
  std::vector<const std::vector<double>*> mu;  // motor outputs, one per rotor
  bool has_V = false, V_usable = false;
  double median_V = std::nan("");
  const std::vector<double>* V = nullptr;  // the logged bus voltage, when usable
  bool current_usable = true;              // the same monitor measures both
  const std::vector<double>* I = nullptr;
  const std::vector<double>* soc = nullptr;
  const std::vector<double>* payload = nullptr;
  const std::vector<double>* alt = nullptr;  // pos_D_m, else baro_alt_m
  double alt_sign = 1.0;                     // alt_sign·alt is the height up
  size_t rows = 0;
};

DynamicsInputs FindInputs(const logs::FlightLog& log, size_t n_rot, bool import_current_usable) {
  DynamicsInputs in;
  in.t = &log.Column("t_s");
  in.vn = &log.Column("vel_N_mps");
  in.ve = &log.Column("vel_E_mps");
  in.vd = &log.Column("vel_D_mps");
  in.ax = &log.Column("accel_x_mps2");
  in.ay = &log.Column("accel_y_mps2");
  in.az = &log.Column("accel_z_mps2");
  in.q[0] = &log.Column("q_w");
  in.q[1] = &log.Column("q_x");
  in.q[2] = &log.Column("q_y");
  in.q[3] = &log.Column("q_z");
  for (size_t m = 0; m < n_rot; ++m) in.mu.push_back(&log.Column(fmt::format("motor_{}_u", m + 1)));
  // A logged voltage whose median is no battery bus (no power monitor connected: e.g. 0.06 V) would
  // stop every rotor in the replay; the configured battery stands in for it, and the channel says so.
  in.has_V = HasData(log, "voltage_V");
  in.median_V = in.has_V ? MedianFinite(log.Column("voltage_V")) : std::nan("");
  in.V_usable = in.has_V && plausibility::IsPlausible("bus_voltage_V", in.median_V);
  in.V = in.V_usable ? &log.Column("voltage_V") : nullptr;
  // The import's check (units, no power monitor; LogInputs::current_usable) judges the current itself.
  in.current_usable = (!in.has_V || in.V_usable) && import_current_usable;
  in.I = HasData(log, "current_A") ? &log.Column("current_A") : nullptr;
  in.soc = HasData(log, "battery_soc") ? &log.Column("battery_soc") : nullptr;
  in.payload = HasData(log, "payload_kg") ? &log.Column("payload_kg") : nullptr;
  const bool has_pos = HasData(log, "pos_D_m");
  in.alt = has_pos ? &log.Column("pos_D_m") : HasData(log, "baro_alt_m") ? &log.Column("baro_alt_m") : nullptr;
  in.alt_sign = has_pos ? -1.0 : 1.0;
  in.rows = log.rows();
  return in;
}

// The battery the replay's ESCs run from, per row. The bus voltage sags with the current through
// the battery's internal resistance R within one autopilot tick (a command step's current spike),
// far faster than a log row, so a bus voltage interpolated between rows leads the real one through
// every thrust change: the replay then reads as a rotor lag (a motor time constant 2 % high). The
// replay carries the slow part, the EMF, and solves the bus from its own current:
//   logged V and I:  EMF = V + R·I (R configured), the bus solved with R;
//   logged V only:   EMF = V with no resistance (the logged bus, stiff);
//   no (usable) V:   EMF = V_oc(SoC) of the configured battery, the bus solved with R.
// bus_V is the bus at the row itself (restarts at steady state, and whether the row is usable).
struct BatteryRows {
  std::vector<double> emf_V, r_ohm, bus_V;
};

BatteryRows BatteryPerRow(const DynamicsInputs& in, const vehicle::VehicleParams& v) {
  const size_t N = in.rows;
  const auto& t = *in.t;
  const double R = v.battery.internal_resistance_ohm;
  BatteryRows b{std::vector<double>(N, std::nan("")), std::vector<double>(N, 0.0), std::vector<double>(N, std::nan(""))};
  double soc = v.battery.initial_soc;
  const double capacity_As = v.battery.capacity_Ah * 3600.0;
  for (size_t i = 0; i < N; ++i) {
    const double I_log = in.I && in.current_usable ? (*in.I)[i] : std::nan("");
    if (in.V) {
      b.bus_V[i] = (*in.V)[i];
      b.r_ohm[i] = std::isfinite(I_log) ? R : 0.0;
      b.emf_V[i] = b.bus_V[i] + b.r_ohm[i] * (std::isfinite(I_log) ? I_log : 0.0);
      continue;
    }
    const double I = in.I && in.current_usable ? (*in.I)[i] : 0.0;  // no usable monitor: no load known
    if (in.soc && std::isfinite((*in.soc)[i])) soc = (*in.soc)[i];
    if (std::isfinite(I)) {
      b.emf_V[i] = v.battery.OpenCircuitVoltage_V(soc);
      b.r_ohm[i] = R;
      b.bus_V[i] = b.emf_V[i] - R * I;
    }
    if (!in.soc && i + 1 < N && std::isfinite(I) && capacity_As > 0) {
      soc = std::clamp(soc - I * (t[i + 1] - t[i]) / capacity_As, 0.0, 1.0);
    }
  }
  return b;
}

// Height of the take-off point (the first finite altitude, as height up); NaN without an altitude.
double TakeOffHeight(const DynamicsInputs& in) {
  if (in.alt) {
    for (double a : *in.alt) {
      if (std::isfinite(a)) return in.alt_sign * a;
    }
  }
  return std::nan("");
}

// Rotor speeds at each row: the configured powertrain integrated from the logged battery (BatteryRows),
// commands interpolated between rows and held between autopilot ticks.
class PowertrainReplay {
 public:
  PowertrainReplay(const DynamicsInputs& in, const vehicle::VehicleParams& v)
      : in_(in), v_(v), bat_(BatteryPerRow(in, v)), ap_rate_hz_(v.sensors.gyro.rate_hz) {}

  // inertia_scale multiplies every rotor's inertia (the rotor time constant scales with it);
  // delta_R_ohm lowers the voltage the ESCs see by ΔR·I (the logged voltage is read ΔR·I upstream
  // of them: the EMF behind the configured resistance is lower by ΔR·I).
  void Run(double inertia_scale, double delta_R_ohm, std::vector<std::vector<double>>* omega,
           std::vector<bool>* row_ok) const {
    const size_t N = in_.rows, n_rot = v_.rotors.size();
    const auto& t = *in_.t;
    std::vector<double> cmd(n_rot), c0(n_rot), c1(n_rot);
    vehicle::VehicleParams pv = v_;
    pv.motor.inertia_kgm2 *= inertia_scale;
    for (auto& r : pv.rotors) r.inertia_kgm2 *= inertia_scale;
    vehicle::PowertrainState ps = vehicle::InitialPowertrainState(pv);
    vehicle::PowertrainOutput step_out;  // reused: its motor records are not reallocated every step
    omega->assign(N, {});
    row_ok->assign(N, false);
    bool have_state = false;
    for (size_t i = 0; i < N; ++i) {
      const bool ok_i = CommandsAt(i, &c1) && std::isfinite(bat_.bus_V[i]) && bat_.bus_V[i] > 0;
      if (!ok_i) {
        have_state = false;
        continue;
      }
      if (!have_state || !(t[i] - t[i - 1] <= kMaxRowGap_s) || !(t[i] > t[i - 1])) {
        // Restart at the steady state of this row's commands.
        for (size_t m = 0; m < n_rot; ++m) {
          ps.omega_radps[m] =
              c1[m] > 0 ? vehicle::SteadyOmega_radps(v_, m, v_.esc.Duty(c1[m]) * RowBus(i, delta_R_ohm)) : 0.0;
        }
      } else {
        CommandsAt(i - 1, &c0);
        const double dt = t[i] - t[i - 1];
        const int sub = std::max(1, static_cast<int>(std::ceil(dt / kSubstep_s - 1e-9)));
        const double h = dt / sub;
        const double E0 = Emf(i - 1, delta_R_ohm), E1 = Emf(i, delta_R_ohm), r_ohm = bat_.r_ohm[i];
        for (int s = 0; s < sub; ++s) {
          // The autopilot updates the commands at its own rate and holds them in between: the
          // command acting at time τ is the one of its last tick, interpolated between the rows.
          // A step acts with the command in force at its start (as the simulator's loop does).
          const double tau = s * h;
          const double w = ap_rate_hz_ > 0 ? std::floor(tau * ap_rate_hz_ + 1e-9) / (ap_rate_hz_ * dt) : tau / dt;
          for (size_t m = 0; m < n_rot; ++m) cmd[m] = (1 - w) * c0[m] + w * c1[m];
          SetBattery((1 - w) * E0 + w * E1, r_ohm, v_.battery.max_current_A, &pv);
          vehicle::StepPowertrain(pv, cmd, h, &ps, &step_out);
        }
      }
      have_state = true;
      (*omega)[i] = ps.omega_radps;
      (*row_ok)[i] = true;
    }
  }

 private:
  bool CommandsAt(size_t i, std::vector<double>* c) const {
    for (size_t m = 0; m < c->size(); ++m) (*c)[m] = (*in_.mu[m])[i];
    return std::all_of(c->begin(), c->end(), [](double x) { return std::isfinite(x); });
  }
  double SagOf(size_t i, double delta_R_ohm) const {
    return delta_R_ohm != 0 && in_.I && std::isfinite((*in_.I)[i]) ? delta_R_ohm * (*in_.I)[i] : 0.0;
  }
  double Emf(size_t i, double delta_R_ohm) const { return bat_.emf_V[i] - SagOf(i, delta_R_ohm); }
  double RowBus(size_t i, double delta_R_ohm) const { return bat_.bus_V[i] - SagOf(i, delta_R_ohm); }

  const DynamicsInputs& in_;
  const vehicle::VehicleParams& v_;
  BatteryRows bat_;
  double ap_rate_hz_;  // the autopilot's control loop runs at the IMU rate (as ArduPilot's and the simulator's do)
};

// The kept (airborne, in-flight) samples' quantities besides the channel's residual.
struct Airborne {
  std::vector<Vec3> F_T, v_B;  // thrust force, body velocity
  std::vector<std::vector<double>> omega;  // rotor speeds
  std::vector<double> mass, omega_sum, current, height;
  std::vector<Eigen::Matrix3d> Rt;  // R_BN
  size_t dropped_ground = 0;
};

// The channel's residual accel − (thrust + drag)/m at the airborne flight rows, and what the
// candidates need there.
void CollectAirborne(const DynamicsInputs& in, const vehicle::VehicleParams& v,
                     const std::vector<std::vector<double>>& omega, const std::vector<bool>& row_ok,
                     const std::vector<realdata::RowKind>& row_kind, ChannelData* ch, Airborne* air) {
  const size_t n_rot = v.rotors.size();
  const double h0 = TakeOffHeight(in);
  for (size_t i = 0; i < in.rows; ++i) {
    if (!row_ok[i] || row_kind[i] != realdata::RowKind::kFlight) continue;
    const Vec3 meas((*in.ax)[i], (*in.ay)[i], (*in.az)[i]);
    const Vec3 vel((*in.vn)[i], (*in.ve)[i], (*in.vd)[i]);
    Eigen::Quaterniond q((*in.q[0])[i], (*in.q[1])[i], (*in.q[2])[i], (*in.q[3])[i]);
    if (!meas.allFinite() || !vel.allFinite() || !q.coeffs().allFinite() || !(q.norm() > 0.5)) continue;
    q.normalize();
    bool armed = true;
    for (size_t m = 0; m < n_rot; ++m) armed = armed && (*in.mu[m])[i] > 0;
    double hgt = std::nan("");
    if (in.alt && std::isfinite((*in.alt)[i])) hgt = in.alt_sign * (*in.alt)[i] - h0;
    // Ground contact forces are not in the model: only airborne samples (height known and clear).
    if (!armed || !(hgt > kMinHeight_m)) {
      ++air->dropped_ground;
      continue;
    }
    const Eigen::Matrix3d R_BN = q.toRotationMatrix().transpose();
    const Vec3 vb = R_BN * vel;
    double m_kg = v.mass_kg + (in.payload && std::isfinite((*in.payload)[i]) ? (*in.payload)[i] : v.payload.mass_kg);
    const Vec3 Ft = vehicle::RotorWrench(v, omega[i]).force_B_N;
    const Vec3 pred = (Ft + DragForce_B(v.drag, vb)) / m_kg;
    double wsum = 0;
    for (size_t m = 0; m < n_rot; ++m) wsum += omega[i][m];
    ch->t.push_back((*in.t)[i]);
    ch->y.emplace_back(meas - pred);
    ch->measured.push_back(meas);
    ch->row.push_back(static_cast<int>(i));
    air->F_T.push_back(Ft);
    air->omega.push_back(omega[i]);
    air->v_B.push_back(vb);
    air->mass.push_back(m_kg);
    air->omega_sum.push_back(wsum);
    air->current.push_back(in.I ? (*in.I)[i] : std::nan(""));
    air->height.push_back(hgt);
    air->Rt.push_back(R_BN);
  }
}

// Thrust force at the kept samples from a replay variant.
std::vector<Vec3> ThrustAtKept(const vehicle::VehicleParams& v, const ChannelData& ch,
                               const std::vector<std::vector<double>>& w, const std::vector<bool>& ok) {
  std::vector<Vec3> F(ch.t.size(), Vec3::Zero());
  for (size_t k = 0; k < F.size(); ++k) {
    const size_t i = static_cast<size_t>(ch.row[k]);
    if (ok[i]) F[k] = vehicle::RotorWrench(v, w[i]).force_B_N;
  }
  return F;
}

// A one-parameter effect computed by replays, g(θ) (the specific force it adds at the kept samples,
// g(0) = 0), fitted by the secant method through replays: θ minimises Σ|y − (g(θ) − mean)|² (the
// mean removed where the channel has a bias nuisance), starting from the secant through 0 and
// θ_start. Returns θ and g(θ); the candidate's regressor is then g(θ)/θ, the secant through the
// fit, so the linear coefficient equals the physical parameter there (a fixed secant point would
// bias the fit of an effect that is nonlinear in θ towards that point).
struct SecantFit {
  double theta = 0.0;
  std::vector<Vec3> g;
};

template <typename Effect>
SecantFit FitBySecant(const ChannelData& ch, const Effect& effect, double theta_start, double lo, double hi) {
  const size_t n = ch.t.size();
  auto demeaned_dot = [&](const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
    Vec3 ma = Vec3::Zero(), mb = Vec3::Zero();
    if (ch.bias_nuisance) {
      for (size_t k = 0; k < n; ++k) {
        ma += a[k];
        mb += b[k];
      }
      ma /= static_cast<double>(n);
      mb /= static_cast<double>(n);
    }
    double s = 0;
    for (size_t k = 0; k < n; ++k) s += (a[k] - ma).dot(b[k] - mb);
    return s;
  };
  double ta = 0.0, tb = theta_start;
  std::vector<Vec3> ga(n, Vec3::Zero()), gb = effect(tb);
  const double tol = 1e-4 * std::fabs(theta_start);
  for (int it = 0; it < 8; ++it) {
    std::vector<Vec3> J(n), r(n);
    for (size_t k = 0; k < n; ++k) {
      J[k] = (gb[k] - ga[k]) / (tb - ta);
      r[k] = ch.y[k] - gb[k];
    }
    const double jj = demeaned_dot(J, J);
    if (!(jj > 0)) break;
    const double tn = std::clamp(tb + demeaned_dot(J, r) / jj, lo, hi);
    if (std::fabs(tn - tb) < tol) break;
    ta = tb;
    ga = std::move(gb);
    tb = tn;
    gb = effect(tb);
  }
  return {tb, std::move(gb)};
}

// Column x with the rows of the other phase (i % 2 != phase) replaced by the interpolation of their
// neighbours in time, where both are finite and the gap between them is a replay step (kMaxRowGap_s
// each): the column as a log at half the row rate would give it to the replay.
std::vector<double> HalfRateColumn(const std::vector<double>& t, const std::vector<double>& x, size_t phase) {
  std::vector<double> h = x;
  for (size_t i = 1; i + 1 < x.size(); ++i) {
    if (i % 2 == phase || !std::isfinite(x[i - 1]) || !std::isfinite(x[i + 1])) continue;
    const double span = t[i + 1] - t[i - 1];
    if (!(span > 0) || !(span <= 2 * kMaxRowGap_s)) continue;
    const double w = (t[i] - t[i - 1]) / span;
    h[i] = (1 - w) * x[i - 1] + w * x[i + 1];
  }
  return h;
}

// motor_time_constant: the rotors respond slower than configured; the replay with every rotor's
// inertia scaled by (1 + κ) (τ ∝ J at a given speed), fitted by the secant method over replays;
// its columns (no regressor yet) give the extra time constant at hover Δτ = κ·τ_hover.
Candidate MotorTimeConstant(const PowertrainReplay& replay, const vehicle::VehicleParams& v, const ChannelData& ch,
                            const Airborne& air) {
  Candidate mt = MakeCandidate("motor_time_constant", {"tau_extra_s"}, {1.0}, "s", "dthrust_dt_N_per_s");
  const double tau_h = HoverRotorTimeConstant_s(v);
  if (!(tau_h > 0)) return mt;
  const size_t n = ch.t.size();
  std::vector<std::vector<double>> w_k;
  std::vector<bool> ok_k;
  auto effect = [&](double kappa) {
    replay.Run(1.0 + kappa, 0.0, &w_k, &ok_k);
    std::vector<Vec3> F = ThrustAtKept(v, ch, w_k, ok_k);
    for (size_t k = 0; k < n; ++k) F[k] = (F[k] - air.F_T[k]) / air.mass[k];
    return F;
  };
  constexpr double kKappaMin = -0.8, kKappaMax = 10.0;
  SecantFit fit = FitBySecant(ch, effect, 1.0, kKappaMin, kKappaMax);
  if (std::fabs(fit.theta) < 0.05) {  // secant through a visible lag so the regressor is not noise
    fit.theta = 0.5;
    fit.g = effect(fit.theta);
  }
  for (size_t k = 0; k < n; ++k) mt.X.emplace_back(fit.g[k] / (fit.theta * tau_h));  // coefficient = Δτ at the fit
  return mt;
}

// thrust_scale: k_T (or the mass) off by a factor, from the replay's thrust. Over one flight's
// thrust range it is nearly collinear with battery_sag (both grow with the thrust); the bootstrap
// then says "ambiguous".
Candidate ThrustScale(const Airborne& air) {
  Candidate ts = MakeCandidate("thrust_scale", {"thrust_scale_minus_1"}, {1.0}, "1", "thrust_N");
  for (size_t k = 0; k < air.F_T.size(); ++k) {
    ts.X.emplace_back(air.F_T[k] / air.mass[k]);
    ts.regressor.push_back(air.F_T[k].norm());
  }
  return ts;
}

// rotor_drag from the replay's rotor speeds: regressor in units of 10⁴ (rad/s)·(m/s) so the
// coefficient is O(1).
Candidate RotorDrag(const Airborne& air) {
  constexpr double kDragUnit = 1e-4;
  Candidate rd = MakeCandidate("rotor_drag", {"rotor_drag_N_per_radps_mps"}, {kDragUnit}, "N/(rad/s*m/s)", "omega_sum_x_speed");
  for (size_t k = 0; k < air.omega_sum.size(); ++k) {
    rd.X.emplace_back(-air.omega_sum[k] * kDragUnit * Vec3(air.v_B[k].x(), air.v_B[k].y(), 0.0) / air.mass[k]);
    rd.regressor.push_back(air.omega_sum[k] * std::hypot(air.v_B[k].x(), air.v_B[k].y()));
  }
  return rd;
}

// thrust_scale, rotor_drag and motor_time_constant.
void AddThrustCandidates(const PowertrainReplay& replay, const vehicle::VehicleParams& v, const Airborne& air,
                         ChannelData* ch) {
  const size_t n = ch->t.size();
  Candidate mt = MotorTimeConstant(replay, v, *ch, air);
  const auto& F_T = air.F_T;
  for (size_t k = 0; k < n; ++k) {
    const size_t a = k > 0 && ch->row[k - 1] == ch->row[k] - 1 ? k - 1 : k;
    const size_t b = k + 1 < n && ch->row[k + 1] == ch->row[k] + 1 ? k + 1 : k;
    mt.regressor.push_back(b > a ? (F_T[b] - F_T[a]).norm() / (ch->t[b] - ch->t[a]) : 0.0);
  }
  ch->candidates.push_back(ThrustScale(air));
  ch->candidates.push_back(RotorDrag(air));
  if (!mt.X.empty()) ch->candidates.push_back(std::move(mt));
}

// battery_sag: the ESCs see V − ΔR·I; the secant through the fitted ΔR over replays with the ESC
// voltage lowered by ΔR·I (rotor dynamics included).
void AddBatterySag(const PowertrainReplay& replay, const DynamicsInputs& in, const vehicle::VehicleParams& v,
                   const Airborne& air, ChannelData* ch) {
  bool current_ok = in.I != nullptr && in.current_usable;
  for (double I : air.current) current_ok = current_ok && std::isfinite(I);
  if (!current_ok) {
    ch->not_available.emplace_back(in.current_usable ? "battery_sag (no current_A column)"
                                                     : "battery_sag (no usable power monitor)");
    return;
  }
  // The thrust lost to a lower ESC voltage is not linear in ΔR (T ∝ ω² while ω follows the
  // voltage: the loss per ohm shrinks as ΔR grows, by ~I/(2V) relative per ohm, ~0.5 % per 10 mΩ
  // at hover), so the regressor is the secant through the fitted ΔR (FitBySecant), not through a
  // fixed point. Range: the plausibility table's battery_sag (0..1 Ω) widened to negative values
  // so that a fit near 0 is not pinned at the bound.
  constexpr double kDeltaRStart_ohm = 0.05, kDeltaRMin_ohm = -0.5, kDeltaRMax_ohm = 1.0;
  std::vector<std::vector<double>> w_s;
  std::vector<bool> ok_s;
  auto effect = [&](double delta_R_ohm) {
    replay.Run(1.0, delta_R_ohm, &w_s, &ok_s);
    std::vector<Vec3> F = ThrustAtKept(v, *ch, w_s, ok_s);
    for (size_t k = 0; k < F.size(); ++k) F[k] = (F[k] - air.F_T[k]) / air.mass[k];
    return F;
  };
  SecantFit fit = FitBySecant(*ch, effect, kDeltaRStart_ohm, kDeltaRMin_ohm, kDeltaRMax_ohm);
  if (std::fabs(fit.theta) < 0.2 * kDeltaRStart_ohm) {  // a secant through a visible sag, not through noise
    fit.theta = kDeltaRStart_ohm;
    fit.g = effect(fit.theta);
  }
  Candidate bs = MakeCandidate("battery_sag", {"delta_R_ohm"}, {1.0}, "ohm", "current_A");
  for (size_t k = 0; k < ch->t.size(); ++k) {
    bs.X.emplace_back(fit.g[k] / fit.theta);
    bs.regressor.push_back(air.current[k]);
  }
  ch->candidates.push_back(std::move(bs));
}

// ground_effect, per rotor as the simulator applies it (vehicle::RotorAeroWrench): rotor i's thrust
// T_i = k_T·ω_i² along its axis gains 1/(1 − a/(16 z_i²)) − 1, a = R², z_i its hub's height above
// the ground, clamped at R/2 (a·u_i ≤ 1/4), with
//   z_i = h_rest + h − (R_NB·r_i)_D,   h the CG height above the take-off point,
// h_rest the CG height when the landing gear stands on the ground (the simulator's gear for this
// vehicle file, sim::BodyParamsFor) and r_i the rotor's position: one rotor height for all rotors
// (the CG's plus a constant) puts the tilted vehicle's low rotors too high and its high rotors too low.
void AddGroundEffect(const vehicle::VehicleParams& v, const Airborne& air, ChannelData* ch) {
  const size_t n = ch->t.size(), n_rot = v.rotors.size();
  const double h_rest = sim::RestingHeight_m(sim::BodyParamsFor(v, sim::WorldParams{}, 0.0));
  // u[k][i] = 1/(16 z_i²) at the hub heights of sample k; the rotors' thrust vectors T_i·axis_i.
  std::vector<std::vector<double>> u(n, std::vector<double>(n_rot));
  std::vector<std::vector<Vec3>> T(n, std::vector<Vec3>(n_rot));
  double z_min = 1e300;
  for (size_t k = 0; k < n; ++k) {
    for (size_t i = 0; i < n_rot; ++i) {
      const auto& r = v.rotors[i];
      const double z = h_rest + air.height[k] - (air.Rt[k].transpose() * r.position_B_m).z();
      z_min = std::min(z_min, z);
      u[k][i] = z > 0 ? 1.0 / (16.0 * z * z) : std::numeric_limits<double>::infinity();
      T[k][i] = r.k_T_Nprps2 * air.omega[k][i] * air.omega[k][i] * r.axis_B / air.mass[k];
    }
  }
  if (!(z_min < 1.0)) {
    ch->not_available.emplace_back("ground_effect (no airborne samples with a rotor within 1 m of the ground)");
    return;
  }
  // Gain − 1 of one rotor and its derivative in a; at or below the clamp z = R/2 (a·u ≥ 1/4) the
  // gain is 4/3 whatever a is.
  auto extra = [](double a, double uk, double* d_da) {
    const double au = a * uk;
    if (!(au < 0.25)) {
      *d_da = 0.0;
      return 1.0 / 0.75 - 1.0;
    }
    *d_da = uk / ((1.0 - au) * (1.0 - au));
    return 1.0 / (1.0 - au) - 1.0;
  };
  auto sum = [&](size_t k, double a, Vec3* d_da) {
    Vec3 g = Vec3::Zero();
    d_da->setZero();
    for (size_t i = 0; i < n_rot; ++i) {
      double d = 0;
      g += T[k][i] * extra(a, u[k][i], &d);
      *d_da += T[k][i] * d;
    }
    return g;
  };
  auto model = [&](size_t k, const Eigen::VectorXd& th, Vec3* g, Mat3X* J) {
    Vec3 d;
    *g = sum(k, th[0], &d);
    *J = d;
  };
  // R up to the plausibility table's 1 m (a ≤ 1 m²).
  const Eigen::VectorXd a0 =
      GaussNewton(ch->y, ch->bias_nuisance, 1, model, Eigen::VectorXd::Zero(1), Eigen::VectorXd::Constant(1, 1.0));
  const double a = std::max(a0[0], 1e-4);  // secant point; tangent at a → 0
  Candidate ge = MakeCandidate("ground_effect", {"radius_sq_m2"}, {1.0}, "m", "height_m");
  for (size_t k = 0; k < n; ++k) {
    Vec3 d;
    ge.X.emplace_back(sum(k, a, &d) / a);
    ge.regressor.push_back(air.height[k]);
  }
  ch->candidates.push_back(std::move(ge));
}

// wind: a constant horizontal wind seen through the configured airframe drag.
void AddWind(const vehicle::VehicleParams& v, const Airborne& air, ChannelData* ch) {
  const auto& dr = v.drag;
  if (!(dr.linear_Nspm.norm() + dr.quadratic_Ns2pm2.norm() > 0)) {
    ch->not_available.emplace_back("wind (the vehicle configures no airframe drag to see it through)");
    return;
  }
  const auto& v_B = air.v_B;
  const auto& Rt = air.Rt;
  auto model = [&](size_t k, const Eigen::VectorXd& th, Vec3* g, Mat3X* J) {
    const Vec3 w_B = Rt[k].leftCols<2>() * th;
    const Vec3 a_B = v_B[k] - w_B;
    *g = (DragForce_B(dr, a_B) - DragForce_B(dr, v_B[k])) / air.mass[k];
    const Vec3 slope = dr.linear_Nspm + 2.0 * dr.quadratic_Ns2pm2.cwiseProduct(a_B.cwiseAbs());  // −∂F/∂a
    *J = slope.asDiagonal() * Rt[k].leftCols<2>() / air.mass[k];
  };
  constexpr double kMaxWind_mps = 30.0;
  const Eigen::VectorXd w0 = GaussNewton(ch->y, ch->bias_nuisance, 2, model, Eigen::VectorXd::Constant(2, -kMaxWind_mps),
                                         Eigen::VectorXd::Constant(2, kMaxWind_mps));
  Candidate wi = MakeCandidate("wind", {"wind_N_mps", "wind_E_mps"}, {1.0, 1.0}, "m/s", "speed_mps");
  for (size_t k = 0; k < ch->t.size(); ++k) {
    // Secant slope per body axis through the working point (tangent where the wind component is ~0).
    const Vec3 b = Rt[k].leftCols<2>() * w0;
    const Vec3 dF = DragForce_B(dr, v_B[k] - b) - DragForce_B(dr, v_B[k]);
    Vec3 slope;
    for (int i = 0; i < 3; ++i) {
      slope[i] = std::fabs(b[i]) > 1e-3 ? dF[i] / b[i]
                                        : dr.linear_Nspm[i] + 2.0 * dr.quadratic_Ns2pm2[i] * std::fabs(v_B[k][i]);
    }
    wi.X.emplace_back(slope.asDiagonal() * Rt[k].leftCols<2>() / air.mass[k]);
    wi.regressor.push_back(std::hypot(v_B[k].x(), v_B[k].y()));
  }
  ch->candidates.push_back(std::move(wi));
}

// The channel with the replay's between-row inputs (motor commands, bus voltage and current) read at
// half the log's row rate, for each phase (even rows kept, odd rows kept): each holds one
// realisation of the reconstruction's error at twice the row interval (AnalyzeInertial's row-rate
// term). Its residual, and the candidates built from the replay's rotor speeds or fitted to the
// residual (thrust_scale, rotor_drag, ground_effect, wind) rebuilt from its own replay and residual:
// a rotor speed reconstructed between rows enters rotor_drag's and ground_effect's regressors as
// it enters the residual. A kept sample whose half-rate replay has no rotor state keeps the
// log-rate values. motor_time_constant and battery_sag keep their log-rate regressors (differences
// of whole replays, which a secant fit per phase would repeat).
std::vector<ChannelData::RowRateVariant> HalfRateVariants(const DynamicsInputs& in, const vehicle::VehicleParams& v,
                                                          const ChannelData& ch, const Airborne& air) {
  const size_t n = ch.t.size(), n_rot = v.rotors.size();
  std::vector<ChannelData::RowRateVariant> variants;
  for (size_t phase = 0; phase < 2; ++phase) {
    DynamicsInputs h = in;
    std::vector<std::vector<double>> mu;
    for (const auto* m : in.mu) mu.push_back(HalfRateColumn(*in.t, *m, phase));
    for (size_t m = 0; m < mu.size(); ++m) h.mu[m] = &mu[m];
    const std::vector<double> V = in.V ? HalfRateColumn(*in.t, *in.V, phase) : std::vector<double>();
    const std::vector<double> I = in.I ? HalfRateColumn(*in.t, *in.I, phase) : std::vector<double>();
    if (in.V) h.V = &V;
    if (in.I) h.I = &I;
    std::vector<std::vector<double>> w;
    std::vector<bool> ok;
    PowertrainReplay(h, v).Run(1.0, 0.0, &w, &ok);
    ChannelData half;
    half.t = ch.t;
    half.y = ch.y;
    half.row = ch.row;
    half.bias_nuisance = ch.bias_nuisance;
    Airborne air_h = air;
    for (size_t k = 0; k < n; ++k) {
      const size_t i = static_cast<size_t>(ch.row[k]);
      if (!ok[i]) continue;
      const Vec3 F = vehicle::RotorWrench(v, w[i]).force_B_N;
      half.y[k] -= (F - air.F_T[k]) / air.mass[k];
      air_h.F_T[k] = F;
      air_h.omega[k] = w[i];
      air_h.omega_sum[k] = 0.0;
      for (size_t m = 0; m < n_rot; ++m) air_h.omega_sum[k] += w[i][m];
    }
    half.candidates.push_back(ThrustScale(air_h));
    half.candidates.push_back(RotorDrag(air_h));
    AddGroundEffect(v, air_h, &half);
    AddWind(v, air_h, &half);
    variants.push_back({std::move(half.y), std::move(half.candidates)});
  }
  return variants;
}

}  // namespace

void ReplayDynamics(const logs::FlightLog& log, const vehicle::VehicleParams& v, const LogInputs& log_in,
                    const std::vector<realdata::RowKind>& row_kind, ReplayResult* out) {
  const char* kName = "dynamics";
  auto skip = [&](const std::string& why) { out->not_diagnosed.emplace_back(kName, why); };
  if (const std::string missing = MissingInputs(log, v.rotors.size()); !missing.empty()) {
    skip("open-loop dynamics replay needs " + missing);
    return;
  }
  // The replay's drag (and every wind candidate) is driven by the logged velocity, and its airborne
  // test by the height: a velocity that does not follow the accelerometer makes the channel meaningless.
  if (const realdata::VelocityCheck vc = realdata::CheckVelocityAgainstAccel(log, row_kind); !vc.ok) {
    skip(vc.why);
    return;
  }
  const DynamicsInputs in = FindInputs(log, v.rotors.size(), log_in.current_usable);
  const PowertrainReplay replay(in, v);
  std::vector<std::vector<double>> omega;
  std::vector<bool> row_ok;
  replay.Run(1.0, 0.0, &omega, &row_ok);

  ChannelData ch;
  ch.name = kName;
  ch.unit = "m/s^2";
  if (in.has_V && !in.V_usable) {
    ch.note = fmt::format("logged voltage_V (median {:.3g} V) is outside {}: no power monitor; the configured battery's "
                          "open-circuit voltage drives the replay", in.median_V, plausibility::RangeText("bus_voltage_V"));
  }
  const vehicle::NoiseParams& np = v.sensors.accel.noise;
  ch.bias_nuisance = np.bias_std > 0 || np.bias_walk_per_sqrt_s > 0;
  ch.bias_walk_per_sqrt_s = np.bias_walk_per_sqrt_s;
  ch.explain_above_noise = true;
  Airborne air;
  CollectAirborne(in, v, omega, row_ok, row_kind, &ch, &air);
  if (ch.t.empty()) {
    skip(fmt::format("no airborne samples with motor outputs (dropped {} on the ground or disarmed)", air.dropped_ground));
    return;
  }
  ch.half_rate = HalfRateVariants(in, v, ch, air);
  AddThrustCandidates(replay, v, air, &ch);
  AddBatterySag(replay, in, v, air, &ch);
  AddGroundEffect(v, air, &ch);
  AddWind(v, air, &ch);
  if (!ch.bias_nuisance) {
    Candidate off = MakeCandidate("bias", {"b_x", "b_y", "b_z"}, {1, 1, 1}, "m/s^2", "");
    for (size_t k = 0; k < ch.t.size(); ++k) off.X.emplace_back(Mat3X(Eigen::Matrix3d::Identity()));
    ch.candidates.push_back(std::move(off));
  }
  out->channels.push_back(std::move(ch));
}

}  // namespace hexsim::gap::internal
