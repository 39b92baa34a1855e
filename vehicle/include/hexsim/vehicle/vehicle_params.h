// VehicleParams: everything about a multirotor that does not change during a run (MuJoCo's
// "model"), read from worlds/vehicles/*.yaml by ParseVehicle (hexsim::vehicle_io,
// hexsim/vehicle/vehicle_io.h). Units and frames are in the names.
//
// Frames: body B = Forward-Right-Down, Earth N = North-East-Down.
// Rotor spin convention: `spin = +1` means the rotor's angular velocity points along its thrust
// axis (up for a normal rotor), i.e. the rotor turns COUNTER-CLOCKWISE SEEN FROM ABOVE; `spin = -1`
// is clockwise seen from above. The aerodynamic drag on a rotor is reacted by the frame, so a
// rotor's yaw reaction torque on the body is  tau_B = -spin * k_Q * omega^2 * axis_B : a CCW rotor
// (spin +1, axis -z) pushes the body's nose to the right (positive yaw about +z down).
#pragma once

#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/common/status.h"
#include "hexsim/magnetics/compass_model.h"
#include "hexsim/magnetics/current_field.h"

namespace hexsim::vehicle {

struct RotorParams {
  Eigen::Vector3d position_B_m = Eigen::Vector3d::Zero();  // rotor hub, from the centre of mass
  int spin = 1;                                             // +1 CCW seen from above, -1 CW
  Eigen::Vector3d axis_B = Eigen::Vector3d(0.0, 0.0, -1.0);  // unit thrust direction (up)
  double k_T_Nprps2 = 0.0;     // thrust = k_T * omega^2      [N/(rad/s)^2]
  double k_Q_Nmprps2 = 0.0;    // drag torque = k_Q * omega^2  [N*m/(rad/s)^2]
  double inertia_kgm2 = 0.0;   // rotor + prop inertia about the spin axis; 0 -> motor.inertia_kgm2
};

// A brushless DC motor seen as an ideal DC machine: V_m = E + I_w*R, E = omega/K_v,
// torque = K_t*(I_w - I_0) with K_t = 1/K_v (SI).
struct MotorParams {
  double kv_rpm_per_V = 0.0;             // speed constant as printed on the motor
  double winding_resistance_ohm = 0.0;   // phase-to-phase equivalent R
  double no_load_current_A = 0.0;        // I_0: friction + iron loss expressed as a current
  double inertia_kgm2 = 0.0;             // rotor bell + propeller about the spin axis

  // SI constants derived from kv.
  double Kv_radps_per_V() const;
  double Kt_Nm_per_A() const;
};

// ESC: duty = 0 for command <= 0 (stopped); otherwise duty_min + (duty_max - duty_min)*command,
// command clamped to 1. duty_min is the armed idle (ESC start-up + autopilot spin-min).
//
// Current limit (powertrain.h): the ESC measures its DC input current I_dc = d*I_w/eta and lowers
// its duty d below the commanded one until I_dc <= current_limit_A (BLHeli_32 / AM32 "current
// protection"; a plain ESC's rating is what a builder sets it to). The autopilot's output stage
// spools the motors up over spool_up_time_s (ArduPilot MOT_SPOOL_TIME; control/spool.h).
struct EscParams {
  double efficiency = 0.95;  // eta: power to the windings = eta * V_bus * I_dc
  double duty_min = 0.10;
  double duty_max = 1.0;
  double current_limit_A = std::numeric_limits<double>::infinity();  // per ESC, DC input side
  double spool_up_time_s = 0.5;  // ground idle -> full throttle range (ArduPilot MOT_SPOOL_TIME)
  double Duty(double command) const {  // inline: the powertrain calls it per motor per step
    if (!(command > 0.0)) return 0.0;  // stopped (also for NaN)
    const double c = command < 1.0 ? command : 1.0;
    return duty_min + (duty_max - duty_min) * c;
  }
};

struct BatteryParams {
  int cells_series = 6;
  double capacity_Ah = 5.0;
  double internal_resistance_ohm = 0.02;  // whole pack
  // Open-circuit voltage per cell against state of charge (0..1), ascending in SoC.
  std::vector<double> ocv_soc = {0.0, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0};
  std::vector<double> ocv_cell_V = {3.27, 3.50, 3.61, 3.69, 3.73, 3.77, 3.81, 3.86, 3.92, 4.00, 4.08, 4.20};
  double initial_soc = 1.0;
  // Largest continuous discharge current of the pack (its C rating times capacity_Ah): the power
  // system lowers every ESC's duty by one common factor to keep the battery current within it
  // (powertrain.h). Infinity: no limit.
  double max_current_A = std::numeric_limits<double>::infinity();
  // Pack open-circuit voltage at a state of charge (linear interpolation, clamped to the table).
  double OpenCircuitVoltage_V(double soc) const;
};

// Aerodynamic drag of the airframe, body axes: F_i = -(lin_i*v_i + quad_i*|v_i|*v_i) with v the
// air-relative velocity in B; moment = -(rot_lin ∘ w + rot_quad ∘ |w| w).
struct DragParams {
  Eigen::Vector3d linear_Nspm = Eigen::Vector3d::Zero();            // N/(m/s)
  Eigen::Vector3d quadratic_Ns2pm2 = Eigen::Vector3d::Zero();       // N/(m/s)^2
  Eigen::Vector3d rotational_Nmsprad = Eigen::Vector3d::Zero();     // N*m/(rad/s)
  Eigen::Vector3d rotational_quad_Nms2prad2 = Eigen::Vector3d::Zero();  // N*m/(rad/s)^2
};

// Rotor aerodynamics beyond k_T·ω² (both 0 = off, the default):
//   rotor drag (induced drag / blade flapping): F_B = −k·(Σ_i ω_i)·(v_x, v_y, 0) with v the body
//   air velocity; ground effect (Cheeseman–Bennett, ρ = 1): T_IGE/T_OGE = 1/(1 − (R/4z)²), z the
//   hub's height above the ground, R an effective rotor radius (z clamped to ≥ R/2).
struct AeroParams {
  double rotor_drag_N_per_radps_mps = 0.0;  // k  [N/((rad/s)·(m/s))]
  double ground_effect_radius_m = 0.0;      // R
};

struct PayloadParams {
  double mass_kg = 0.0;                                  // 0 = no payload
  Eigen::Vector3d attach_B_m = Eigen::Vector3d(0.0, 0.0, 0.1);  // attachment point
  double tether_length_m = 0.0;                          // 0 = rigidly attached
};

// White noise per sample, a constant bias drawn once from bias_std and a bias random walk.
struct NoiseParams {
  double noise_std = 0.0;            // per sample (from noise_density * sqrt(rate_hz) if given so)
  double bias_std = 0.0;             // the constant bias' std, drawn at start
  double bias_walk_per_sqrt_s = 0.0; // bias random walk: std grows as this * sqrt(t)
};

struct ImuSensorParams {
  double rate_hz = 400.0;
  NoiseParams noise;
};

struct CompassParams {
  std::string name = "mag";
  Eigen::Vector3d position_B_m = Eigen::Vector3d::Zero();
  bool external = false;
  magnetics::CompassErrorParams error;
  double rate_hz = 75.0;
  NoiseParams noise;  // in uT
  // Low-pass on the currents seen by this compass (ESC/current lag); < 0 -> use the wiring's.
  double current_lag_tau_s = -1.0;
};

struct GpsParams {
  double rate_hz = 5.0;
  NoiseParams horizontal_m;   // per horizontal axis
  NoiseParams vertical_m;
  NoiseParams velocity_mps;   // per axis
  double latency_s = 0.2;
};

struct BaroParams {
  double rate_hz = 50.0;
  NoiseParams noise_m;
};

struct SensorParams {
  ImuSensorParams gyro;    // rad/s
  ImuSensorParams accel;   // m/s^2
  GpsParams gps;
  BaroParams baro;
};

struct VehicleParams {
  std::string name;
  double mass_kg = 0.0;
  Eigen::Matrix3d inertia_kgm2 = Eigen::Matrix3d::Identity() * 0.05;
  std::vector<RotorParams> rotors;
  MotorParams motor;
  EscParams esc;
  BatteryParams battery;
  double avionics_current_A = 0.5;
  DragParams drag;
  AeroParams aero;
  PayloadParams payload;
  magnetics::CurrentFieldParams wiring;
  std::vector<CompassParams> compasses;
  SensorParams sensors;

  size_t rotor_count() const { return rotors.size(); }
  // Spin-axis inertia of rotor i (its own value, or the motor's). Inline: the powertrain asks per
  // rotor per physics step.
  double RotorInertia_kgm2(size_t i) const {
    HEXSIM_CHECK(i < rotors.size());
    return rotors[i].inertia_kgm2 > 0.0 ? rotors[i].inertia_kgm2 : motor.inertia_kgm2;
  }
};

}  // namespace hexsim::vehicle
