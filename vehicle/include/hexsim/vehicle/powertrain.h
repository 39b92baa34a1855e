// Powertrain: ESC + DC motor + rotor per arm, one battery (CONTRACTS "Electrical model").
//
// Per motor:  duty d = esc.Duty(command), V_m = d*V_bus, E = omega/K_v,
//   I_w = max(0, (V_m - E)/R)                  (ESC without active braking)
//   J*domega/dt = K_t*(I_w - I_0) - k_Q*omega^2  (K_t = 1/K_v; I_0 acts as friction, never drives)
//   I_dc = V_m*I_w/(eta*V_bus) = d*I_w/eta      (battery-side current of this ESC)
// so that  V_bus*I_dc = E*(I_w-I_0) + I_w^2*R + E*I_0 + (1-eta)*V_bus*I_dc.
// Battery: V_bus = V_oc(SoC) - R_int*I_batt, I_batt = sum I_dc + avionics (solved exactly: the
// relation is piecewise linear and convex in V_bus, Newton from V_oc converges in finitely many
// steps); dSoC/dt = -I_batt/capacity.
//
// Current limits (vehicle esc.current_limit_A = L, battery.max_current_A = I_max), enforced on the
// duty, never on the command:
//   ESC: where the commanded duty would draw I_dc > L, the ESC lowers its duty to the d at which
//     d*(d*V_bus - E)/(eta*R) = L, i.e. d = (E + sqrt(E^2 + 4*V_bus*L*eta*R))/(2*V_bus); the ESC is
//     then a constant-current load L on the bus (the bus solve treats it so; the set of limited ESCs
//     only grows as the bus voltage rises, so at most one pass per ESC).
//   Battery: where the total would exceed I_max, every ESC's duty is lowered by one common factor k
//     (d_i = min(k*d_cmd_i, the ESC's own limit)) so that I_batt = I_max exactly; the bus is then
//     V_oc - R_int*I_max, and k follows by bisection (each current increases with k).
// A spinning rotor's inertia is what these limits meet at spin-up: accelerating J*omega from rest
// through the winding resistance alone draws (d*V_bus/R)*d/eta per ESC.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "hexsim/magnetics/current_field.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::vehicle {

struct PowertrainState {
  std::vector<double> omega_radps;  // per rotor, >= 0 (magnitude; direction from RotorParams::spin)
  double soc = 1.0;                 // battery state of charge 0..1
};

// Rotors stopped, battery at its initial state of charge.
PowertrainState InitialPowertrainState(const VehicleParams& params);

struct MotorOperatingPoint {
  double command = 0.0;          // 0..1
  double duty = 0.0;
  double omega_radps = 0.0;
  double back_emf_V = 0.0;       // E
  double motor_V = 0.0;          // V_m = duty * V_bus
  double winding_A = 0.0;        // I_w
  double dc_A = 0.0;             // I_dc (what the log calls motor_i_A)
  double motor_torque_Nm = 0.0;  // K_t*(I_w - I_0) (0 when stalled below friction)
  double thrust_N = 0.0;         // k_T*omega^2 along the rotor axis
  double drag_torque_Nm = 0.0;   // k_Q*omega^2, the yaw reaction magnitude
  double power_in_W = 0.0;       // V_bus*I_dc
  double shaft_W = 0.0;          // E*(I_w - I_0)
  double copper_W = 0.0;         // I_w^2*R
  double no_load_W = 0.0;        // E*I_0
  double esc_loss_W = 0.0;       // (1-eta)*V_bus*I_dc
  double aero_W = 0.0;           // k_Q*omega^3, power absorbed by the propeller
  bool current_limited = false;  // the ESC lowered its duty below the command's (own or battery limit)
};

struct PowertrainOutput {
  std::vector<MotorOperatingPoint> motors;
  double open_circuit_V = 0.0;
  double bus_V = 0.0;
  double battery_A = 0.0;        // sum of dc_A + avionics
  double soc = 0.0;
  double power_in_W = 0.0;       // V_bus*I_batt (motors + avionics)
  double battery_loss_W = 0.0;   // R_int*I_batt^2
  double shaft_W = 0.0;          // sum over motors
  double copper_W = 0.0;         // sum over motors
  double total_thrust_N = 0.0;   // sum of |thrust| (magnitudes)
  int esc_limited = 0;           // ESCs at their own current limit (log column esc_limited)
  bool battery_limited = false;  // the battery limit scaled every duty down (log column batt_limited)

  // The currents the magnetic model needs.
  magnetics::Currents Currents() const;
};

// The operating point at `state` with `commands` (one per rotor, 0..1), without advancing it.
PowertrainOutput EvaluatePowertrain(const VehicleParams& params, const PowertrainState& state,
                                    const std::vector<double>& commands);
// The same into a caller-owned output (every field overwritten; its `motors` storage is reused, so
// a caller that keeps one PowertrainOutput across steps allocates nothing).
void EvaluatePowertrain(const VehicleParams& params, const PowertrainState& state, const std::vector<double>& commands,
                        PowertrainOutput* out);

// Advances rotor speeds and SoC by dt_s (semi-implicit Euler on the rotor speed, stable for any
// dt). Returns the operating point that acted over the step (evaluated at the start state).
PowertrainOutput StepPowertrain(const VehicleParams& params, const std::vector<double>& commands, double dt_s,
                                PowertrainState* state);
// The same into a caller-owned output (see EvaluatePowertrain above): the simulation loop's form.
void StepPowertrain(const VehicleParams& params, const std::vector<double>& commands, double dt_s,
                    PowertrainState* state, PowertrainOutput* out);

// Steady state (domega/dt = 0 for every rotor, body held still) for per-rotor commands at a state
// of charge, current limits included; the bus voltage is found by bisection on the battery equation.
PowertrainOutput SteadyStateForCommands(const VehicleParams& params, const std::vector<double>& commands,
                                        double soc);
// Every motor at the same command (the paper's collective control amount u = 1000*command).
PowertrainOutput SteadyStateForCommand(const VehicleParams& params, double command, double soc);

// Steady rotor speed of one motor at a motor voltage V_m (0 when it cannot overcome friction).
double SteadyOmega_radps(const VehicleParams& params, size_t rotor, double motor_V);

// Thrust -> command feed-forward at a given bus voltage (steady state). Thrust <= 0 gives 0
// (stopped); thrust below the idle thrust gives kIdleCommand; thrust beyond reach gives 1.
inline constexpr double kIdleCommand = 1e-6;
double CommandForThrust(const VehicleParams& params, size_t rotor, double thrust_N, double bus_V);
// The inverse: steady thrust of one rotor at a command and bus voltage (its ESC's current limit
// included).
double ThrustForCommand(const VehicleParams& params, size_t rotor, double command, double bus_V);
// Steady speed of one rotor whose ESC draws exactly dc_A at bus_V (the speed its current limit
// allows): I_w = I_0 + k_Q*w^2/K_t, V_m = K_t*w + I_w*R, V_m*I_w = eta*V_bus*dc_A.
double SteadyOmegaAtDcCurrent_radps(const VehicleParams& params, size_t rotor, double dc_A, double bus_V);

struct Wrench {
  Eigen::Vector3d force_B_N = Eigen::Vector3d::Zero();
  Eigen::Vector3d torque_B_Nm = Eigen::Vector3d::Zero();  // about the centre of mass
};

// Force and torque of the rotors on the body, body frame: thrust k_T*omega^2 along each axis,
// r x F moments, yaw reactions -spin*k_Q*omega^2*axis, and, when given, the gyroscopic term
// -w_B x h (h = sum spin*J_r*omega*axis) and the spin-up reaction -spin*J_r*domega/dt*axis.
Wrench RotorWrench(const VehicleParams& params, const std::vector<double>& omega_radps,
                   const Eigen::Vector3d& w_B_radps = Eigen::Vector3d::Zero(),
                   const std::vector<double>& omega_dot_radps2 = {});

}  // namespace hexsim::vehicle
