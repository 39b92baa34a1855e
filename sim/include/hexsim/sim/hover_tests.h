// Response experiments at hover, built on Simulation: a step on one loop's setpoint, a multisine
// on one loop's setpoint (frequency response), and a disturbance (gust, payload release).
//
// The vehicle takes off to a hover point and settles under the built-in cascade. Then:
//   roll | pitch | yaw : a test controller (wrapping the built-in CascadedController) flies the
//                        attitude loop alone: q_sp = Euler(r_roll, r_pitch, r_yaw) and the hover
//                        thrust (captured at the switch, divided by cos φ_sp·cos θ_sp); the input
//                        r is added on the chosen axis; the output is the true Euler angle.
//   alt                : the position setpoint's altitude gets r; the output is the true altitude.
//   vel_N              : velocity control (position_valid = false) with v_N setpoint r; the output
//                        is the true north velocity.
// Angles are in degrees at this interface, altitude in m, velocity in m/s.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "hexsim/common/status.h"
#include "hexsim/sim/response.h"
#include "hexsim/sim/simulation.h"

namespace hexsim::sim {

enum class ResponseAxis { kRoll, kPitch, kYaw, kAlt, kVelN };
Result<ResponseAxis> ParseResponseAxis(const std::string& name);  // roll|pitch|yaw|alt|vel_N
std::string AxisName(ResponseAxis axis);
std::string AxisUnit(ResponseAxis axis);  // deg | m | m/s
bool IsAttitudeAxis(ResponseAxis axis);    // roll, pitch or yaw

struct HoverOptions {
  double hover_alt_m = 10.0;
  double settle_s = 12.0;     // take-off and settling before the test input starts
  double sample_hz = 200.0;   // recorded series (a divisor of the physics rate)
};

struct TimeSeries {
  std::vector<double> t_s, reference, output;  // axis units; reference is the input added
};

struct StepTestResult {
  TimeSeries series;
  double t_step_s = 0.0;
  double initial = 0.0;  // output at the step
  StepMetrics metrics;
};
Result<StepTestResult> RunStepTest(const RunSetup& setup, ResponseAxis axis, double size, double after_s,
                                   const HoverOptions& hover = {});

struct FreqTestOptions {
  double f_lo_hz = 0.2;
  double f_hi_hz = 8.0;
  double amplitude = 4.0;     // peak of the multisine, axis units
  int period_samples = 2048;  // at HoverOptions::sample_hz
  int periods = 4;            // analysed (one more is run first and discarded as transient)
  double min_coherence = 0.8;
};
struct FreqTestResult {
  TimeSeries series;
  FrequencyResponse response;  // closed loop T: reference → output
  LoopMetrics metrics;
};
Result<FreqTestResult> RunFrequencyTest(const RunSetup& setup, ResponseAxis axis, const FreqTestOptions& options,
                                        const HoverOptions& hover = {});

struct DisturbanceSpec {
  Eigen::Vector3d gust_N_mps = Eigen::Vector3d::Zero();  // step in the mean wind
  double gust_duration_s = 0.0;                           // 0: stays
  double payload_release_kg = 0.0;                        // carried from take-off, dropped at onset
  double after_s = 15.0;                                  // recorded after the onset
  double recovery_band_m = 0.25;                          // recovered: deviation stays within this
};
struct DisturbTestResult {
  TimeSeries series;  // output = |p − p_hover| (m); reference = wind speed (m/s) or payload (kg)
  std::vector<double> dev_N_m, dev_E_m, dev_D_m;
  double t_onset_s = 0.0;
  double peak_deviation_m = 0.0;
  double peak_time_s = 0.0;        // after onset
  double recovery_time_s = -1.0;   // after onset; −1: not recovered within the record
  double peak_tilt_deg = 0.0;
};
Result<DisturbTestResult> RunDisturbTest(const RunSetup& setup, const DisturbanceSpec& spec,
                                         const HoverOptions& hover = {});

}  // namespace hexsim::sim
