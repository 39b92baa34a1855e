// Error-state Kalman filter (in the spirit of PX4 EKF2).
//
// Nominal state: q_NB, v_N, p_N, gyro bias b_g, accel bias b_a. Error state (15): δθ (rotation
// error in N: R_true = (I + [δθ]×)·R), δv, δp, δb_g, δb_a.
//   δθ' = −R δb_g,  δv' = −[R(f−b_a)]× δθ − R δb_a,  δp' = δv,  δb' = white noise.
// Covariance prediction P ← F P Fᵀ + Q with F = I + A·Δt at the filter rate `cov_predict_rate_hz`
// (default 100 Hz, EKF2's and EKF3's prediction rate) on the accumulated interval Δt = Σdt and delta
// velocity Δv_N = ΣR·f·dt (f_N·dt → Δv_N in A); the nominal state integrates every IMU sample
// (fixed-size 15×15, no heap in the loop). Measurements are fused on arrival against the covariance
// of the last filter step (at most one filter period old, as EKF2 fuses at its filter step).
// Updates are sequential scalar updates in Joseph form (expanded for a symmetric P, evaluated on
// the upper triangle and mirrored); each measurement group is gated first: every component must
// satisfy |y_i| ≤ gate_sigma·√S_ii, else the whole group is rejected and counted. GPS horizontal
// position, GPS height and GPS velocity are separate groups.
// Recovery (EKF2-style): no horizontal GPS fused for gps_reset_timeout_s → horizontal position and
// velocity reset to GPS; no GPS velocity fused for gps_reset_timeout_s (the position still fusing)
// → velocity reset to GPS; no compass fused for mag_yaw_reset_timeout_s → yaw reset to the compass
// (all counted in SensorStats::resets).
// Heading Jacobian: the compass is levelled with the estimated tilt, so the innovation is
// y = δθ_D − B_D(B_N δθ_N + B_E δθ_E)/B_H² (a tilt error leaks in ×tan(inclination)).
// Compass: heading mode (ψ from the tilt-compensated field with the estimated roll/pitch, plus the
// reference declination) or 3-axis mode (h = R_NBᵀ B_N; fused as a heading while the yaw std
// exceeds 5°, because a large yaw error makes the 3-axis linearisation poor).
// GPS latency: stored-state approach. Past (p, v) are kept every 5 ms for 1.275 s; the innovation is
// formed against the stored state at the sample's time of validity, the gain from the current
// covariance, and the correction is applied to the current state and to the stored history alike.
// Compass and barometer are fused on arrival (taken as current).
#pragma once

#include <memory>

#include "hexsim/nav/estimator.h"

namespace hexsim::nav {

// The "eskf" estimator. `params` must pass ValidateNavParams (MakeEstimator checks it).
std::unique_ptr<Estimator> MakeEskf(const NavParams& params);

}  // namespace hexsim::nav
