// PX4 state the ULog importer reads beside the sensors, on ULog files the test writes itself: the
// armed state (actuator_armed, else vehicle_status), the sensor rotations of each PX4 release, and
// the magnetometer power compensation (CAL_MAG_COMP_TYP, CAL_MAGn_X/Y/ZCOMP).
#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "hexsim/logs/mag_input.h"
#include "hexsim/logs/ulog.h"
#include "hexsim/logs/ulog_import.h"
#include "support/ulog_writer.h"

namespace hexsim::logs {
namespace {

using testing::Pack;
using testing::ULogWriter;

constexpr double kDeg = M_PI / 180.0;

// 10 s of attitude at 10 Hz from t = 1 s (level, identity).
void Attitude(ULogWriter* w) {
  w->Format("vehicle_attitude:uint64_t timestamp;float[4] q;");
  const uint16_t att = w->Subscribe("vehicle_attitude", 0);
  for (int k = 0; k <= 100; ++k) {
    w->Data(att, Pack<uint64_t>(1000000 + 100000ull * static_cast<uint64_t>(k)) + Pack(1.0f) + Pack(0.0f) + Pack(0.0f) +
                     Pack(0.0f));
  }
}

// The attitude and 20 raw sensor_mag samples of device 9 (0.2, 0, 0.4 G) from t = 1.05 s.
void AttitudeAndRawMag(ULogWriter* w) {
  Attitude(w);
  w->Format("sensor_mag:uint64_t timestamp;uint32_t device_id;float x;float y;float z;");
  const uint16_t mag = w->Subscribe("sensor_mag", 0);
  for (int k = 0; k < 20; ++k) {
    w->Data(mag, Pack<uint64_t>(1050000 + 100000ull * static_cast<uint64_t>(k)) + Pack<uint32_t>(9) + Pack(0.2f) +
                     Pack(0.0f) + Pack(0.4f));
  }
}

double ArmedAt(const FlightLog& log, double t) {
  const auto& ts = log.Column("t_s");
  for (size_t r = 0; r < ts.size(); ++r) {
    if (std::fabs(ts[r] - t) < 1e-6) return log.Column("armed")[r];
  }
  return -1;
}

TEST(ULogPx4State, GivenActuatorArmedEvents_WhenImported_ThenTheArmedColumnFollowsThemFromTheFirstRow) {
  ULogWriter w;
  Attitude(&w);
  w.Format("actuator_armed:uint64_t timestamp;bool armed;bool prearmed;uint8_t[6] _padding0;");
  // vehicle_status says otherwise: actuator_armed, the outputs' own state, wins.
  w.Format("vehicle_status:uint64_t timestamp;uint8_t nav_state;uint8_t arming_state;");
  const uint16_t aa = w.Subscribe("actuator_armed", 0), vs = w.Subscribe("vehicle_status", 0);
  w.Data(vs, Pack<uint64_t>(1000000) + Pack<uint8_t>(0) + Pack<uint8_t>(1));
  // First record after the log starts (2 s): its state holds from the first row on.
  w.Data(aa, Pack<uint64_t>(2000000) + Pack<uint8_t>(0) + Pack<uint8_t>(0) + std::string(6, '\0'));
  w.Data(aa, Pack<uint64_t>(4000000) + Pack<uint8_t>(1) + Pack<uint8_t>(0) + std::string(6, '\0'));
  w.Data(aa, Pack<uint64_t>(8500000) + Pack<uint8_t>(0) + Pack<uint8_t>(0) + std::string(6, '\0'));
  auto r = ImportULog(w.bytes(), "a.ulg");
  ASSERT_TRUE(r.ok()) << r.status().message();
  const FlightLog& log = r->log;
  ASSERT_TRUE(log.Has("armed"));
  EXPECT_EQ(ArmedAt(log, 1.0), 0.0);
  EXPECT_EQ(ArmedAt(log, 3.9), 0.0);
  EXPECT_EQ(ArmedAt(log, 4.0), 1.0);
  EXPECT_EQ(ArmedAt(log, 8.4), 1.0);
  EXPECT_EQ(ArmedAt(log, 8.5), 0.0);
  EXPECT_EQ(log.meta["armed_source"], "actuator_armed.armed");
  EXPECT_FALSE(log.Has("armed_t_s"));
}

TEST(ULogPx4State, GivenOnlyVehicleStatus_WhenImported_ThenArmingState2IsArmed) {
  ULogWriter w;
  Attitude(&w);
  w.Format("vehicle_status:uint64_t timestamp;uint8_t nav_state;uint8_t arming_state;");
  const uint16_t vs = w.Subscribe("vehicle_status", 0);
  const uint8_t states[4] = {1, 2, 2, 1};  // standby, armed, armed, standby
  for (int k = 0; k < 4; ++k) w.Data(vs, Pack<uint64_t>(1000000 + 2500000ull * k) + Pack<uint8_t>(3) + Pack(states[k]));
  auto r = ImportULog(w.bytes(), "s.ulg");
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_EQ(ArmedAt(r->log, 3.4), 0.0);
  EXPECT_EQ(ArmedAt(r->log, 3.5), 1.0);
  EXPECT_EQ(ArmedAt(r->log, 8.4), 1.0);
  EXPECT_EQ(ArmedAt(r->log, 8.5), 0.0);
  EXPECT_NE(r->log.meta["armed_source"].get<std::string>().find("vehicle_status"), std::string::npos);
}

// The px4_calibration of a calibrated compass with CAL_MAG0_ROT `rot`, logged by release `release`
// (ver_sw_release 0xMMmm0000; 0 = not logged).
nlohmann::json CalibrationOf(int rot, uint32_t release, bool custom_angles = false) {
  ULogWriter w;
  if (release != 0) w.Info("uint32_t ver_sw_release", Pack(release));
  w.ParamInt("CAL_MAG0_ID", 5);
  w.ParamInt("CAL_MAG0_ROT", rot);
  w.Param("CAL_MAG0_XOFF", 0.1f);
  if (custom_angles) {
    w.Param("CAL_MAG0_ROLL", 10.0f);
    w.Param("CAL_MAG0_PITCH", -20.0f);
    w.Param("CAL_MAG0_YAW", 30.0f);
  }
  Attitude(&w);
  w.Format("vehicle_magnetometer:uint64_t timestamp;uint32_t device_id;float[3] magnetometer_ga;");
  const uint16_t vm = w.Subscribe("vehicle_magnetometer", 0);
  w.Data(vm, Pack<uint64_t>(1500000) + Pack<uint32_t>(5) + Pack(0.2f) + Pack(0.0f) + Pack(0.4f));
  auto r = ImportULog(w.bytes(), "r.ulg");
  EXPECT_TRUE(r.ok()) << r.status().message();
  return r.ok() ? r->log.meta["compasses"][0]["px4_calibration"] : nlohmann::json();
}

Eigen::Matrix3d MatrixOf(const nlohmann::json& c) {
  Eigen::Matrix3d R;
  for (int k = 0; k < 9; ++k) R(k / 3, k % 3) = c["rotation_matrix"][static_cast<size_t>(k)].get<double>();
  return R;
}

Eigen::Matrix3d Euler(double roll_deg, double pitch_deg, double yaw_deg) {
  return (Eigen::AngleAxisd(yaw_deg * kDeg, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch_deg * kDeg, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll_deg * kDeg, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

TEST(ULogPx4State, GivenRotationsBeyond25_WhenImported_ThenEachReleaseLayoutIsUsedOrTheRotationIsUnknown) {
  constexpr uint32_t k114 = 0x010E0000, k110 = 0x010A0000, k111 = 0x010B0200;
  // 1.12 on (MAVLink's MAV_SENSOR_ORIENTATION): 38 = roll 90, pitch 68, yaw 293; 45 = pitch 45.
  auto c = CalibrationOf(38, k114);
  ASSERT_TRUE(c["rotation_known"].get<bool>());
  EXPECT_TRUE(MatrixOf(c).isApprox(Euler(90, 68, 293), 1e-9));
  EXPECT_TRUE(MatrixOf(CalibrationOf(45, k114)).isApprox(Euler(0, 45, 0), 1e-9));
  // 1.10 and older: 26 = roll 270, yaw 270 (1.12 on: pitch 180, yaw 90).
  c = CalibrationOf(26, k110);
  ASSERT_TRUE(c["rotation_known"].get<bool>());
  EXPECT_TRUE(MatrixOf(c).isApprox(Euler(270, 0, 270), 1e-9));
  EXPECT_TRUE(MatrixOf(CalibrationOf(26, k114)).isApprox(Euler(0, 180, 90), 1e-9));
  // 1.11 (between the layouts), no release logged, or past the table: unknown.
  EXPECT_FALSE(CalibrationOf(26, k111)["rotation_known"].get<bool>());
  EXPECT_FALSE(CalibrationOf(30, 0)["rotation_known"].get<bool>());
  EXPECT_FALSE(CalibrationOf(48, k114)["rotation_known"].get<bool>());
  // 0..25 are the same everywhere; 100 is the custom Euler angles CAL_MAG0_ROLL/PITCH/YAW.
  EXPECT_TRUE(MatrixOf(CalibrationOf(25, 0)).isApprox(Euler(0, 270, 0), 1e-9));
  c = CalibrationOf(100, k114, true);
  ASSERT_TRUE(c["rotation_known"].get<bool>());
  EXPECT_TRUE(MatrixOf(c).isApprox(Euler(10, -20, 30), 1e-6));
  EXPECT_FALSE(CalibrationOf(100, k114, false)["rotation_known"].get<bool>());
}

// PX4 1.11 on logs raw sensor_mag in the sensor's own frame and rotates it into the body frame in
// its calibration (CAL_MAGn_ROT for an external compass): the rotation must come with the raw field
// too, else an external compass mounted upside down (luk8426/flugdrohne: CAL_MAG1_ROT 10, roll 180
// yaw 90) is fitted in its sensor frame (residual 10 uT RMS there instead of 2.7).
TEST(ULogPx4State, GivenRawSensorMagOfARotatedExternalCompass_WhenRead_ThenItsRotationTakesItToTheBodyFrame) {
  ULogWriter w;
  w.Info("uint32_t ver_sw_release", Pack<uint32_t>(0x010E0000));
  w.ParamInt("CAL_MAG0_ID", 9);
  w.ParamInt("CAL_MAG0_ROT", 10);  // roll 180, yaw 90
  w.Param("CAL_MAG0_XSCALE", 1.1f);
  AttitudeAndRawMag(&w);
  auto r = ImportULog(w.bytes(), "rot.ulg");
  ASSERT_TRUE(r.ok()) << r.status().message();
  const auto& c = r->log.meta["compasses"][0]["px4_calibration"];
  ASSERT_TRUE(c["rotation_known"].get<bool>());
  EXPECT_TRUE(MatrixOf(c).isApprox(Euler(180, 0, 90), 1e-9));
  auto in = ParseMagInput(w.bytes(), "rot.ulg", "mag");
  ASSERT_TRUE(in.ok()) << in.status().message();
  const Eigen::Matrix3d S = Eigen::Vector3d(1.1, 1.0, 1.0).asDiagonal();
  EXPECT_TRUE(in->body_from_raw.isApprox(Euler(180, 0, 90) * S, 1e-6)) << in->body_from_raw;
}

// A compass whose raw reading holds the motors' field P·d (d = −comp, gauss per unit P), with PX4's
// compensation CAL_MAG_COMP_TYP `type` in force; the magnetometer topic is raw sensor_mag or the
// calibrated vehicle_magnetometer. Returns the samples calibrate reads and the truth K·B + b each.
struct CompCase {
  MagInput in;
  std::vector<Eigen::Vector3d> truth_uT;
};

CompCase WithCompensation(int type, bool calibrated) {
  const Eigen::Vector3d b(0.12, -0.05, 0.2), comp(0.05, -0.3, 0.15), off(0.02, 0.01, -0.03);
  ULogWriter w;
  w.Info("uint32_t ver_sw_release", Pack<uint32_t>(0x010E0000));
  w.ParamInt("CAL_MAG_COMP_TYP", type);
  w.ParamInt("CAL_MAG0_ID", 9);
  w.ParamInt("CAL_MAG0_ROT", 2);  // yaw 90
  const char* axes[3] = {"X", "Y", "Z"};
  for (int k = 0; k < 3; ++k) {
    w.Param(std::string("CAL_MAG0_") + axes[k] + "COMP", static_cast<float>(comp(k)));
    w.Param(std::string("CAL_MAG0_") + axes[k] + "OFF", static_cast<float>(off(k)));
  }
  Attitude(&w);
  w.Format("sensor_mag:uint64_t timestamp;uint32_t device_id;float x;float y;float z;");
  w.Format("vehicle_magnetometer:uint64_t timestamp;uint32_t device_id;float[3] magnetometer_ga;");
  w.Format("battery_status:uint64_t timestamp;float voltage_v;float current_a;");
  w.Format("actuator_controls_0:uint64_t timestamp;float[8] control;");
  w.Format("actuator_armed:uint64_t timestamp;bool armed;");
  const uint16_t mag = w.Subscribe(calibrated ? "vehicle_magnetometer" : "sensor_mag", 0);
  const uint16_t bat = w.Subscribe("battery_status", 0), thr = w.Subscribe("actuator_controls_0", 0),
                 aa = w.Subscribe("actuator_armed", 0);
  w.Data(aa, Pack<uint64_t>(1000000) + Pack<uint8_t>(0));
  w.Data(aa, Pack<uint64_t>(3000000) + Pack<uint8_t>(1));  // armed from 3 s
  const Eigen::Matrix3d R = Euler(0, 0, 90);
  CompCase out;
  for (int k = 0; k < 90; ++k) {
    const uint64_t t = 1050000 + 100000ull * static_cast<uint64_t>(k);
    const double throttle = 0.3 + 0.2 * std::sin(0.3 * k), current_A = 40.0 * throttle;
    std::string ctl = Pack(t);
    for (int m = 0; m < 8; ++m) ctl += Pack<float>(m == 3 ? static_cast<float>(throttle) : 0.0f);
    w.Data(thr, ctl);
    w.Data(bat, Pack(t) + Pack(15.0f) + Pack(static_cast<float>(current_A)));
    const double armed = t >= 3000000 ? 1.0 : 0.0;
    const double p = type == 1 ? armed * throttle : current_A / 1000.0;
    const double az = 2.39996 * k, el = std::asin(1.0 - 2.0 * (k + 0.5) / 90);
    const Eigen::Vector3d field = 0.5 * Eigen::Vector3d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
    const Eigen::Vector3d raw = field + b - p * comp;  // the motors' field: −P·comp
    const Eigen::Vector3f logged = (calibrated ? Eigen::Vector3d(R * (raw + p * comp - off)) : raw).cast<float>();
    w.Data(mag, Pack(t + 1000) + Pack<uint32_t>(9) + Pack(logged(0)) + Pack(logged(1)) + Pack(logged(2)));
    out.truth_uT.emplace_back(100.0 * (field + b));
  }
  auto in = ParseMagInput(w.bytes(), "c.ulg", "mag");
  EXPECT_TRUE(in.ok()) << in.status().message();
  if (in.ok()) out.in = *in;
  return out;
}

TEST(ULogPx4State, GivenPowerCompensationInForce_WhenRead_ThenSamplesAreWhatPx4sOffsetsActOnForEveryTopicAndType) {
  for (const int type : {1, 2}) {
    for (const bool calibrated : {false, true}) {
      SCOPED_TRACE(::testing::Message() << "type " << type << (calibrated ? " calibrated" : " raw"));
      const CompCase c = WithCompensation(type, calibrated);
      // One sample per new mag time; the last one comes after the last attitude row.
      ASSERT_GE(c.in.field.size(), 80u);
      double worst = 0.0;
      for (size_t i = 0; i < c.in.field.size(); ++i) worst = std::max(worst, (c.in.field[i] - c.truth_uT[i]).norm());
      // float32 logging and one attitude row of hold (0.1 s of the power signal) at most.
      std::string notes;
      for (const auto& n : c.in.notes) notes += n + "\n";
      EXPECT_LT(worst, 0.05) << notes;
      EXPECT_NE(notes.find("power compensation in force"), std::string::npos) << notes;
    }
  }
}

TEST(ULogPx4State, GivenCompensationButNoPowerSignal_WhenImported_ThenWarned) {
  ULogWriter w;
  w.ParamInt("CAL_MAG_COMP_TYP", 3);  // battery instance 1, absent
  w.ParamInt("CAL_MAG0_ID", 9);
  w.Param("CAL_MAG0_XCOMP", 0.1f);
  Attitude(&w);
  w.Format("sensor_mag:uint64_t timestamp;uint32_t device_id;float x;float y;float z;");
  const uint16_t mag = w.Subscribe("sensor_mag", 0);
  w.Data(mag, Pack<uint64_t>(1500000) + Pack<uint32_t>(9) + Pack(0.2f) + Pack(0.0f) + Pack(0.4f));
  auto r = ImportULog(w.bytes(), "n.ulg");
  ASSERT_TRUE(r.ok()) << r.status().message();
  ASSERT_FALSE(r->warnings.empty());
  EXPECT_NE(r->warnings.back().find("CAL_MAG_COMP_TYP 3"), std::string::npos) << r->warnings.back();
  EXPECT_FALSE(r->log.Has("px4_mag_power"));
}

TEST(ULogPx4State, GivenOldSensorCombinedMagnetometer_WhenRead_ThenTheCalMagPrimeSlotUndoesItNotSlot0) {
  // PX4 1.10 and older: sensor_combined magnetometer_ga is the primary compass, calibrated with the
  // slot whose CAL_MAGn_ID is CAL_MAG_PRIME (here slot 2); slot 0 belongs to another sensor.
  const Eigen::Vector3d off(0.38, 0.46, 0.02), scale(1.11, 0.97, 0.95);
  ULogWriter w;
  w.Info("uint32_t ver_sw_release", Pack<uint32_t>(0x01060000));
  w.ParamInt("CAL_MAG_PRIME", 73233);
  w.ParamInt("CAL_MAG0_ID", 263178);
  w.ParamInt("CAL_MAG2_ID", 73233);
  w.ParamInt("CAL_MAG2_ROT", 0);
  const char* axes[3] = {"X", "Y", "Z"};
  for (int k = 0; k < 3; ++k) {
    w.Param(std::string("CAL_MAG0_") + axes[k] + "OFF", 1.0f);
    w.Param(std::string("CAL_MAG0_") + axes[k] + "SCALE", 0.2f);
    w.Param(std::string("CAL_MAG2_") + axes[k] + "OFF", static_cast<float>(off(k)));
    w.Param(std::string("CAL_MAG2_") + axes[k] + "SCALE", static_cast<float>(scale(k)));
  }
  Attitude(&w);
  w.Format("sensor_combined:uint64_t timestamp;float[3] gyro_rad;float[3] magnetometer_ga;");
  const uint16_t sc = w.Subscribe("sensor_combined", 0);
  const Eigen::Vector3d raw(0.5, -0.7, 0.45);  // gauss
  const Eigen::Vector3f cal = (scale.asDiagonal() * (raw - off)).cast<float>();
  for (int k = 0; k < 20; ++k) {
    w.Data(sc, Pack<uint64_t>(1050000 + 100000ull * static_cast<uint64_t>(k)) + Pack(0.0f) + Pack(0.0f) + Pack(0.0f) +
                   Pack(cal(0)) + Pack(cal(1)) + Pack(cal(2)));
  }
  auto r = ImportULog(w.bytes(), "old.ulg");
  ASSERT_TRUE(r.ok()) << r.status().message();
  const auto& c = r->log.meta["compasses"][0]["px4_calibration"];
  EXPECT_EQ(c["index"], 2);
  EXPECT_EQ(c["matched_by"], "CAL_MAG_PRIME");
  auto in = ParseMagInput(w.bytes(), "old.ulg", "mag");
  ASSERT_TRUE(in.ok()) << in.status().message();
  ASSERT_FALSE(in->field.empty());
  EXPECT_LT((in->field[0] - 100.0 * raw).norm(), 1e-3) << in->field[0].transpose();
  EXPECT_EQ(in->px4_index, 2);
}

TEST(ULogPx4State, GivenTheDeviceIdInTwoSlots_WhenImported_ThenTheFirstSlotCalibratesAsInPx4) {
  // PX4 1.14 logs seen in the wild hold the same CAL_MAGn_ID twice: the calibration in force in slot 0
  // (rotation, offsets) and a stale one further on (rotation 0, zero offsets). PX4 uses the first.
  ULogWriter w;
  w.ParamInt("CAL_MAG0_ID", 9);
  w.ParamInt("CAL_MAG0_ROT", 10);
  w.ParamInt("CAL_MAG1_ID", 9);
  w.ParamInt("CAL_MAG1_ROT", 0);
  const char* axes[3] = {"X", "Y", "Z"};
  for (int k = 0; k < 3; ++k) {
    w.Param(std::string("CAL_MAG0_") + axes[k] + "OFF", 0.1f * static_cast<float>(k + 1));
    w.Param(std::string("CAL_MAG1_") + axes[k] + "OFF", 0.0f);
  }
  AttitudeAndRawMag(&w);
  auto r = ImportULog(w.bytes(), "twice.ulg");
  ASSERT_TRUE(r.ok()) << r.status().message();
  const auto& c = r->log.meta["compasses"][0]["px4_calibration"];
  EXPECT_EQ(c["index"], 0);
  EXPECT_EQ(c["matched_by"], "device_id");
}

TEST(ULogPx4State, GivenAULog_WhenInfoIsAsked_ThenTopicsRatesAndCompassParametersAreListed) {
  // `hexsim import --info` on a .ulg said "not an ArduPilot DataFlash log".
  ULogWriter w;
  w.ParamInt("CAL_MAG0_ID", 9);
  w.ParamInt("SYS_AUTOSTART", 4001);
  w.ParamInt("MPC_XY_VEL_MAX", 12);
  w.Format("sensor_mag:uint64_t timestamp;uint32_t device_id;float x;float y;float z;");
  const uint16_t mag = w.Subscribe("sensor_mag", 0);
  for (int k = 0; k < 21; ++k) {
    w.Data(mag, Pack<uint64_t>(1000000 + 100000ull * static_cast<uint64_t>(k)) + Pack<uint32_t>(9) + Pack(0.2f) +
                    Pack(0.0f) + Pack(0.4f));
  }
  auto u = ParseULog(w.bytes(), "i.ulg");
  ASSERT_TRUE(u.ok()) << u.status().message();
  const std::string info = ULogInfo(*u, "i.ulg");
  EXPECT_NE(info.find("sensor_mag[0]: 21 records, 10.0 Hz"), std::string::npos) << info;
  EXPECT_NE(info.find("time span: 1.0 .. 3.0 s (2.0 s)"), std::string::npos) << info;
  EXPECT_NE(info.find("CAL_MAG0_ID = 9"), std::string::npos) << info;
  EXPECT_NE(info.find("SYS_AUTOSTART = 4001"), std::string::npos) << info;
  EXPECT_EQ(info.find("MPC_XY_VEL_MAX"), std::string::npos) << info;
}

// PX4 publishes one actuator_outputs instance per output driver. A PX4 1.9 log with UAVCAN ESCs has
// instance 0 all zeros (main PWM unused), its motors on instance 1 as UAVCAN raw commands (0..8191)
// and servos parked on instance 2: the motors are the instance whose outputs move, read on their
// command's own full scale.
TEST(ULogPx4State, GivenMotorsOnTheUavcanOutputsInstance_WhenImported_ThenTheyAreReadFromItOnItsFullScale) {
  ULogWriter w;
  Attitude(&w);
  w.Format("actuator_outputs:uint64_t timestamp;uint32_t noutputs;float[8] output;");
  const uint16_t pwm = w.Subscribe("actuator_outputs", 0), can = w.Subscribe("actuator_outputs", 1),
                 aux = w.Subscribe("actuator_outputs", 2);
  for (int k = 0; k < 90; ++k) {
    const uint64_t t = 1050000 + 100000ull * static_cast<uint64_t>(k);
    std::string zero = Pack(t) + Pack<uint32_t>(8), cmd = Pack(t) + Pack<uint32_t>(6), park = Pack(t) + Pack<uint32_t>(6);
    for (int m = 0; m < 8; ++m) {
      zero += Pack(0.0f);
      cmd += Pack(static_cast<float>(m < 4 ? 4000.0 + 800.0 * std::sin(0.2 * k + m) : 0.0));
      park += Pack(1500.0f);
    }
    w.Data(pwm, zero);
    w.Data(can, cmd);
    w.Data(aux, park);
  }
  auto r = ImportULog(w.bytes(), "uavcan.ulg");
  ASSERT_TRUE(r.ok()) << r.status().message();
  const FlightLog& log = r->log;
  ASSERT_TRUE(log.Has("motor_1_u"));
  const auto& t = log.Column("t_s");
  const auto& u1 = log.Column("motor_1_u");
  size_t checked = 0;
  for (size_t i = 0; i < t.size(); ++i) {
    if (!std::isfinite(u1[i])) continue;
    EXPECT_GT(u1[i], (4000.0 - 810.0) / 8191.0) << t[i];
    EXPECT_LT(u1[i], (4000.0 + 810.0) / 8191.0) << t[i];
    ++checked;
  }
  EXPECT_GT(checked, 50u);
}

}  // namespace
}  // namespace hexsim::logs
