#include "ulog_mag_cal.h"

#include <array>
#include <cmath>
#include <string>

#include <Eigen/Geometry>
#include <fmt/format.h>

namespace hexsim::logs::internal {
namespace {

constexpr int kCalSlots = 4;  // CAL_MAG0..CAL_MAG3
constexpr double kDegToRad = M_PI / 180.0;

// PX4's rotation enum (src/lib/conversion/rotation.h): {roll, pitch, yaw} in degrees. Values
// 0..25 have kept their meaning across PX4 releases; later ones were renumbered, so they are not
// taken as known.
constexpr std::array<std::array<int, 3>, 26> kRotations = {{
    {0, 0, 0},     {0, 0, 45},    {0, 0, 90},    {0, 0, 135},  {0, 0, 180},   {0, 0, 225},   {0, 0, 270},
    {0, 0, 315},   {180, 0, 0},   {180, 0, 45},  {180, 0, 90}, {180, 0, 135}, {0, 180, 0},   {180, 0, 225},
    {180, 0, 270}, {180, 0, 315}, {90, 0, 0},    {90, 0, 45},  {90, 0, 90},   {90, 0, 135},  {270, 0, 0},
    {270, 0, 45},  {270, 0, 90},  {270, 0, 135}, {0, 90, 0},   {0, 270, 0},
}};

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

// The rotation of enum `rot`; false when unknown.
bool Rotation(double rot, Eigen::Matrix3d* R) {
  if (!(rot >= 0 && rot < static_cast<double>(kRotations.size())) || rot != std::floor(rot)) return false;
  const auto& e = kRotations[static_cast<size_t>(rot)];
  *R = Dcm(e[0], e[1], e[2]);
  return true;
}

}  // namespace

nlohmann::json Px4MagCalibration(const ULog& u, double device_id, int instance, MagFrame frame) {
  if (frame == MagFrame::kRaw && device_id <= 0) return nullptr;
  int slot = -1;
  std::string matched_by = "device_id";
  for (int n = 0; n < kCalSlots && device_id > 0; ++n) {
    if (Param(u, fmt::format("CAL_MAG{}_ID", n), -1) == device_id) slot = n;
  }
  if (slot < 0) {
    // No device id to match (old topics), or no slot holds it: the slot of the same instance.
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
                      {"power_compensation", vec("COMP", 0.0)}};
  const double rot = Param(u, p + "ROT", -1);
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  bool known = true;
  if (frame == MagFrame::kCalibrated) {
    if (rot < 0) {  // internal: the board rotation, trimmed
      known = Rotation(Param(u, "SENS_BOARD_ROT", 0), &R);
      R = Dcm(Param(u, "SENS_BOARD_X_OFF", 0), Param(u, "SENS_BOARD_Y_OFF", 0), Param(u, "SENS_BOARD_Z_OFF", 0)) * R;
    } else {
      known = Rotation(rot, &R);
    }
  }
  c["rotation"] = rot;
  c["rotation_known"] = known;
  c["rotation_matrix"] = {R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2)};
  return c;
}

}  // namespace hexsim::logs::internal
