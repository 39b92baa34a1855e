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

std::string ArduPilotParmText(const ParamList& params, const std::string& source, const std::vector<std::string>& comments) {
  std::string out = "# " + source + ": ArduPilot compass parameters (NAME VALUE; offsets in mG, absolute)\n";
  for (const auto& c : comments) out += "# " + c + "\n";
  for (const auto& [name, value] : params) out += Format("%s %.7g\n", name.c_str(), value);
  return out;
}

std::string Px4ParamsText(const ParamList& params, const std::string& source, const std::vector<std::string>& comments) {
  std::string out = "# " + source +
                    ": PX4 compass parameters (QGroundControl: sysid compid name value type; offsets in gauss)\n";
  for (const auto& c : comments) out += "# " + c + "\n";
  out += "# Vehicle-Id\tComponent-Id\tName\tValue\tType\n";
  for (const auto& [name, value] : params) out += Format("1\t1\t%s\t%.9g\t9\n", name.c_str(), value);
  return out;
}

MotorParams CompensationParams(int compass_index, int px4_index, bool fitted, bool usable, bool form_throttle,
                               const Vector3d& d_uT, const Vector3d& d_ci_half_uT, const Matrix3d& body_from_raw_inv,
                               const MotorCompensationInLog& log, int px4_comp_type, const Vector3d& px4_comp_G,
                               const std::string& no_flight) {
  MotorParams m;
  if (!no_flight.empty()) fitted = usable = false;  // a fit that saw no flight neither writes nor zeroes
  const std::string n = ApSuffix(compass_index);
  const std::string mot = "COMPASS_MOT" + n + "_";
  const int motct = form_throttle ? 1 : 2;  // ArduPilot: 1 throttle, 2 current
  const char* unit = form_throttle ? "mG per unit throttle" : "mG/A";
  const std::string had =
      log.motct < 0 ? "the log does not say its COMPASS_MOTCT"
                    : Format("the log had COMPASS_MOTCT %d, %sX/Y/Z %.1f %.1f %.1f", log.motct, mot.c_str(), log.mot(0),
                             log.mot(1), log.mot(2));
  auto write_mot = [&](int ct, const Vector3d& v) {
    m.ardupilot.emplace_back("COMPASS_MOTCT", ct);
    for (int k = 0; k < 3; ++k) m.ardupilot.emplace_back(mot + static_cast<char>('X' + k), v(k));
  };
  if (usable) {
    const Vector3d mot_mG = -kMilligaussPerMicrotesla * d_uT;  // corrected = M(raw + OFS) + MOT·r
    write_mot(motct, mot_mG);
    m.action = log.motct > 0 ? "replaced" : "written";
    m.comment = Format("COMPASS_MOTCT/%s*: %s by the fitted %s field (%s)", mot.c_str(), m.action.c_str(),
                       form_throttle ? "throttle" : "current", had.c_str());
    // PX4: S·((u + P·comp) − off), P = I/1000 (kA; comp in G/kA) or the throttle (comp in G).
    const int typ = form_throttle ? 1 : 2;
    const double g_per = form_throttle ? kGaussPerMicrotesla : 1e3 * kGaussPerMicrotesla;
    const Vector3d comp = (px4_comp_type == typ ? px4_comp_G : Vector3d::Zero()) - g_per * body_from_raw_inv * d_uT;
    if (px4_comp_type > 0 && px4_comp_type != typ) return m;  // another form in force: not touched
    const int pi = px4_index >= 0 ? px4_index : compass_index;
    m.px4.emplace_back("CAL_MAG_COMP_TYP", typ);
    for (int k = 0; k < 3; ++k) m.px4.emplace_back(Format("CAL_MAG%d_%cCOMP", pi, static_cast<char>('X' + k)), comp(k));
    return m;
  }
  if (log.motct <= 0 || log.mot.isZero()) {
    m.action = "none";
    m.comment = no_flight.empty()
                    ? Format("COMPASS_MOTCT/%s*: not written, no resolved and plausible field (%s)", mot.c_str(), had.c_str())
                    : Format("COMPASS_MOTCT/%s*: not written: the fit saw no flight, %s (%s)", mot.c_str(), no_flight.c_str(),
                             had.c_str());
    return m;
  }
  // The fit saw the field with the log's compensation undone: the log's value as a d is −MOT/10.
  const Vector3d log_d = -log.mot / kMilligaussPerMicrotesla;
  const bool same_form = log.motct == motct;
  const bool log_inside = fitted && same_form && ((d_uT - log_d).array().abs() <= d_ci_half_uT.array()).all();
  const bool zero_inside = fitted && (d_uT.array().abs() <= d_ci_half_uT.array()).all();
  if (fitted && same_form && !log_inside && zero_inside) {
    write_mot(log.motct, Vector3d::Zero());
    m.action = "zeroed";
    m.comment = Format("COMPASS_MOTCT/%s*: zeroed: the fitted field is zero within its interval and the log's %s is "
                       "outside it (%s)", mot.c_str(), unit, had.c_str());
  } else {
    write_mot(log.motct, log.mot);
    m.action = "kept";
    m.comment = Format("COMPASS_MOTCT/%s*: kept as the log had them: the fit %s (%s)", mot.c_str(),
                       !no_flight.empty() ? ("saw no flight, " + no_flight).c_str()
                       : !fitted          ? "has no such term"
                       : !same_form       ? "is in the other form"
                                          : "cannot tell them apart",
                       had.c_str());
  }
  return m;
}

}  // namespace hexsim::magnetics
