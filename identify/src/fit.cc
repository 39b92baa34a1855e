// Identify(): block least squares on the flight samples, profiled motor lag, block bootstrap.
#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Cholesky>
#include <fmt/format.h>

#include "hexsim/common/plausibility.h"
#include "hexsim/common/rotation.h"
#include "hexsim/vehicle/powertrain.h"
#include "samples.h"

namespace hexsim::identify {
namespace internal {
namespace {

// Normal equations of one block: A = Σ x·xᵀ, b = Σ x·y, yy = Σ y², n samples.
struct Normal {
  Eigen::MatrixXd A;
  Eigen::VectorXd b, xsum;
  double yy = 0.0, n = 0.0, ysum = 0.0;
  explicit Normal(int p = 0)
      : A(Eigen::MatrixXd::Zero(p, p)), b(Eigen::VectorXd::Zero(p)), xsum(Eigen::VectorXd::Zero(p)) {}
  void Add(const Eigen::VectorXd& x, double y) {
    A.noalias() += x * x.transpose();
    b.noalias() += x * y;
    xsum += x;
    yy += y * y;
    ysum += y;
    n += 1;
  }
  // The same data with every y shifted by δ.
  void ShiftY(double delta) {
    yy += 2.0 * delta * ysum + delta * delta * n;
    ysum += delta * n;
    b += delta * xsum;
  }
  void AddScaled(const Normal& o, double w) {
    A += w * o.A;
    b += w * o.b;
    xsum += w * o.xsum;
    yy += w * o.yy;
    ysum += w * o.ysum;
    n += w * o.n;
  }
  // Least squares with a ridge of 1e-12 on the column-scaled (unit-diagonal) normal matrix: the
  // regularisation is the same for every column whatever its units. A ridge on the raw matrix, sized
  // by its trace, would pull a small-scale column (the constant or the charge drawn, beside a current
  // in tens of amperes) towards 0 and bias the others (it moved a noiseless battery resistance by
  // 1.5e-4 of its value, outside its bootstrap interval).
  Eigen::VectorXd Solve() const {
    const Eigen::VectorXd d = A.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
    const Eigen::MatrixXd As = d.asDiagonal() * A * d.asDiagonal();
    const Eigen::VectorXd z = (As + 1e-12 * Eigen::MatrixXd::Identity(A.rows(), A.cols())).ldlt().solve(d.cwiseProduct(b));
    return d.cwiseProduct(z);
  }
  double Sse(const Eigen::VectorXd& c) const { return yy - 2.0 * c.dot(b) + c.dot(A * c); }
};

// Per-block statistics of every output (vertical and yaw per τ).
struct BlockStats {
  std::vector<std::vector<Normal>> vertical, yaw;  // [τ][block]
  std::vector<Normal> lateral, battery;            // [block]
  std::vector<Eigen::Vector3d> gyro2, accel2;      // Σ Δ² per axis, [block]
  std::vector<double> dn;                          // Δ pairs, [block]
};

// The coefficients one (resampled) data set gives.
struct Coeffs {
  size_t tau = 0;
  Eigen::VectorXd vert, yaw, lat, batt;
  Eigen::Vector3d gyro_sigma = Eigen::Vector3d::Zero(), accel_sigma = Eigen::Vector3d::Zero();
};

bool ExpoFixed(double expo) { return std::isfinite(expo); }

// Vertical regressors: fixed expo [φ_e, v_z]; free [1, S1, S2, v_z] (per motor: a0 + a1·x + a2·x²).
Eigen::VectorXd VerticalX(const FlightSamples& s, size_t k, size_t g, double expo) {
  const LaggedSums& L = s.sums[k];
  if (ExpoFixed(expo)) {
    Eigen::VectorXd x(2);
    x << (1 - expo) * L.S1[g] + expo * L.S2[g], s.v_B[k].z();
    return x;
  }
  Eigen::VectorXd x(4);
  x << static_cast<double>(s.motors), L.S1[g], L.S2[g], s.v_B[k].z();
  return x;
}

// Per-motor thrust curve (a0, a1, a2) from the vertical coefficients.
Eigen::Vector3d Curve(const Eigen::VectorXd& vert, double expo) {
  if (ExpoFixed(expo)) return {0.0, vert(0) * (1 - expo), vert(0) * expo};
  return {vert(0), vert(1), vert(2)};
}

// Yaw statistics are kept on [Z1, Z2, r, 1]; with the curve they become [Y, r, 1], Y = a1·Z1 + a2·Z2.
Normal YawReduced(const Normal& z, const Eigen::Vector3d& curve) {
  Eigen::MatrixXd T = Eigen::MatrixXd::Zero(4, 3);
  T(0, 0) = curve(1);
  T(1, 0) = curve(2);
  T(2, 1) = 1.0;
  T(3, 2) = 1.0;
  Normal r(3);
  r.A = T.transpose() * z.A * T;
  r.b = T.transpose() * z.b;
  r.xsum = T.transpose() * z.xsum;
  r.yy = z.yy;
  r.n = z.n;
  r.ysum = z.ysum;
  return r;
}

// fixed_tau >= 0: the lag at that grid index instead of the profiled one.
Coeffs FitWeighted(const BlockStats& st, const std::vector<double>& w, double expo, int fixed_tau = -1) {
  Coeffs c;
  double best = INFINITY;
  const int pv = ExpoFixed(expo) ? 2 : 4;
  for (size_t g = 0; g < kTauCount; ++g) {
    if (fixed_tau >= 0 && g != static_cast<size_t>(fixed_tau)) continue;
    Normal v(pv);
    for (size_t b = 0; b < w.size(); ++b) {
      if (w[b] > 0) v.AddScaled(st.vertical[g][b], w[b]);
    }
    const Eigen::VectorXd coef = v.Solve();
    const double sse = v.Sse(coef);
    if (sse < best) {
      best = sse;
      c.tau = g;
      c.vert = coef;
    }
  }
  Normal z(4), lat(4), bat(3);
  Eigen::Vector3d g2 = Eigen::Vector3d::Zero(), a2 = Eigen::Vector3d::Zero();
  double dn = 0;
  for (size_t b = 0; b < w.size(); ++b) {
    if (!(w[b] > 0)) continue;
    z.AddScaled(st.yaw[c.tau][b], w[b]);
    lat.AddScaled(st.lateral[b], w[b]);
    bat.AddScaled(st.battery[b], w[b]);
    g2 += w[b] * st.gyro2[b];
    a2 += w[b] * st.accel2[b];
    dn += w[b] * st.dn[b];
  }
  c.yaw = YawReduced(z, Curve(c.vert, expo)).Solve();
  c.lat = lat.Solve();
  c.batt = bat.n >= 3 ? bat.Solve() : Eigen::VectorXd::Constant(3, std::nan(""));
  if (dn > 0) {
    c.gyro_sigma = (g2 / (6 * dn)).cwiseSqrt();  // Var(Δ²) = 6σ² for white noise
    c.accel_sigma = (a2 / (6 * dn)).cwiseSqrt();
  }
  return c;
}

// Hover output: per-motor curve a0 + a1·x + a2·x² = g/n, smallest root in (0, 2]; NaN if none.
double HoverOutput(const Eigen::Vector3d& curve, size_t motors) {
  const double target = kGravity_mps2 / static_cast<double>(motors);
  auto f = [&](double x) { return curve(0) + curve(1) * x + curve(2) * x * x - target; };
  double lo = 0.0, hi = 2.0;
  if (f(lo) > 0 || f(hi) < 0) return std::nan("");
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (f(mid) < 0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// k_T multiplier s that makes the base vehicle hover at output u_h on a bus at V (bisection: the
// hover command falls as s grows). NaN when no s in [0.2, 5] does.
double ThrustScaleFor(const vehicle::VehicleParams& base, double u_h, double V) {
  if (!std::isfinite(u_h) || !(V > 0) || base.rotors.empty()) return std::nan("");
  const double T_each = (base.mass_kg + base.payload.mass_kg) * kGravity_mps2 / static_cast<double>(base.rotors.size());
  auto cmd = [&](double s) {
    vehicle::VehicleParams v = base;
    for (auto& r : v.rotors) r.k_T_Nprps2 *= s;
    return vehicle::CommandForThrust(v, 0, T_each, V);
  };
  double lo = 0.2, hi = 5.0;
  if (cmd(lo) < u_h || cmd(hi) > u_h) return std::nan("");
  for (int i = 0; i < 50; ++i) {
    const double mid = std::sqrt(lo * hi);
    (cmd(mid) > u_h ? lo : hi) = mid;
  }
  return std::sqrt(lo * hi);
}

}  // namespace
}  // namespace internal

namespace {

using internal::Coeffs;
using internal::FlightSamples;

// The identified parameters with their definitions; each one's physical range and its reason are in
// the shared plausibility table (hexsim/common/plausibility.h) under `range` (the name itself unless
// the range is stated per cell or per weight).
struct ParamSpec {
  const char* name;
  const char* unit;
  const char* range;
  const char* note;
};
const ParamSpec kSpecs[] = {
    {"thrust_full_output_mps2", "m/s^2", "thrust_to_weight", "specific thrust of one motor at full output and V_ref: per-motor curve a0 + a1·x + a2·x² at x = 1 (range: thrust_to_weight × g / motors)"},
    {"hover_output", "1", "hover_output", "motor output (0..1 of the PWM range) that holds the weight at V_ref"},
    {"thrust_scale", "1", "thrust_scale", "k_T of the base vehicle times this hovers it at hover_output on V_ref"},
    {"motor_time_constant_s", "s", "motor_time_constant_s", "first-order lag from motor output to thrust, profiled over 0–300 ms"},
    {"vertical_drag_per_mass_1ps", "1/s", "vertical_drag_per_mass_1ps", "−f_z gains d_z·v_z,B"},
    {"linear_drag_per_mass_1ps", "1/s", "linear_drag_per_mass_1ps", "f_x,y = −δ1·v − δ2·|v|·v (body axes; rotor drag included)"},
    {"quadratic_drag_per_mass_1pm", "1/m", "quadratic_drag_per_mass_1pm", "δ2 above"},
    {"yaw_torque_coefficient_m", "m", "yaw_torque_coefficient_m", "k_Q/k_T = κ·J_z/m from ṙ = κ·Σ s_i·T_i/m − ζ·r (J_z, m from the base)"},
    {"yaw_damping_1ps", "1/s", "yaw_damping_1ps", "ζ above"},
    {"battery_ocv_V", "V", "battery_ocv_cell_V", "open-circuit voltage at the start: V = V_oc − R·I − k_q·Q (range per cell × cells, cells = round(V_oc / 3.8))"},
    {"battery_resistance_ohm", "ohm", "battery_resistance_ohm", "pack internal resistance R above"},
    {"battery_charge_slope_V_per_Ah", "V/Ah", "battery_charge_slope_V_per_Ah", "k_q above (open-circuit voltage falling with charge drawn)"},
    {"gyro_noise_radps", "rad/s", "gyro_noise_radps", "white noise per logged IMU sample, RMS over axes, from second differences (vibration included; reported, not applied: a log's IMU samples are the autopilot's filtered ones)"},
    {"accel_noise_mps2", "m/s^2", "accel_noise_mps2", "the same for the accelerometer"},
};

double ExpoOf(const logs::FlightLog& log, std::string* source) {
  const auto& m = log.meta;
  // ArduPilot's MOT_THST_EXPO and PX4's THR_MDL_FAC are the same model: thrust ∝ (1−e)·x + e·x².
  for (const char* name : {"MOT_THST_EXPO", "THR_MDL_FAC"}) {
    if (!m.contains("params") || !m["params"].is_object() || !m["params"].contains(name) || !m["params"][name].is_number()) continue;
    const double e = m["params"][name].get<double>();
    if (e >= -1.0 && e <= 1.0) {
      *source = std::string(name) + " (log)";
      return e;
    }
  }
  *source = "not logged: per-motor quadratic a0 + a1·x + a2·x² fitted";
  return std::nan("");
}

std::map<std::string, double> Derive(const Coeffs& c, const FlightSamples& s, const vehicle::VehicleParams& base,
                                     double expo) {
  std::map<std::string, double> d;
  const Eigen::Vector3d curve = internal::Curve(c.vert, expo);
  const double u_h = internal::HoverOutput(curve, s.motors);
  const double V_ref = s.V_ref > 0 ? s.V_ref : base.battery.OpenCircuitVoltage_V(base.battery.initial_soc);
  d["thrust_full_output_mps2"] = curve.sum();
  d["hover_output"] = u_h;
  d["thrust_scale"] = internal::ThrustScaleFor(base, u_h, V_ref);
  d["motor_time_constant_s"] = internal::kTauGrid_s[c.tau];
  d["vertical_drag_per_mass_1ps"] = c.vert(c.vert.size() - 1);
  d["linear_drag_per_mass_1ps"] = -c.lat(0);
  d["quadratic_drag_per_mass_1pm"] = -c.lat(1);
  d["yaw_torque_coefficient_m"] = c.yaw(0) * base.inertia_kgm2(2, 2) / (base.mass_kg + base.payload.mass_kg);
  d["yaw_damping_1ps"] = -c.yaw(1);
  d["battery_ocv_V"] = c.batt(0);
  d["battery_resistance_ohm"] = c.batt(1);
  d["battery_charge_slope_V_per_Ah"] = c.batt(2);
  d["gyro_noise_radps"] = std::sqrt(c.gyro_sigma.squaredNorm() / 3.0);
  d["accel_noise_mps2"] = std::sqrt(c.accel_sigma.squaredNorm() / 3.0);
  return d;
}

double Percentile(std::vector<double> v, double p) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double pos = p * static_cast<double>(v.size() - 1);
  const size_t i = static_cast<size_t>(pos);
  const double f = pos - static_cast<double>(i);
  return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

// Accumulates measured/predicted pairs of one output on held-out samples.
struct Score {
  double n = 0, sm = 0, smm = 0, sr = 0;
  void Add(double meas, double pred) {
    n += 1;
    sm += meas;
    smm += meas * meas;
    sr += (meas - pred) * (meas - pred);
  }
  HeldoutFit Result(const char* output, const char* unit) const {
    HeldoutFit h;
    h.output = output;
    h.unit = unit;
    h.samples = static_cast<size_t>(n);
    if (n < 2) return h;
    const double var = std::max(0.0, smm / n - (sm / n) * (sm / n));
    h.rms_measured = std::sqrt(var);
    h.rms_residual = std::sqrt(sr / n);
    h.r2 = var > 0 ? 1.0 - (sr / n) / var : 0.0;
    return h;
  }
};

// Fit on the even fitting blocks, score on the odd blocks; traces of the vertical and yaw outputs.
void HeldoutAndTraces(const FlightSamples& s, const internal::BlockStats& st, double expo, const std::vector<int>& fit,
                      IdentifyResult* res) {
  using namespace internal;
  std::vector<double> w(st.lateral.size(), 0.0);
  for (int b : fit) {
    if (b % 2 == 0) w[static_cast<size_t>(b)] = 1.0;
  }
  const Coeffs c = FitWeighted(st, w, expo);
  const Eigen::Vector3d curve = Curve(c.vert, expo);
  Score vert, yaw, lat, batt;
  Trace tv{"vertical specific force -f_z", "m/s^2", {}, {}, {}}, ty{"yaw acceleration", "rad/s^2", {}, {}, {}};
  const size_t step = std::max<size_t>(1, s.t_s.size() / 4000);
  for (size_t k = 0; k < s.t_s.size(); ++k) {
    if (s.block[k] % 2 == 0) continue;
    const size_t g = c.tau;
    const double pv = VerticalX(s, k, g, expo).dot(c.vert);
    const double Y = curve(1) * s.sums[k].Z1[g] + curve(2) * s.sums[k].Z2[g];
    const double py = c.yaw(0) * Y + c.yaw(1) * s.w_B[k].z() + c.yaw(2);
    vert.Add(-s.f_B[k].z(), pv);
    yaw.Add(s.r_dot[k], py);
    for (int a = 0; a < 2; ++a) {
      const double v = s.v_B[k](a);
      lat.Add(s.f_B[k](a), c.lat(0) * v + c.lat(1) * std::fabs(v) * v + c.lat(2 + a));
    }
    if (k % step == 0) {
      tv.t_s.push_back(s.t_s[k]);
      tv.measured.push_back(-s.f_B[k].z());
      tv.predicted.push_back(pv);
      ty.t_s.push_back(s.t_s[k]);
      ty.measured.push_back(s.r_dot[k]);
      ty.predicted.push_back(py);
    }
  }
  for (size_t k = 0; k < s.batt_V.size(); ++k) {
    if (s.batt_block[k] % 2 == 0 || !c.batt.allFinite()) continue;
    batt.Add(s.batt_V[k], c.batt(0) - c.batt(1) * s.batt_I[k] - c.batt(2) * s.batt_Q_Ah[k]);
  }
  res->heldout = {vert.Result("vertical_specific_force", "m/s^2"), yaw.Result("yaw_acceleration", "rad/s^2"),
                  lat.Result("lateral_specific_force", "m/s^2"), batt.Result("bus_voltage", "V")};
  res->traces = {tv, ty};
}

// How far the log's bus voltage may lie outside the base vehicle's battery (empty..full open-circuit
// voltage) for the base's powertrain to stand for the airframe: 25 %, one cell of a 4S pack. Beyond it
// the pack has another cell count, and a motor's thrust, which grows with the square of its voltage,
// is off by half or more (a 12S log on quad_x's 4S motors: 9 times).
constexpr double kBusVoltageMargin = 1.25;

// Why the base vehicle's powertrain cannot be driven with the log's voltage ("" when it can).
std::string VoltageMismatch(const FlightSamples& s, const vehicle::VehicleParams& base) {
  const double full_V = base.battery.OpenCircuitVoltage_V(1.0), empty_V = base.battery.OpenCircuitVoltage_V(0.0);
  if (!(s.V_ref > 0) || !(full_V > 0) || (s.V_ref <= kBusVoltageMargin * full_V && s.V_ref >= empty_V / kBusVoltageMargin)) {
    return "";
  }
  return fmt::format("the log's bus voltage {:.3g} V is outside the base vehicle's battery ({:.3g}..{:.3g} V) by more than "
                     "{:.0f} %: its motors would be driven at a voltage they never see, so neither vehicle's held-out "
                     "dynamics residual measures the vehicle (give --base with a vehicle of this airframe's battery)",
                     s.V_ref, empty_V, full_V, 100.0 * (kBusVoltageMargin - 1.0));
}

// The held-out dynamics residual of the base and of the identified vehicle (even-block fit).
void DynamicsComparison(const FlightSamples& s, const vehicle::VehicleParams& base, double expo,
                        const internal::BlockStats& st, const std::vector<int>& fit, IdentifyResult* res) {
  res->dynamics_not_comparable = VoltageMismatch(s, base);
  if (!res->dynamics_not_comparable.empty()) {
    res->dynamics_rms_base = res->dynamics_rms_identified = std::nan("");
    res->improves_on_base = false;
    return;
  }
  IdentifyResult even = *res;
  std::vector<double> w(st.lateral.size(), 0.0);
  for (int b : fit) {
    if (b % 2 == 0) w[static_cast<size_t>(b)] = 1.0;
  }
  const auto d = Derive(internal::FitWeighted(st, w, expo), s, base, expo);
  for (auto& [k, p] : even.params) {
    if (d.count(k)) p.value = d.at(k);
  }
  const vehicle::VehicleParams ident = ApplyIdentified(base, even);
  const double V_fallback = base.battery.OpenCircuitVoltage_V(base.battery.initial_soc);
  auto residual2 = [&](const vehicle::VehicleParams& v, size_t k) {
    double T = 0;
    const double V = s.V[k] > 0 && s.V_ref > 0 ? s.V[k] : V_fallback;
    for (size_t m = 0; m < s.motors; ++m) T += vehicle::ThrustForCommand(v, m, s.u[k][m], V);
    const Eigen::Vector3d& vb = s.v_B[k];
    const Eigen::Vector3d drag = -(v.drag.linear_Nspm.cwiseProduct(vb) +
                                   v.drag.quadratic_Ns2pm2.cwiseProduct(vb.cwiseAbs().cwiseProduct(vb)));
    const Eigen::Vector3d pred = (Eigen::Vector3d(0, 0, -T) + drag) / (v.mass_kg + v.payload.mass_kg);
    return (s.f_B[k] - pred).squaredNorm();
  };
  double sb = 0, si = 0, n = 0;
  for (size_t k = 0; k < s.t_s.size(); ++k) {
    if (s.block[k] % 2 == 0) continue;
    sb += residual2(base, k);
    si += residual2(ident, k);
    n += 1;
  }
  if (n > 0) {
    res->dynamics_rms_base = std::sqrt(sb / n);
    res->dynamics_rms_identified = std::sqrt(si / n);
  }
  res->improves_on_base = n > 0 && res->dynamics_rms_identified < res->dynamics_rms_base;
}

// Per-block sufficient statistics of every linear sub-model (vertical and yaw at each lag of the grid,
// lateral drag, battery) and the second differences' energy for the noise estimates.
internal::BlockStats AccumulateBlockStats(const FlightSamples& s, size_t G, double expo) {
  using namespace internal;
  BlockStats st;
  const int pv = ExpoFixed(expo) ? 2 : 4;
  st.vertical.assign(kTauCount, std::vector<Normal>(G, Normal(pv)));
  st.yaw.assign(kTauCount, std::vector<Normal>(G, Normal(4)));
  st.lateral.assign(G, Normal(4));
  st.battery.assign(G, Normal(3));
  st.gyro2.assign(G, Eigen::Vector3d::Zero());
  st.accel2.assign(G, Eigen::Vector3d::Zero());
  st.dn.assign(G, 0.0);
  Eigen::VectorXd zx(4), lx(4), bx(3);
  for (size_t k = 0; k < s.t_s.size(); ++k) {
    const size_t b = static_cast<size_t>(s.block[k]);
    for (size_t g = 0; g < kTauCount; ++g) {
      st.vertical[g][b].Add(VerticalX(s, k, g, expo), -s.f_B[k].z());
      zx << s.sums[k].Z1[g], s.sums[k].Z2[g], s.w_B[k].z(), 1.0;
      st.yaw[g][b].Add(zx, s.r_dot[k]);
    }
    for (int a = 0; a < 2; ++a) {
      const double v = s.v_B[k](a);
      lx << v, std::fabs(v) * v, a == 0 ? 1.0 : 0.0, a == 1 ? 1.0 : 0.0;
      st.lateral[b].Add(lx, s.f_B[k](a));
    }
  }
  for (size_t k = 0; k < s.batt_V.size(); ++k) {
    bx << 1.0, -s.batt_I[k], -s.batt_Q_Ah[k];
    st.battery[static_cast<size_t>(s.batt_block[k])].Add(bx, s.batt_V[k]);
  }
  for (size_t k = 0; k < s.d_gyro.size(); ++k) {
    const size_t b = static_cast<size_t>(s.d_block[k]);
    st.gyro2[b] += s.d_gyro[k].cwiseAbs2();
    st.accel2[b] += s.d_accel[k].cwiseAbs2();
    st.dn[b] += 1;
  }
  return st;
}

// The model-error half-widths added in quadrature to each bootstrap interval (see the comments inside).
std::map<std::string, double> ModelErrorShifts(const internal::BlockStats& st, const FlightSamples& s,
                                               const vehicle::VehicleParams& base, double expo,
                                               const std::vector<double>& w_fit,
                                               const std::map<std::string, double>& value,
                                               const std::map<std::string, std::vector<double>>& boot) {
  using namespace internal;
  const size_t G = st.battery.size();
  Eigen::VectorXd bx(3);
  // Model-error terms, each added to every interval in quadrature (the largest change of the point
  // fit over the alternatives): (1) the accelerometer's constant bias cannot be told from thrust in
  // hover: the vertical specific force shifted by ±1.96·σ_b (σ_b from the base vehicle's
  // accelerometer: bias_std and its walk over the flight); (2) the charge drawn is a sum over the
  // sampled current: the right instead of the left Riemann sum.
  std::map<std::string, double> bias_shift;
  auto shift_by = [&](const BlockStats& alt) {
    for (const auto& [k, v] : Derive(FitWeighted(alt, w_fit, expo), s, base, expo)) {
      if (std::isfinite(v - value.at(k))) bias_shift[k] = std::max(bias_shift[k], std::fabs(v - value.at(k)));
    }
  };
  const double flight_s = s.t_s.empty() ? 0.0 : s.t_s.back() - s.t_s.front();
  const double sigma_b = std::hypot(base.sensors.accel.noise.bias_std,
                                    base.sensors.accel.noise.bias_walk_per_sqrt_s * std::sqrt(flight_s));
  for (double sign : {-1.0, 1.0}) {
    BlockStats shifted = st;
    for (auto& per_tau : shifted.vertical) {
      for (auto& nb : per_tau) nb.ShiftY(sign * 1.96 * sigma_b);
    }
    shift_by(shifted);
  }
  {
    BlockStats right = st;
    right.battery.assign(G, Normal(3));
    for (size_t k = 0; k < s.batt_V.size(); ++k) {
      bx << 1.0, -s.batt_I[k], -s.batt_Q_right_Ah[k];
      right.battery[static_cast<size_t>(s.batt_block[k])].Add(bx, s.batt_V[k]);
    }
    shift_by(right);
  }
  // (3) the motor lag is known only within its interval, and the parameters fitted at the profiled lag
  // move with it (the yaw coefficient, fitted beside the yaw damping, by ~2 % per millisecond: a 10-ms
  // grid step moved it by 20 %, while the resamples of the bootstrap, on the same grid, mostly kept the
  // same lag). Each parameter is refitted with the lag at the ends of the lag's own interval (half-way
  // to the next grid value, as that interval states: the mean of the fits at the two grid values).
  std::map<std::string, double> lag_shift;
  {
    const std::vector<double>& bt = boot.at("motor_time_constant_s");
    const double tau0 = value.at("motor_time_constant_s");
    const double db = bias_shift["motor_time_constant_s"];
    const double t_lo = tau0 - std::hypot(tau0 - Percentile(bt, 0.025), db);
    const double t_hi = tau0 + std::hypot(Percentile(bt, 0.975) - tau0, db);
    const double* g0 = std::begin(kTauGrid_s);
    const double* g1 = std::end(kTauGrid_s);
    const double* lo = std::lower_bound(g0, g1, t_lo - 1e-12);
    const double* hi = std::lower_bound(g0, g1, t_hi - 1e-12);
    auto fit_at = [&](const double* g) { return Derive(FitWeighted(st, w_fit, expo, static_cast<int>(g - g0)), s, base, expo); };
    auto end_shift = [&](const double* a, const double* b) {  // the fit half-way between grid values a and b
      const auto fa = fit_at(a), fb = fit_at(b);
      for (const auto& [k, v] : fa) {
        const double d = 0.5 * (v + fb.at(k)) - value.at(k);
        if (std::isfinite(d) && k != "motor_time_constant_s") lag_shift[k] = std::max(lag_shift[k], std::fabs(d));
      }
    };
    if (lo != g1) end_shift(lo != g0 ? lo - 1 : lo, lo);
    if (hi != g1) end_shift(hi, hi + 1 != g1 ? hi + 1 : hi);
  }
  for (auto& [k, v] : lag_shift) bias_shift[k] = std::max(bias_shift[k], v);
  return bias_shift;
}

// One reported parameter per kSpecs row: value, interval (bootstrap percentile widened by the
// model-error shift), physical range, and whether the vehicle file applies it.
void FillParams(const std::map<std::string, double>& value, const std::map<std::string, std::vector<double>>& boot,
                const std::map<std::string, double>& bias_shift, const FlightSamples& s, IdentifyResult* out) {
  using namespace internal;
  IdentifyResult& res = *out;
  auto shift_of = [&bias_shift](const std::string& k) {
    const auto it = bias_shift.find(k);
    return it == bias_shift.end() ? 0.0 : it->second;
  };
  for (const ParamSpec& sp : kSpecs) {
    Param p;
    p.value = value.at(sp.name);
    const double db = shift_of(sp.name);
    p.ci95[0] = p.value - std::hypot(p.value - Percentile(boot.at(sp.name), 0.025), db);
    p.ci95[1] = p.value + std::hypot(Percentile(boot.at(sp.name), 0.975) - p.value, db);
    if (std::string(sp.name) == "motor_time_constant_s") {
      // A profiled value is known only to within its grid cell: the interval reaches half-way to
      // the neighbouring grid values.
      const double* g0 = std::begin(kTauGrid_s);
      const double* g1 = std::end(kTauGrid_s);
      const double* lo = std::lower_bound(g0, g1, p.ci95[0] - 1e-12);
      const double* hi = std::lower_bound(g0, g1, p.ci95[1] - 1e-12);
      if (lo != g0 && lo != g1) p.ci95[0] = 0.5 * (*(lo - 1) + *lo);
      if (hi != g1 && hi + 1 != g1) p.ci95[1] = 0.5 * (*hi + *(hi + 1));
      p.ci95[0] = std::max(p.ci95[0], *g0);  // nothing outside the profiled grid was tried
      p.ci95[1] = std::min(p.ci95[1], *(g1 - 1));
    }
    p.unit = sp.unit;
    p.note = sp.note;
    const plausibility::PhysicalRange* pr = plausibility::FindRange(sp.range);
    double per = 1.0;  // the table states some ranges per weight or per cell
    if (std::string(sp.name) == "thrust_full_output_mps2") {
      per = kGravity_mps2 / static_cast<double>(s.motors);
    } else if (std::string(sp.name) == "battery_ocv_V") {
      per = std::isfinite(p.value) ? std::max(1.0, std::round(p.value / 3.8)) : 1.0;
    }
    p.range[0] = pr ? pr->lo * per : -INFINITY;
    p.range[1] = pr ? pr->hi * per : INFINITY;
    p.range_reason = pr ? pr->reason : "no stated range";
    if (!std::isfinite(p.value) || !p.plausible()) p.source = "model mismatch";
    p.applied = p.source == "fitted" && p.ci95[0] >= p.range[0] && p.ci95[1] <= p.range[1];
    if (p.source == "fitted" && !p.applied) p.not_applied = "the interval leaves the physical range";
    // The profile's best value at the grid's last (slowest) lag: the held-out fit wants a slower
    // response than the grid holds (a log whose outputs lead the thrust by a delay, filtering the
    // first-order lag does not describe), so the value is a lower bound, not the motor's lag.
    if (std::string(sp.name) == "motor_time_constant_s" && p.source == "fitted" &&
        p.value >= kTauGrid_s[kTauCount - 1]) {
      p.applied = false;
      p.not_applied = fmt::format("the profile's best is its grid's last value ({:g} s): a lower bound, not an "
                                  "estimate (the response lags more than a first-order motor lag describes)",
                                  kTauGrid_s[kTauCount - 1]);
    }
    res.params[sp.name] = p;
    res.param_order.emplace_back(sp.name);
  }
}

// Parameters the log did not determine (no usable battery data, no usable velocity): the base's.
void KeepBaseWhereUndetermined(const FlightSamples& s, const vehicle::VehicleParams& base, IdentifyResult* out) {
  IdentifyResult& res = *out;
  if (s.batt_V.size() < 3) {
    // The base battery's values: V_oc at its initial charge, R, and dV_oc/dQ over its first 10 %.
    const vehicle::BatteryParams& bb = base.battery;
    const double soc0 = bb.initial_soc, ocv0 = bb.OpenCircuitVoltage_V(soc0);
    const std::map<std::string, double> base_batt = {
        {"battery_ocv_V", ocv0},
        {"battery_resistance_ohm", bb.internal_resistance_ohm},
        {"battery_charge_slope_V_per_Ah", (ocv0 - bb.OpenCircuitVoltage_V(soc0 - 0.1)) / (0.1 * bb.capacity_Ah)}};
    for (const auto& [k, v] : base_batt) {
      res.params[k].value = res.params[k].ci95[0] = res.params[k].ci95[1] = v;
      res.params[k].source = "base";
      res.params[k].applied = false;
      res.params[k].note += " (no usable voltage and current in flight: not identified)";
    }
  }
  if (!s.velocity_ok) {
    const double m_base = base.mass_kg + base.payload.mass_kg;
    const std::map<std::string, double> base_drag = {{"vertical_drag_per_mass_1ps", base.drag.linear_Nspm.z() / m_base},
                                                     {"linear_drag_per_mass_1ps", base.drag.linear_Nspm.x() / m_base},
                                                     {"quadratic_drag_per_mass_1pm", base.drag.quadratic_Ns2pm2.x() / m_base}};
    for (const auto& [k, v] : base_drag) {
      res.params[k].value = res.params[k].ci95[0] = res.params[k].ci95[1] = v;
      res.params[k].source = "base";
      res.params[k].applied = false;
      res.params[k].note += " (not identified: the logged velocity is not usable)";
    }
    res.notes.push_back(s.velocity_why + "; drag not identified, thrust fitted without the velocity terms");
  }
}

// What the log cannot determine at all: kept from the base.
void AppendBaseOnlyParams(const vehicle::VehicleParams& base, IdentifyResult* out) {
  IdentifyResult& res = *out;
  const double m_kg = base.mass_kg + base.payload.mass_kg;
  auto base_param = [&](const std::string& k, double v, const char* unit, const char* note) {
    Param p;
    p.value = v;
    p.ci95[0] = p.ci95[1] = v;
    p.unit = unit;
    p.source = "base";
    p.range[0] = p.range[1] = v;
    p.note = note;
    res.params[k] = p;
    res.param_order.push_back(k);
  };
  base_param("mass_kg", m_kg, "kg", "the log measures forces per unit mass only");
  base_param("inertia_xx_kgm2", base.inertia_kgm2(0, 0), "kg*m^2", "not separable from the torque coefficients");
  base_param("inertia_yy_kgm2", base.inertia_kgm2(1, 1), "kg*m^2", "");
  base_param("inertia_zz_kgm2", base.inertia_kgm2(2, 2), "kg*m^2", "");
  base_param("motor_kv_rpm_per_V", base.motor.kv_rpm_per_V, "rpm/V", "rotor speed is not logged");

}

}  // namespace

std::string IdentifyOptions::IsValid() const {
  const std::vector<std::string> names = FrameNames();
  if (frame != "auto" && std::find(names.begin(), names.end(), frame) == names.end()) {
    std::string list = "auto";
    for (const auto& n : names) list += ", " + n;
    return "frame: expected one of " + list + " (got '" + frame + "')";
  }
  if (blocks < 4) return "blocks: at least 4";
  if (bootstrap_samples < 20) return "bootstrap_samples: at least 20";
  if (!(min_height_m >= 0) || !(window_edge_s >= 0) || !(min_flight_s > 0)) return "window options must be >= 0";
  for (int b : fit_blocks) {
    if (b < 0 || b >= blocks) return "fit_blocks: outside 0..blocks-1";
  }
  return "";
}

Result<IdentifyResult> Identify(const logs::FlightLog& log, const vehicle::VehicleParams& base,
                                const IdentifyOptions& options) {
  using namespace internal;
  const std::string name = log.meta.value("source", std::string("log"));
  if (const std::string why = options.IsValid(); !why.empty()) return Status::BadInput("identify: " + why);
  IdentifyResult res;
  res.base_name = base.name;
  if (options.frame != "auto") {
    res.frame = options.frame;
    res.frame_source = "--frame";
  } else {
    res.frame = FrameOfLog(log, &res.frame_source);
  }
  const std::vector<FrameRotor> table = FrameRotors(res.frame);
  res.motors = !table.empty() ? table.size() : base.rotors.size();
  if (res.motors != base.rotors.size()) {
    // The base's wiring, motor constants and mixer are per rotor: a vehicle of another rotor count
    // written from it would not be a vehicle `run` accepts.
    return Status::BadInput(fmt::format("{}: --base: '{}' has {} rotors, the log's frame {} ({}) has {}: give a base "
                                        "with {} rotors{}",
                                        name, base.name, base.rotors.size(), res.frame, res.frame_source, res.motors,
                                        res.motors,
                                        DefaultBaseFor(res.frame).empty() ? "" : " (e.g. " + DefaultBaseFor(res.frame) + ")"));
  }
  HEXSIM_RETURN_IF_ERROR(internal::ChooseLayout(log, base, table, &res));
  auto built = BuildSamples(log, res.spins, options, (base.mass_kg + base.payload.mass_kg) * kGravity_mps2);
  if (res.layout_from_log) {
    res.notes.push_back(fmt::format("motor layout from {} differs from the base vehicle '{}': the vehicle written takes "
                                    "the log's", res.layout_source, base.name));
  }
  if (!built.ok()) return built.status();
  const FlightSamples& s = *built;
  res.windows = s.windows;
  res.data_source = s.source;
  res.v_ref_V = s.V_ref;
  res.blocks = s.blocks;
  const double expo = ExpoOf(log, &res.thrust_expo_source);
  res.thrust_expo = expo;

  const size_t G = static_cast<size_t>(std::max(4, options.blocks));
  const internal::BlockStats st = AccumulateBlockStats(s, G, expo);
  std::vector<int> fit = options.fit_blocks;
  if (fit.empty()) {
    for (size_t b = 0; b < G; ++b) fit.push_back(static_cast<int>(b));
  }
  res.fit_blocks = fit;
  std::vector<double> w(G, 0.0);
  for (int b : fit) w[static_cast<size_t>(b)] = 1.0;
  const std::vector<double> w_fit = w;
  const Coeffs point = FitWeighted(st, w, expo);
  const auto value = Derive(point, s, base, expo);
  std::map<std::string, std::vector<double>> boot;
  std::mt19937_64 rng(options.seed);
  std::uniform_int_distribution<size_t> pick(0, fit.size() - 1);
  for (int r = 0; r < options.bootstrap_samples; ++r) {
    std::fill(w.begin(), w.end(), 0.0);
    for (size_t i = 0; i < fit.size(); ++i) w[static_cast<size_t>(fit[pick(rng)])] += 1.0;
    for (const auto& [k, v] : Derive(FitWeighted(st, w, expo), s, base, expo)) boot[k].push_back(v);
  }
  const std::map<std::string, double> bias_shift = ModelErrorShifts(st, s, base, expo, w_fit, value, boot);
  FillParams(value, boot, bias_shift, s, &res);
  KeepBaseWhereUndetermined(s, base, &res);
  AppendBaseOnlyParams(base, &res);
  HeldoutAndTraces(s, st, expo, fit, &res);
  // Steady hover samples: level, slow, thrust ≈ weight (for the plot and the hover check).
  for (size_t k = 0; k < s.t_s.size(); ++k) {
    if (s.v_B[k].norm() < 0.5 && std::fabs(-s.f_B[k].z() - kGravity_mps2) < 0.5 && s.w_B[k].norm() < 0.2) {
      res.hover_voltage_V.push_back(s.V[k]);
      res.hover_output.push_back(s.u_mean[k]);
    }
  }
  DynamicsComparison(s, base, expo, st, fit, &res);
  res.notes.insert(res.notes.end(), s.notes.begin(), s.notes.end());
  if (s.V_ref <= 0 && s.notes.empty()) res.notes.emplace_back("no bus voltage in the log: motor outputs used without voltage scaling");
  return res;
}

}  // namespace hexsim::identify
