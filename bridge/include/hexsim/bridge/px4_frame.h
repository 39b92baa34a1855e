// PX4's control-allocation rotor order for the frames hexsim ships, and the PX4 airframe
// parameters of a hexsim vehicle.
//
// PX4 output channel i (HIL_ACTUATOR_CONTROLS.controls[i], PWM_MAIN_FUNC(i+1) = Motor i+1 = 101+i)
// drives CA_ROTOR<i>. Its standard layouts (src/lib/mixer/MultirotorMixer/geometries/quad_x.toml,
// hex_x.toml; CA_ROTOR<i>_KM > 0 for a CCW rotor, control_allocator/module.yaml), angles from the
// nose, positive towards the right:
//   quad-X: 1  45 CCW   2 -135 CCW   3 -45 CW    4  135 CW
//   hex-X:  1  90 CW    2  -90 CCW   3 -30 CW    4  150 CCW   5  30 CCW   6 -150 CW
// PX4 scales a non-reversible motor's output to [0, 1] (pwm_out_sim/PWMSim.cpp) and sends zeros
// while disarmed; hexsim's rotor command is the same 0..1 ESC input.
#pragma once

#include <string>
#include <vector>

#include "hexsim/common/status.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::bridge {

struct Px4RotorMap {
  std::string frame;              // "quad_x" or "hex_x"
  std::vector<size_t> rotor;      // rotor[i]: the hexsim rotor PX4's output channel i drives
};

// Matches the vehicle's rotors (angle within 10 degrees, same spin) to PX4's layout with the same
// rotor count. Bad input when the vehicle has another count or layout.
Result<Px4RotorMap> MapPx4Rotors(const vehicle::VehicleParams& v);

// hexsim rotor commands (rotor order) from PX4's output channels; NaN or out-of-range values are
// clamped to [0, 1] (NaN: 0).
void CommandsFromPx4Outputs(const Px4RotorMap& map, const float* controls, size_t n_controls,
                            std::vector<double>* commands);

// The PX4 parameter lines (`param set-default NAME VALUE`) of an airframe file for the vehicle:
// CA_ROTOR* geometry and moment coefficients in PX4's order, PWM_MAIN_FUNC*, MPC_THR_HOVER (the
// hover command at full charge), THR_MDL_FAC (PX4's thrust curve (1-f)u + f u^2 fitted to the
// vehicle's thrust-for-command curve), and the calibration of the first two compasses
// (CAL_MAG<n>_ID of PX4's simulated magnetometers, offsets = hard iron in gauss, scale and
// off-diagonals = the inverse of the soft iron), SIM_BAT_ENABLE 0.
Result<std::string> Px4AirframeParams(const vehicle::VehicleParams& v);

}  // namespace hexsim::bridge
