// Complementary estimator (Mahony-style attitude with a gyro-bias integrator, plus a simple
// position/velocity blend).
//
// Attitude: at every IMU sample the body rate is corrected by Kp_tilt·(gravity-direction error) in
// the body frame; each compass sample rotates the estimate about the N down axis by
// Kp_yaw·dt_mag·Δψ (compass used for yaw only, tilt-compensated with the estimated roll/pitch); the
// gyro bias integrates −Ki·(correction). Position/velocity: strapdown integration of the specific
// force (no accel-bias estimate), pulled towards GPS (against the stored state at the sample's time
// of validity, same buffer as the ESKF) and barometer by fixed gains. GPS and baro errors are gated
// against gate_sigma·√(σ_meas² + σ_nominal²) per axis; after `comp_reset_after_rejections`
// consecutive gated GPS samples the position and velocity are reset to GPS.
#pragma once

#include <memory>

#include "hexsim/nav/estimator.h"

namespace hexsim::nav {

// The "complementary" estimator. `params` must pass ValidateNavParams.
std::unique_ptr<Estimator> MakeComplementary(const NavParams& params);

}  // namespace hexsim::nav
