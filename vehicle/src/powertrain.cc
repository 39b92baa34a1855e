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
};

MotorConstants Constants(const VehicleParams& p) {
  return {p.motor.Kt_Nm_per_A(), p.motor.winding_resistance_ohm, p.motor.no_load_current_A, p.esc.efficiency};
}

// Winding current at motor voltage V_m and back-EMF E: the ESC cannot push current backwards.
double WindingCurrent(const MotorConstants& c, double motor_V, double back_emf_V) {
  return std::max(0.0, (motor_V - back_emf_V) / c.R);
}

// Net electromagnetic torque: K_t*(I_w - I_0) while spinning; at standstill I_0 acts as static
// friction, so the rotor stays put unless the drive exceeds it.
double MotorTorque(const MotorConstants& c, double omega_radps, double winding_A) {
  const double t = c.K_t * (winding_A - c.I_0);
  if (omega_radps <= 0.0 && t < 0.0) return 0.0;
  return t;
}

MotorOperatingPoint OperatingPoint(const VehicleParams& p, const MotorConstants& c, size_t i, double command,
                                   double omega_radps, double bus_V) {
  const RotorParams& rotor = p.rotors[i];
  MotorOperatingPoint m;
  m.command = command;
  m.duty = p.esc.Duty(command);
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
  return m;
}

// Battery current as a function of the bus voltage for fixed rotor speeds:
// I(V) = avionics + sum_active d_i*(d_i*V - E_i)/(eta*R). Also returns dI/dV. d_i and E_i are
// motors[i].duty and motors[i].back_emf_V (the caller's output buffer, no scratch vectors).
double BatteryCurrent(const VehicleParams& p, const MotorConstants& c, const std::vector<MotorOperatingPoint>& motors,
                      double bus_V, double* dI_dV) {
  double I = p.avionics_current_A;
  double slope = 0.0;
  for (const MotorOperatingPoint& m : motors) {
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

// Fills *out (every field reset; the motor vector's storage is reused, so a caller that keeps its
// PowertrainOutput allocates nothing per step).
void Assemble(const VehicleParams& p, const MotorConstants& c, const std::vector<double>& commands,
              const std::vector<double>& omega, double soc, double open_circuit_V, double bus_V,
              PowertrainOutput* out_ptr) {
  std::vector<MotorOperatingPoint> motors = std::move(out_ptr->motors);
  PowertrainOutput& out = *out_ptr;
  out = PowertrainOutput();
  out.motors = std::move(motors);
  out.open_circuit_V = open_circuit_V;
  out.bus_V = bus_V;
  out.soc = soc;
  out.battery_A = p.avionics_current_A;
  out.motors.resize(commands.size());
  for (size_t i = 0; i < commands.size(); ++i) {
    out.motors[i] = OperatingPoint(p, c, i, commands[i], omega[i], bus_V);
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
void Evaluate(const VehicleParams& params, const MotorConstants& c, const PowertrainState& state,
              const std::vector<double>& commands, PowertrainOutput* out) {
  // Duty and back-EMF first (the bus-voltage solve needs them), kept in the output's motor records.
  out->motors.resize(commands.size());
  for (size_t i = 0; i < commands.size(); ++i) {
    out->motors[i].duty = params.esc.Duty(commands[i]);
    out->motors[i].back_emf_V = state.omega_radps[i] * c.K_t;
  }
  const double V_oc = params.battery.OpenCircuitVoltage_V(state.soc);
  const double V_bus = SolveBusVoltage(params, c, out->motors, V_oc);
  Assemble(params, c, commands, state.omega_radps, state.soc, V_oc, V_bus, out);
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
  for (size_t i = 0; i < commands.size(); ++i) {
    const MotorOperatingPoint& m = out.motors[i];
    const double J = params.RotorInertia_kgm2(i);
    const double k_Q = params.rotors[i].k_Q_Nmprps2;
    const double w = state->omega_radps[i];
    // f(w) = (K_t*(I_w - I_0) - k_Q*w^2)/J; df/dw = -(K_t^2/R [while driven] + 2*k_Q*w)/J.
    const double f = (m.motor_torque_Nm - m.drag_torque_Nm) / J;
    const double electrical_damping = m.winding_A > 0.0 ? c.K_t * c.K_t / c.R : 0.0;
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

PowertrainOutput SteadyStateForCommands(const VehicleParams& params, const std::vector<double>& commands,
                                        double soc) {
  HEXSIM_CHECK(commands.size() == params.rotors.size());
  const MotorConstants c = Constants(params);
  const double V_oc = params.battery.OpenCircuitVoltage_V(soc);
  std::vector<double> omega(commands.size(), 0.0);
  auto battery_current = [&](double V) {
    double I = params.avionics_current_A;
    for (size_t i = 0; i < commands.size(); ++i) {
      const double d = params.esc.Duty(commands[i]);
      omega[i] = SteadyOmega_radps(params, i, d * V);
      I += d * WindingCurrent(c, d * V, omega[i] * c.K_t) / c.eta;
    }
    return I;
  };
  // h(V) = V + R_int*I(V) - V_oc increases with V: bisection on [0, V_oc].
  double lo = 0.0, hi = V_oc;
  for (int iter = 0; iter < 200 && hi - lo > 1e-12 * V_oc; ++iter) {
    const double mid = 0.5 * (lo + hi);
    if (mid + params.battery.internal_resistance_ohm * battery_current(mid) > V_oc) hi = mid;
    else lo = mid;
  }
  const double V_bus = 0.5 * (lo + hi);
  battery_current(V_bus);  // leaves omega at V_bus
  PowertrainOutput out;
  Assemble(params, c, commands, omega, soc, V_oc, V_bus, &out);
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
  const double omega = SteadyOmega_radps(params, rotor, params.esc.Duty(command) * bus_V);
  return params.rotors[rotor].k_T_Nprps2 * omega * omega;
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
