#include "hexsim/magnetics/autopilot_params.h"

#include <cmath>

#include <Eigen/LU>

#include "hexsim/common/format.h"

namespace hexsim::magnetics {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

constexpr double kMilligaussPerMicrotesla = 10.0;  // 1 µT = 10 mG
constexpr double kGaussPerMicrotesla = 0.01;       // 1 G = 100 µT

Matrix3d UnitShape(const Matrix3d& A) {
  const double d = A.determinant();
  return d > 0.0 ? Matrix3d(A / std::cbrt(d)) : A;
}

std::string ApSuffix(int k) { return k == 0 ? "" : std::to_string(k + 1); }

double Get(const ParamList& p, const std::string& name, double fallback) {
  for (const auto& kv : p) {
    if (kv.first == name) return kv.second;
  }
  return fallback;
}

Matrix3d SymFrom(double dx, double dy, double dz, double oxy, double oxz, double oyz) {
  Matrix3d M;
  M << dx, oxy, oxz, oxy, dy, oyz, oxz, oyz, dz;
  return M;
}

}  // namespace

ParamList ArduPilotCompassParams(const Vector3d& offset_uT, const Matrix3d& A, int compass_index) {
  const std::string n = ApSuffix(compass_index);
  const Matrix3d M = UnitShape(A);
  const Vector3d ofs = -offset_uT * kMilligaussPerMicrotesla;
  return {{"COMPASS_OFS" + n + "_X", ofs(0)}, {"COMPASS_OFS" + n + "_Y", ofs(1)}, {"COMPASS_OFS" + n + "_Z", ofs(2)},
          {"COMPASS_DIA" + n + "_X", M(0, 0)}, {"COMPASS_DIA" + n + "_Y", M(1, 1)}, {"COMPASS_DIA" + n + "_Z", M(2, 2)},
          {"COMPASS_ODI" + n + "_X", M(0, 1)}, {"COMPASS_ODI" + n + "_Y", M(0, 2)}, {"COMPASS_ODI" + n + "_Z", M(1, 2)}};
}

ParamList Px4CompassParams(const Vector3d& offset_uT, const Matrix3d& A, int compass_index) {
  const std::string n = "CAL_MAG" + std::to_string(compass_index) + "_";
  const Matrix3d S = UnitShape(A);
  const Vector3d off = offset_uT * kGaussPerMicrotesla;
  return {{n + "XOFF", off(0)},     {n + "YOFF", off(1)},     {n + "ZOFF", off(2)},
          {n + "XSCALE", S(0, 0)},  {n + "YSCALE", S(1, 1)},  {n + "ZSCALE", S(2, 2)},
          {n + "XODIAG", S(0, 1)},  {n + "YODIAG", S(0, 2)},  {n + "ZODIAG", S(1, 2)}};
}

Vector3d ApplyArduPilotCompass(const ParamList& params, int compass_index, const Vector3d& raw_mG) {
  const ParamList& p = params;
  const std::string n = ApSuffix(compass_index);
  auto g = [&](const std::string& base, const char* axis, double fb) { return Get(p, "COMPASS_" + base + n + "_" + axis, fb); };
  const Vector3d ofs(g("OFS", "X", 0.0), g("OFS", "Y", 0.0), g("OFS", "Z", 0.0));
  const Matrix3d M = SymFrom(g("DIA", "X", 1.0), g("DIA", "Y", 1.0), g("DIA", "Z", 1.0), g("ODI", "X", 0.0),
                             g("ODI", "Y", 0.0), g("ODI", "Z", 0.0));
  return M * (raw_mG + ofs);
}

Vector3d ApplyPx4Compass(const ParamList& params, int compass_index, const Vector3d& raw_G) {
  const ParamList& p = params;
  const std::string n = "CAL_MAG" + std::to_string(compass_index) + "_";
  auto g = [&](const char* name, double fb) { return Get(p, n + name, fb); };
  const Vector3d off(g("XOFF", 0.0), g("YOFF", 0.0), g("ZOFF", 0.0));
  const Matrix3d S = SymFrom(g("XSCALE", 1.0), g("YSCALE", 1.0), g("ZSCALE", 1.0), g("XODIAG", 0.0), g("YODIAG", 0.0),
                             g("ZODIAG", 0.0));
  return S * (raw_G - off);
}

std::string ArduPilotParmText(const ParamList& params) {
  std::string out = "# hexsim calibrate: ArduPilot compass parameters (NAME VALUE; offsets in mG, absolute)\n";
  for (const auto& [name, value] : params) out += Format("%s %.7g\n", name.c_str(), value);
  return out;
}

std::string Px4ParamsText(const ParamList& params) {
  std::string out =
      "# hexsim calibrate: PX4 compass parameters (QGroundControl: sysid compid name value type; offsets in gauss)\n"
      "# Vehicle-Id\tComponent-Id\tName\tValue\tType\n";
  for (const auto& [name, value] : params) out += Format("1\t1\t%s\t%.9g\t9\n", name.c_str(), value);
  return out;
}

}  // namespace hexsim::magnetics
