#include "ulog_mag_cal.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include <Eigen/Geometry>
#include <fmt/format.h>

namespace hexsim::logs::internal {
namespace {

constexpr int kCalSlots = 4;  // CAL_MAG0..CAL_MAG3
constexpr double kDegToRad = M_PI / 180.0;

// PX4's rotation enum (src/lib/conversion/rotation.h): {roll, pitch, yaw} in degrees. 0..25 mean
// the same in every release. PX4 1.12 renumbered the rest to match MAVLink's MAV_SENSOR_ORIENTATION
// (PX4 pull requests 14797 and 15784) and later appended 42..47; 1.10 and older had their own 26..34.
// 1.11 sat between the two layouts, so there (and where the log names no release) only 0..25 are
// taken as known. 100 is ROTATION_CUSTOM: the Euler angles CAL_MAGn_ROLL/PITCH/YAW (PX4 1.13 on).
constexpr std::array<std::array<int, 3>, 48> kRotations = {{
    {0, 0, 0},     {0, 0, 45},    {0, 0, 90},    {0, 0, 135},   {0, 0, 180},   {0, 0, 225},   {0, 0, 270},
    {0, 0, 315},   {180, 0, 0},   {180, 0, 45},  {180, 0, 90},  {180, 0, 135}, {0, 180, 0},   {180, 0, 225},
    {180, 0, 270}, {180, 0, 315}, {90, 0, 0},    {90, 0, 45},   {90, 0, 90},   {90, 0, 135},  {270, 0, 0},
    {270, 0, 45},  {270, 0, 90},  {270, 0, 135}, {0, 90, 0},    {0, 270, 0},   {0, 180, 90},  {0, 180, 270},
    {90, 90, 0},   {180, 90, 0},  {270, 90, 0},  {90, 180, 0},  {270, 180, 0}, {90, 270, 0},  {180, 270, 0},
    {270, 270, 0}, {90, 180, 90}, {90, 0, 270},  {90, 68, 293}, {0, 315, 0},   {90, 315, 0},  {270, 0, 180},
    {270, 0, 270}, {0, 90, 180},  {0, 9, 180},   {0, 45, 0},    {270, 0, 225}, {270, 0, 315},
}};
// PX4 1.10 and older: 26..34.
constexpr std::array<std::array<int, 3>, 9> kRotationsBefore111 = {{
    {270, 0, 270}, {180, 270, 0}, {0, 90, 180}, {90, 90, 0}, {90, 68, 293}, {270, 90, 0}, {0, 9, 180}, {0, 45, 0}, {0, 315, 0},
}};
constexpr int kStableRotations = 26;  // 0..25
constexpr int kRotationCustom = 100;

// The log's PX4 release as major·100 + minor (ver_sw_release = 0xMMmmpptt), or -1 when not logged.
int Release(const ULog& u) {
  const auto it = u.info.find("ver_sw_release");
  if (it == u.info.end()) return -1;
  const double v = std::strtod(it->second.c_str(), nullptr);
  if (!(v > 0 && v < 4294967296.0)) return -1;
  const auto r = static_cast<uint32_t>(v);
  return static_cast<int>((r >> 24) & 0xFF) * 100 + static_cast<int>((r >> 16) & 0xFF);
}

// PX4's Dcm of Euler angles (roll φ, pitch θ, yaw ψ): R = Rz(ψ)·Ry(θ)·Rx(φ).
Eigen::Matrix3d Dcm(double roll_deg, double pitch_deg, double yaw_deg) {
  return (Eigen::AngleAxisd(yaw_deg * kDegToRad, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch_deg * kDegToRad, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll_deg * kDegToRad, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

double Param(const ULog& u, const std::string& name, double fallback) {
  const auto it = u.params.find(name);
  return it == u.params.end() ? fallback : it->second;
}

// The rotation of enum `rot` for the log's release; false when unknown. `slot`: the CAL_MAGn
// prefix for a custom rotation ("" for the board).
bool Rotation(const ULog& u, double rot, const std::string& slot, Eigen::Matrix3d* R) {
  if (rot != std::floor(rot)) return false;
  const int release = Release(u);
  std::array<int, 3> e{};
  if (rot >= 0 && rot < kStableRotations) {
    e = kRotations[static_cast<size_t>(rot)];
  } else if (rot >= kStableRotations && rot < static_cast<double>(kRotations.size()) && release >= 112) {
    e = kRotations[static_cast<size_t>(rot)];
  } else if (rot >= kStableRotations && rot < kStableRotations + static_cast<double>(kRotationsBefore111.size()) &&
             release >= 0 && release < 111) {
    e = kRotationsBefore111[static_cast<size_t>(rot) - kStableRotations];
  } else if (rot == kRotationCustom && !slot.empty() && u.params.count(slot + "ROLL") != 0) {
    *R = Dcm(Param(u, slot + "ROLL", 0), Param(u, slot + "PITCH", 0), Param(u, slot + "YAW", 0));
    return true;
  } else {
    return false;
  }
  *R = Dcm(e[0], e[1], e[2]);
  return true;
}

}  // namespace

nlohmann::json Px4MagCalibration(const ULog& u, double device_id, int instance, MagFrame frame) {
  if (frame == MagFrame::kRaw && device_id <= 0) return nullptr;
  int slot = -1;
  std::string matched_by = "device_id";
  // The first slot that holds the device id, as PX4 itself picks it (calibration::FindCurrentCalibrationIndex
  // returns the first match): a stale slot further on (a sensor moved between ports, same id, rotation 0
  // and zero offsets) must not override the calibration in force.
  for (int n = 0; n < kCalSlots && device_id > 0 && slot < 0; ++n) {
    if (Param(u, fmt::format("CAL_MAG{}_ID", n), -1) == device_id) slot = n;
  }
  // No device id (old topics): the first instance is the primary magnetometer PX4 selected, the one
  // CAL_MAG_PRIME names (PX4 1.10 and older, sensor_combined magnetometer_ga).
  const double prime = Param(u, "CAL_MAG_PRIME", 0);
  for (int n = 0; n < kCalSlots && slot < 0 && device_id <= 0 && instance == 0 && prime > 0; ++n) {
    if (Param(u, fmt::format("CAL_MAG{}_ID", n), -1) == prime) {
      slot = n;
      matched_by = "CAL_MAG_PRIME";
    }
  }
  if (slot < 0) {
    // No device id to match, or no slot holds it: the slot of the same instance.
    if (instance < 0 || instance >= kCalSlots || u.params.count(fmt::format("CAL_MAG{}_XOFF", instance)) == 0) {
      return nullptr;
    }
    slot = instance;
    matched_by = "instance";
  }
  const std::string p = fmt::format("CAL_MAG{}_", slot);
  auto vec = [&](const char* what, double fallback) {
    nlohmann::json v = nlohmann::json::array();
    for (const char* axis : {"X", "Y", "Z"}) v.push_back(Param(u, p + axis + what, fallback));
    return v;
  };
  nlohmann::json c = {{"index", slot},
                      {"matched_by", matched_by},
                      {"offsets_G", vec("OFF", 0.0)},
                      {"scales", vec("SCALE", 1.0)},
                      {"offdiagonals", vec("ODIAG", 0.0)},
                      {"power_compensation", vec("COMP", 0.0)},
                      {"power_compensation_type", Param(u, "CAL_MAG_COMP_TYP", 0)}};
  const double rot = Param(u, p + "ROT", -1);
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  bool known = true;
  // PX4 rotates a compass into the body frame in its calibration (calibration::Magnetometer::Correct:
  // R·S·(data + P·comp − off), R the CAL_MAGn_ROT rotation, or the board rotation for an internal one):
  // raw sensor_mag (PX4 1.11 on) and vehicle_magnetometer both need it; only the driver-calibrated
  // sensor_mag of older releases comes rotated by its driver.
  if (frame != MagFrame::kDriverCalibrated) {
    if (rot < 0) {  // internal: the board rotation, trimmed
      known = Rotation(u, Param(u, "SENS_BOARD_ROT", 0), "", &R);
      R = Dcm(Param(u, "SENS_BOARD_X_OFF", 0), Param(u, "SENS_BOARD_Y_OFF", 0), Param(u, "SENS_BOARD_Z_OFF", 0)) * R;
    } else {
      known = Rotation(u, rot, p, &R);
    }
  }
  c["rotation"] = rot;
  c["rotation_known"] = known;
  c["rotation_matrix"] = {R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2)};
  return c;
}

}  // namespace hexsim::logs::internal
