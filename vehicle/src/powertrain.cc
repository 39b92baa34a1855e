#include "hexsim/vehicle/powertrain.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace hexsim::vehicle {
namespace {

// Motor constants in SI for the shared motor model.
struct MotorConstants {
  double K_t = 0.0;   // N*m/A (= V*s/rad, the back-EMF constant)
  double R = 0.0;     // ohm
  double I_0 = 0.0;   // A
  double eta = 1.0;
  double L = 0.0;     // ESC DC current limit, A (infinity: none)
};

MotorConstants Constants(const VehicleParams& p) {
  return {p.motor.Kt_Nm_per_A(), p.motor.winding_resistance_ohm, p.motor.no_load_current_A, p.esc.efficiency,
          p.esc.current_limit_A};
}

// Winding current at motor voltage V_m and back-EMF E: the ESC cannot push current backwards.
double WindingCurrent(const MotorConstants& c, double motor_V, double back_emf_V) {
  return std::max(0.0, (motor_V - back_emf_V) / c.R);
}

// DC input current of one ESC: I_dc = d*I_w/eta, I_w = max(0, d*V_bus - E)/R.
double DcCurrent(const MotorConstants& c, double duty, double back_emf_V, double bus_V) {
  return duty > 0.0 ? duty * WindingCurrent(c, duty * bus_V, back_emf_V) / c.eta : 0.0;
}

// The duty at which one ESC draws dc_A > 0: the positive root of V*d^2 - E*d - dc_A*eta*R = 0
// (I_dc increases with d above E/V, where it is 0).
double DutyForDcCurrent(const MotorConstants& c, double dc_A, double back_emf_V, double bus_V) {
  const double E = back_emf_V;
  return (E + std::sqrt(E * E + 4.0 * bus_V * dc_A * c.eta * c.R)) / (2.0 * bus_V);
}

// Net electromagnetic torque: K_t*(I_w - I_0) while spinning; at standstill I_0 acts as static
// friction, so the rotor stays put unless the drive exceeds it.
double MotorTorque(const MotorConstants& c, double omega_radps, double winding_A) {
  const double t = c.K_t * (winding_A - c.I_0);
  if (omega_radps <= 0.0 && t < 0.0) return 0.0;
  return t;
}

// The operating point at the duty the ESC applies (the command's, or lower at a current limit),
// written into *m in place (m->duty is that duty; m->current_limited is left as it is).
void FillOperatingPoint(const VehicleParams& p, const MotorConstants& c, size_t i, double command, double omega_radps,
                        double bus_V, MotorOperatingPoint* m_ptr) {
  const RotorParams& rotor = p.rotors[i];
  MotorOperatingPoint& m = *m_ptr;
  m.command = command;
  m.omega_radps = omega_radps;
  m.back_emf_V = omega_radps * c.K_t;
  m.motor_V = m.duty * bus_V;
  m.winding_A = m.duty > 0.0 ? WindingCurrent(c, m.motor_V, m.back_emf_V) : 0.0;
  m.dc_A = m.duty > 0.0 ? m.duty * m.winding_A / c.eta : 0.0;  // V_m*I_w = eta*V_bus*I_dc
  m.motor_torque_Nm = MotorTorque(c, omega_radps, m.winding_A);
  m.thrust_N = rotor.k_T_Nprps2 * omega_radps * omega_radps;
  m.drag_torque_Nm = rotor.k_Q_Nmprps2 * omega_radps * omega_radps;
  m.power_in_W = bus_V * m.dc_A;
  m.shaft_W = m.back_emf_V * (m.winding_A - c.I_0);
  m.copper_W = m.winding_A * m.winding_A * c.R;
  m.no_load_W = m.back_emf_V * c.I_0;
  m.esc_loss_W = (1.0 - c.eta) * m.power_in_W;
  m.aero_W = m.drag_torque_Nm * omega_radps;
}

// Battery current as a function of the bus voltage for fixed rotor speeds:
// I(V) = avionics + sum_active d_i*(d_i*V - E_i)/(eta*R). Also returns dI/dV. d_i and E_i are
// motors[i].duty and motors[i].back_emf_V (the caller's output buffer, no scratch vectors).
double BatteryCurrent(const VehicleParams& p, const MotorConstants& c, const std::vector<MotorOperatingPoint>& motors,
                      double bus_V, double* dI_dV) {
  double I = p.avionics_current_A;
  double slope = 0.0;
  for (const MotorOperatingPoint& m : motors) {
    if (m.current_limited) {  // an ESC at its limit is a constant-current load
      I += c.L;
      continue;
    }
    if (m.duty <= 0.0) continue;
    const double drive_V = m.duty * bus_V - m.back_emf_V;
    if (drive_V <= 0.0) continue;
    I += m.duty * drive_V / (c.eta * c.R);
    slope += m.duty * m.duty / (c.eta * c.R);
  }
  if (dI_dV) *dI_dV = slope;
  return I;
}

// Solves V = V_oc - R_int*I(V). g(V) = V + R_int*I(V) - V_oc is increasing, convex and piecewise
// linear, so Newton from V_oc (where g >= 0) decreases monotonically onto the root.
double SolveBusVoltage(const VehicleParams& p, const MotorConstants& c, const std::vector<MotorOperatingPoint>& motors,
                       double open_circuit_V) {
  const double R_int = p.battery.internal_resistance_ohm;
  double V = open_circuit_V;
  for (size_t iter = 0; iter < motors.size() + 4; ++iter) {
    double slope = 0.0;
    const double I = BatteryCurrent(p, c, motors, V, &slope);
    const double g = V + R_int * I - open_circuit_V;
    const double V_next = V - g / (1.0 + R_int * slope);
    if (std::abs(V_next - V) <= 1e-13 * open_circuit_V) return V_next;
    V = V_next;
  }
  return V;
}

// Fills *out: every field is written, in place (the motor records too, so a caller that keeps its
// PowertrainOutput allocates and copies nothing per step). out->motors[i].duty and .current_limited
// hold what the ESCs apply (EnforceCurrentLimits); esc_limited/battery_limited are the limits' summary.
void Assemble(const VehicleParams& p, const MotorConstants& c, const std::vector<double>& commands,
              const std::vector<double>& omega, double soc, double open_circuit_V, double bus_V, int esc_limited,
              bool battery_limited, PowertrainOutput* out_ptr) {
  PowertrainOutput& out = *out_ptr;
  out.open_circuit_V = open_circuit_V;
  out.bus_V = bus_V;
  out.soc = soc;
  out.battery_A = p.avionics_current_A;
  out.shaft_W = 0.0;
  out.copper_W = 0.0;
  out.total_thrust_N = 0.0;
  out.esc_limited = esc_limited;
  out.battery_limited = battery_limited;
  HEXSIM_CHECK(out.motors.size() == commands.size());
  for (size_t i = 0; i < commands.size(); ++i) {
    FillOperatingPoint(p, c, i, commands[i], omega[i], bus_V, &out.motors[i]);
    const MotorOperatingPoint& m = out.motors[i];
    out.battery_A += m.dc_A;
    out.shaft_W += m.shaft_W;
    out.copper_W += m.copper_W;
    out.total_thrust_N += m.thrust_N;
  }
  out.power_in_W = bus_V * out.battery_A;
  out.battery_loss_W = p.battery.internal_resistance_ohm * out.battery_A * out.battery_A;
}

}  // namespace

magnetics::Currents PowertrainOutput::Currents() const {
  magnetics::Currents c;
  c.battery_A = battery_A;
  c.motor_A.reserve(motors.size());
  for (const MotorOperatingPoint& m : motors) c.motor_A.push_back(m.dc_A);
  return c;
}

PowertrainState InitialPowertrainState(const VehicleParams& params) {
  PowertrainState s;
  s.omega_radps.assign(params.rotors.size(), 0.0);
  s.soc = params.battery.initial_soc;
  return s;
}

PowertrainOutput EvaluatePowertrain(const VehicleParams& params, const PowertrainState& state,
                                    const std::vector<double>& commands) {
  PowertrainOutput out;
  EvaluatePowertrain(params, state, commands, &out);
  return out;
}

namespace {

// The battery limit at fixed rotor speeds: the bus sits at V_b = V_oc - R_int*I_max and every duty
// is d_i = min(k*d_cmd_i, the ESC's own limit at V_b); k in (0, 1) by bisection on
// avionics + sum I_dc,i(k) = I_max (each term increases with k). Sets duty/current_limited;
// returns V_b and adds the ESCs at their own limit to *esc_limited.
double EnforceBatteryLimit(const VehicleParams& p, const MotorConstants& c, const std::vector<double>& commands,
                           double open_circuit_V, std::vector<MotorOperatingPoint>* motors, int* esc_limited) {
  const double I_max = p.battery.max_current_A;
  const double V_b = open_circuit_V - p.battery.internal_resistance_ohm * I_max;
  HEXSIM_CHECK(V_b > 0.0);
  auto duty = [&](size_t i, double k) {
    const double d = k * p.esc.Duty(commands[i]);
    if (!std::isfinite(c.L) || d <= 0.0) return d;
    return std::min(d, DutyForDcCurrent(c, c.L, (*motors)[i].back_emf_V, V_b));
  };
  auto total = [&](double k) {
    double I = p.avionics_current_A;
    for (size_t i = 0; i < motors->size(); ++i) I += DcCurrent(c, duty(i, k), (*motors)[i].back_emf_V, V_b);
    return I;
  };
  double lo = 0.0, hi = 1.0;
  for (int iter = 0; iter < 60 && hi - lo > 1e-13; ++iter) {
    const double mid = 0.5 * (lo + hi);
    (total(mid) > I_max ? hi : lo) = mid;
  }
  *esc_limited = 0;
  for (size_t i = 0; i < motors->size(); ++i) {
    MotorOperatingPoint& m = (*motors)[i];
    const double d_cmd = p.esc.Duty(commands[i]);
    m.duty = duty(i, lo);
    m.current_limited = d_cmd > 0.0;
    if (std::isfinite(c.L) && d_cmd > 0.0 && m.duty < lo * d_cmd) ++*esc_limited;
  }
  return V_b;
}

// Lowers duties to the ESC limit and then the battery limit (powertrain.h); returns the bus voltage.
double EnforceCurrentLimits(const VehicleParams& p, const MotorConstants& c, const std::vector<double>& commands,
                            double open_circuit_V, double bus_V, std::vector<MotorOperatingPoint>* motors,
                            int* esc_limited, bool* battery_limited) {
  *esc_limited = 0;
  *battery_limited = false;
  double V = bus_V;
  if (std::isfinite(c.L)) {
    // An ESC over its limit becomes a constant-current load; the bus rises, so others may join.
    for (bool changed = true; changed;) {
      changed = false;
      for (MotorOperatingPoint& m : *motors) {
        if (!m.current_limited && DcCurrent(c, m.duty, m.back_emf_V, V) > c.L) {
          m.current_limited = true;
          changed = true;
          ++*esc_limited;
        }
      }
      if (changed) V = SolveBusVoltage(p, c, *motors, open_circuit_V);
    }
    for (MotorOperatingPoint& m : *motors) {
      if (m.current_limited) m.duty = DutyForDcCurrent(c, c.L, m.back_emf_V, V);
    }
  }
  if (std::isfinite(p.battery.max_current_A) &&
      BatteryCurrent(p, c, *motors, V, nullptr) > p.battery.max_current_A) {
    *battery_limited = true;
    V = EnforceBatteryLimit(p, c, commands, open_circuit_V, motors, esc_limited);
  }
  return V;
}

void Evaluate(const VehicleParams& params, const MotorConstants& c, const PowertrainState& state,
              const std::vector<double>& commands, PowertrainOutput* out) {
  // Duty and back-EMF first (the bus-voltage solve needs them), kept in the output's motor records.
  out->motors.resize(commands.size());
  for (size_t i = 0; i < commands.size(); ++i) {
    out->motors[i].duty = params.esc.Duty(commands[i]);
    out->motors[i].back_emf_V = state.omega_radps[i] * c.K_t;
    out->motors[i].current_limited = false;
  }
  const double V_oc = params.battery.OpenCircuitVoltage_V(state.soc);
  double V_bus = SolveBusVoltage(params, c, out->motors, V_oc);
  int esc_limited = 0;
  bool battery_limited = false;
  if (std::isfinite(c.L) || std::isfinite(params.battery.max_current_A)) {
    V_bus = EnforceCurrentLimits(params, c, commands, V_oc, V_bus, &out->motors, &esc_limited, &battery_limited);
  }
  Assemble(params, c, commands, state.omega_radps, state.soc, V_oc, V_bus, esc_limited, battery_limited, out);
}
}  // namespace

void EvaluatePowertrain(const VehicleParams& params, const PowertrainState& state, const std::vector<double>& commands,
                        PowertrainOutput* out) {
  HEXSIM_CHECK(out != nullptr);
  HEXSIM_CHECK(commands.size() == params.rotors.size());
  HEXSIM_CHECK(state.omega_radps.size() == params.rotors.size());
  Evaluate(params, Constants(params), state, commands, out);
}

PowertrainOutput StepPowertrain(const VehicleParams& params, const std::vector<double>& commands, double dt_s,
                                PowertrainState* state) {
  PowertrainOutput out;
  StepPowertrain(params, commands, dt_s, state, &out);
  return out;
}

void StepPowertrain(const VehicleParams& params, const std::vector<double>& commands, double dt_s,
                    PowertrainState* state, PowertrainOutput* out_ptr) {
  HEXSIM_CHECK(state != nullptr);
  HEXSIM_CHECK(out_ptr != nullptr);
  HEXSIM_CHECK(dt_s >= 0.0);
  HEXSIM_CHECK(commands.size() == params.rotors.size());
  HEXSIM_CHECK(state->omega_radps.size() == params.rotors.size());
  PowertrainOutput& out = *out_ptr;
  const MotorConstants c = Constants(params);
  Evaluate(params, c, *state, commands, &out);
  const double driven_damping = c.K_t * c.K_t / c.R;
  for (size_t i = 0; i < commands.size(); ++i) {
    const MotorOperatingPoint& m = out.motors[i];
    const double J = params.RotorInertia_kgm2(i);
    const double k_Q = params.rotors[i].k_Q_Nmprps2;
    const double w = state->omega_radps[i];
    // f(w) = (K_t*(I_w - I_0) - k_Q*w^2)/J; df/dw = -(K_t^2/R [while driven] + 2*k_Q*w)/J.
    const double f = (m.motor_torque_Nm - m.drag_torque_Nm) / J;
    const double electrical_damping = m.winding_A > 0.0 ? driven_damping : 0.0;
    const double df_dw = -(electrical_damping + 2.0 * k_Q * w) / J;
    // Semi-implicit (linearised backward) Euler: w+ = w + dt*f/(1 - dt*df/dw).
    state->omega_radps[i] = std::max(0.0, w + dt_s * f / (1.0 - dt_s * df_dw));
  }
  const double capacity_As = params.battery.capacity_Ah * 3600.0;
  state->soc = std::clamp(state->soc - out.battery_A * dt_s / capacity_As, 0.0, 1.0);
}

double SteadyOmega_radps(const VehicleParams& params, size_t rotor, double motor_V) {
  HEXSIM_CHECK(rotor < params.rotors.size());
  const MotorConstants c = Constants(params);
  // k_Q*w^2 + (K_t^2/R)*w - K_t*(V_m/R - I_0) = 0, positive root (stable form).
  const double a = params.rotors[rotor].k_Q_Nmprps2;
  const double b = c.K_t * c.K_t / c.R;
  const double cc = c.K_t * (motor_V / c.R - c.I_0);
  if (cc <= 0.0) return 0.0;
  return 2.0 * cc / (b + std::sqrt(b * b + 4.0 * a * cc));
}

namespace {

// One motor's steady state at duty d on bus V, its ESC limit included: writes the speed and the
// duty applied (lower at the limit) and returns I_dc.
double SteadyMotor(const VehicleParams& p, const MotorConstants& c, size_t i, double duty, double bus_V,
                   double* omega_radps, double* applied_duty, bool* limited) {
  *omega_radps = SteadyOmega_radps(p, i, duty * bus_V);
  *applied_duty = duty;
  *limited = false;
  const double I = DcCurrent(c, duty, *omega_radps * c.K_t, bus_V);
  if (!(I > c.L)) return I;
  *omega_radps = SteadyOmegaAtDcCurrent_radps(p, i, c.L, bus_V);
  *applied_duty = DutyForDcCurrent(c, c.L, *omega_radps * c.K_t, bus_V);
  *limited = true;
  return c.L;
}

}  // namespace

PowertrainOutput SteadyStateForCommands(const VehicleParams& params, const std::vector<double>& commands,
                                        double soc) {
  HEXSIM_CHECK(commands.size() == params.rotors.size());
  const MotorConstants c = Constants(params);
  const double V_oc = params.battery.OpenCircuitVoltage_V(soc);
  const size_t n = commands.size();
  std::vector<double> omega(n, 0.0);
  PowertrainOutput out;
  out.motors.resize(n);
  int esc_limited = 0;
  // Battery current with every duty scaled by k (k = 1: as commanded) at bus voltage V.
  auto battery_current = [&](double V, double k) {
    double I = params.avionics_current_A;
    esc_limited = 0;
    for (size_t i = 0; i < n; ++i) {
      MotorOperatingPoint& m = out.motors[i];
      I += SteadyMotor(params, c, i, k * params.esc.Duty(commands[i]), V, &omega[i], &m.duty, &m.current_limited);
      esc_limited += m.current_limited ? 1 : 0;
    }
    return I;
  };
  // h(V) = V + R_int*I(V) - V_oc increases with V: bisection on [0, V_oc].
  double lo = 0.0, hi = V_oc;
  for (int iter = 0; iter < 200 && hi - lo > 1e-12 * V_oc; ++iter) {
    const double mid = 0.5 * (lo + hi);
    if (mid + params.battery.internal_resistance_ohm * battery_current(mid, 1.0) > V_oc) hi = mid;
    else lo = mid;
  }
  double V_bus = 0.5 * (lo + hi);
  double k = 1.0;
  bool battery_limited = false;
  if (battery_current(V_bus, 1.0) > params.battery.max_current_A) {
    // Battery limit: the bus at V_oc - R_int*I_max, every duty scaled by the k that draws I_max.
    battery_limited = true;
    V_bus = V_oc - params.battery.internal_resistance_ohm * params.battery.max_current_A;
    double k_lo = 0.0, k_hi = 1.0;
    for (int iter = 0; iter < 60 && k_hi - k_lo > 1e-13; ++iter) {
      const double mid = 0.5 * (k_lo + k_hi);
      (battery_current(V_bus, mid) > params.battery.max_current_A ? k_hi : k_lo) = mid;
    }
    k = k_lo;
  }
  battery_current(V_bus, k);  // leaves omega, duties and flags at V_bus
  if (battery_limited) {
    for (size_t i = 0; i < n; ++i) out.motors[i].current_limited = commands[i] > 0.0;
  }
  Assemble(params, c, commands, omega, soc, V_oc, V_bus, esc_limited, battery_limited, &out);
  return out;
}

PowertrainOutput SteadyStateForCommand(const VehicleParams& params, double command, double soc) {
  return SteadyStateForCommands(params, std::vector<double>(params.rotors.size(), command), soc);
}

double CommandForThrust(const VehicleParams& params, size_t rotor, double thrust_N, double bus_V) {
  HEXSIM_CHECK(rotor < params.rotors.size());
  if (!(thrust_N > 0.0) || !(bus_V > 0.0)) return 0.0;
  const MotorConstants c = Constants(params);
  const RotorParams& r = params.rotors[rotor];
  const double omega = std::sqrt(thrust_N / r.k_T_Nprps2);
  // Steady: K_t*(I_w - I_0) = k_Q*w^2, V_m = E + I_w*R.
  const double I_w = c.I_0 + r.k_Q_Nmprps2 * omega * omega / c.K_t;
  const double V_m = omega * c.K_t + I_w * c.R;
  const double duty = V_m / bus_V;
  const double command = (duty - params.esc.duty_min) / (params.esc.duty_max - params.esc.duty_min);
  return std::clamp(command, kIdleCommand, 1.0);
}

double ThrustForCommand(const VehicleParams& params, size_t rotor, double command, double bus_V) {
  HEXSIM_CHECK(rotor < params.rotors.size());
  const MotorConstants c = Constants(params);
  double omega = 0.0, duty = 0.0;
  bool limited = false;
  SteadyMotor(params, c, rotor, params.esc.Duty(command), bus_V, &omega, &duty, &limited);
  return params.rotors[rotor].k_T_Nprps2 * omega * omega;
}

double SteadyOmegaAtDcCurrent_radps(const VehicleParams& params, size_t rotor, double dc_A, double bus_V) {
  HEXSIM_CHECK(rotor < params.rotors.size());
  const MotorConstants c = Constants(params);
  const double k_Q = params.rotors[rotor].k_Q_Nmprps2;
  const double P_W = c.eta * bus_V * dc_A;  // power into the windings, V_m*I_w
  // h(w) = V_m(w)*I_w(w) - P increases with w; h(w_hi) >= 0 since V_m*I_w >= I_w^2*R >= (k_Q*w^2/K_t)^2*R.
  auto h = [&](double w) {
    const double I_w = c.I_0 + k_Q * w * w / c.K_t;
    return (c.K_t * w + I_w * c.R) * I_w - P_W;
  };
  if (!(P_W > 0.0) || h(0.0) >= 0.0) return 0.0;
  double lo = 0.0, hi = std::sqrt(c.K_t * std::sqrt(P_W / c.R) / k_Q);
  for (int iter = 0; iter < 80 && hi - lo > 1e-12 * hi; ++iter) {
    const double mid = 0.5 * (lo + hi);
    (h(mid) > 0.0 ? hi : lo) = mid;
  }
  return 0.5 * (lo + hi);
}

Wrench RotorWrench(const VehicleParams& params, const std::vector<double>& omega_radps,
                   const Eigen::Vector3d& w_B_radps, const std::vector<double>& omega_dot_radps2) {
  HEXSIM_CHECK(omega_radps.size() == params.rotors.size());
  HEXSIM_CHECK(omega_dot_radps2.empty() || omega_dot_radps2.size() == params.rotors.size());
  Wrench w;
  Eigen::Vector3d h_B = Eigen::Vector3d::Zero();  // rotors' spin angular momentum, N*m*s
  for (size_t i = 0; i < params.rotors.size(); ++i) {
    const RotorParams& r = params.rotors[i];
    const double om = omega_radps[i];
    const Eigen::Vector3d F = r.k_T_Nprps2 * om * om * r.axis_B;
    w.force_B_N += F;
    w.torque_B_Nm += r.position_B_m.cross(F);
    w.torque_B_Nm += -r.spin * r.k_Q_Nmprps2 * om * om * r.axis_B;  // drag reaction
    const double J_r = params.RotorInertia_kgm2(i);
    h_B += r.spin * J_r * om * r.axis_B;
    if (!omega_dot_radps2.empty()) w.torque_B_Nm += -r.spin * J_r * omega_dot_radps2[i] * r.axis_B;
  }
  w.torque_B_Nm += -w_B_radps.cross(h_B);  // gyroscopic: body must turn the rotors' momentum
  return w;
}

}  // namespace hexsim::vehicle
