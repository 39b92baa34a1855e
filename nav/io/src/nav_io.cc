// NavParams from the `nav:` YAML map.
#include "hexsim/nav/nav_io.h"

#include <string>

namespace hexsim::nav {

Status ParseNavParams(YamlReader& r, NavParams* p) {
  r.Opt("estimator", &p->estimator, {"eskf", "complementary"});
  r.Opt("gyro_noise_radps_rthz", &p->gyro_noise_radps_rthz, Positive());
  r.Opt("accel_noise_mps2_rthz", &p->accel_noise_mps2_rthz, Positive());
  r.Opt("gyro_bias_rw_radps2_rthz", &p->gyro_bias_rw_radps2_rthz, Positive());
  r.Opt("accel_bias_rw_mps3_rthz", &p->accel_bias_rw_mps3_rthz, Positive());
  std::string mode = p->mag_mode == MagMode::kThreeAxis ? "3axis" : "heading";
  r.Opt("mag_mode", &mode, {"heading", "3axis"});
  p->mag_mode = mode == "3axis" ? MagMode::kThreeAxis : MagMode::kHeading;
  r.Opt("mag_heading_std_rad", &p->mag_heading_std_rad, Positive());
  r.Opt("mag_std_uT", &p->mag_std_uT, Positive());
  r.Opt("gps_pos_std_m", &p->gps_pos_std_m, Positive());
  r.Opt("gps_vel_std_mps", &p->gps_vel_std_mps, Positive());
  r.Opt("baro_std_m", &p->baro_std_m, Positive());
  r.Opt("mag_gate_sigma", &p->mag_gate_sigma, Positive());
  r.Opt("gps_gate_sigma", &p->gps_gate_sigma, Positive());
  r.Opt("baro_gate_sigma", &p->baro_gate_sigma, Positive());
  r.Opt("gps_delay_s", &p->gps_delay_s, InRange(0.0, 1.0));
  r.Opt("gps_reset_timeout_s", &p->gps_reset_timeout_s, Positive());
  r.Opt("mag_yaw_reset_timeout_s", &p->mag_yaw_reset_timeout_s, Positive());
  r.Opt("init_tilt_std_rad", &p->init_tilt_std_rad, Positive());
  r.Opt("init_yaw_std_rad", &p->init_yaw_std_rad, Positive());
  r.Opt("init_vel_std_mps", &p->init_vel_std_mps, Positive());
  r.Opt("init_pos_std_m", &p->init_pos_std_m, Positive());
  r.Opt("init_gyro_bias_std_radps", &p->init_gyro_bias_std_radps, Positive());
  r.Opt("init_accel_bias_std_mps2", &p->init_accel_bias_std_mps2, Positive());
  r.Opt("align_time_s", &p->align_time_s, Positive());
  r.Opt("cov_predict_every_n", &p->cov_predict_every_n, InRange(1, 100));
  r.Opt("cov_predict_rate_hz", &p->cov_predict_rate_hz, InRange(0, 10000));
  r.Opt("comp_tilt_gain_radps", &p->comp_tilt_gain_radps, NonNegative());
  r.Opt("comp_yaw_gain_radps", &p->comp_yaw_gain_radps, NonNegative());
  r.Opt("comp_bias_gain_rad", &p->comp_bias_gain_rad, NonNegative());
  r.Opt("comp_pos_gain", &p->comp_pos_gain, InRange(0, 1));
  r.Opt("comp_vel_from_pos_gain", &p->comp_vel_from_pos_gain, InRange(0, 1));
  r.Opt("comp_vel_gain", &p->comp_vel_gain, InRange(0, 1));
  r.Opt("comp_baro_gain", &p->comp_baro_gain, InRange(0, 1));
  r.Opt("comp_pos_std_m", &p->comp_pos_std_m, Positive());
  r.Opt("comp_vel_std_mps", &p->comp_vel_std_mps, Positive());
  r.Opt("comp_reset_after_rejections", &p->comp_reset_after_rejections, InRange(1, 1e6));
  r.Opt("earth_B_N_uT", &p->earth.B_N_uT);
  return r.Finish();
}

}  // namespace hexsim::nav
