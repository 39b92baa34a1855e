#include "hexsim/nav/estimator.h"

#include <cmath>

#include "hexsim/nav/complementary.h"
#include "hexsim/nav/eskf.h"

namespace hexsim::nav {

double TiltCompensatedHeadingRad(const Eigen::Vector3d& m, double roll_rad, double pitch_rad) {
  const double cr = std::cos(roll_rad), sr = std::sin(roll_rad);
  const double cp = std::cos(pitch_rad), sp = std::sin(pitch_rad);
  const double x_h = m.x() * cp + m.y() * sr * sp + m.z() * cr * sp;
  const double y_h = m.y() * cr - m.z() * sr;
  return std::atan2(-y_h, x_h);
}

double DeclinationRad(const EarthFieldReference& earth) {
  return std::atan2(earth.B_N_uT.y(), earth.B_N_uT.x());
}

Status ValidateNavParams(const NavParams& p) {
  struct Check {
    const char* name;
    double value;
  };
  const Check positive[] = {
      {"gyro_noise_radps_rthz", p.gyro_noise_radps_rthz},
      {"accel_noise_mps2_rthz", p.accel_noise_mps2_rthz},
      {"gyro_bias_rw_radps2_rthz", p.gyro_bias_rw_radps2_rthz},
      {"accel_bias_rw_mps3_rthz", p.accel_bias_rw_mps3_rthz},
      {"mag_heading_std_rad", p.mag_heading_std_rad},
      {"mag_std_uT", p.mag_std_uT},
      {"gps_pos_std_m", p.gps_pos_std_m},
      {"gps_vel_std_mps", p.gps_vel_std_mps},
      {"baro_std_m", p.baro_std_m},
      {"mag_gate_sigma", p.mag_gate_sigma},
      {"gps_gate_sigma", p.gps_gate_sigma},
      {"baro_gate_sigma", p.baro_gate_sigma},
      {"init_tilt_std_rad", p.init_tilt_std_rad},
      {"init_yaw_std_rad", p.init_yaw_std_rad},
      {"init_vel_std_mps", p.init_vel_std_mps},
      {"init_pos_std_m", p.init_pos_std_m},
      {"init_gyro_bias_std_radps", p.init_gyro_bias_std_radps},
      {"init_accel_bias_std_mps2", p.init_accel_bias_std_mps2},
      {"align_time_s", p.align_time_s},
      {"comp_pos_std_m", p.comp_pos_std_m},
      {"gps_reset_timeout_s", p.gps_reset_timeout_s},
      {"mag_yaw_reset_timeout_s", p.mag_yaw_reset_timeout_s},
      {"comp_vel_std_mps", p.comp_vel_std_mps},
  };
  for (const Check& c : positive) {
    if (!(std::isfinite(c.value) && c.value > 0)) {
      return Status::BadInput(std::string("nav.") + c.name + ": must be a finite number > 0");
    }
  }
  const Check non_negative[] = {
      {"gps_delay_s", p.gps_delay_s},
      {"comp_tilt_gain_radps", p.comp_tilt_gain_radps},
      {"comp_yaw_gain_radps", p.comp_yaw_gain_radps},
      {"comp_bias_gain_rad", p.comp_bias_gain_rad},
  };
  for (const Check& c : non_negative) {
    if (!(std::isfinite(c.value) && c.value >= 0)) {
      return Status::BadInput(std::string("nav.") + c.name + ": must be a finite number >= 0");
    }
  }
  const Check fractions[] = {
      {"comp_pos_gain", p.comp_pos_gain},
      {"comp_vel_from_pos_gain", p.comp_vel_from_pos_gain},
      {"comp_vel_gain", p.comp_vel_gain},
      {"comp_baro_gain", p.comp_baro_gain},
  };
  for (const Check& c : fractions) {
    if (!(c.value >= 0 && c.value <= 1)) {
      return Status::BadInput(std::string("nav.") + c.name + ": must be in [0, 1]");
    }
  }
  if (p.cov_predict_every_n < 1) return Status::BadInput("nav.cov_predict_every_n: must be >= 1");
  if (!(p.cov_predict_rate_hz >= 0 && p.cov_predict_rate_hz <= 10000)) {
    return Status::BadInput("nav.cov_predict_rate_hz: must be in [0, 10000] (0 = every IMU sample)");
  }
  if (p.comp_reset_after_rejections < 1) {
    return Status::BadInput("nav.comp_reset_after_rejections: must be >= 1");
  }
  const Eigen::Vector3d& B = p.earth.B_N_uT;
  if (!B.allFinite() || std::hypot(B.x(), B.y()) <= 0.0) {
    return Status::BadInput(
        "nav.earth_B_N_uT: the Earth field reference needs a non-zero horizontal component");
  }
  return Status::Ok();
}

Result<std::unique_ptr<Estimator>> MakeEstimator(const std::string& name, const NavParams& params) {
  HEXSIM_RETURN_IF_ERROR(ValidateNavParams(params));
  if (name == "eskf") return MakeEskf(params);
  if (name == "complementary") return MakeComplementary(params);
  return Status::BadInput("nav.estimator: unknown estimator '" + name +
                          "' (expected eskf or complementary)");
}

}  // namespace hexsim::nav
