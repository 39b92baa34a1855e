#include "hexsim/magnetics/calibrate.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <Eigen/LU>
#include <fmt/format.h>

#include "calibrate_internal.h"
#include "hexsim/magnetics/calib_io.h"
#include "hexsim/magnetics/compensators.h"

namespace hexsim::magnetics {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

using internal::Vec;
nlohmann::json Mat(const Matrix3d& m) {
  return nlohmann::json::array({Vec(m.row(0).transpose()), Vec(m.row(1).transpose()), Vec(m.row(2).transpose())});
}
nlohmann::json Params(const ParamList& p) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [k, v] : p) j[k] = v;
  return j;
}

bool IsFieldMethod(const std::string& m) {
  const auto names = FieldMethodNames();
  return std::find(names.begin(), names.end(), m) != names.end();
}

// The free-hand path: one fit of field_calibration.h, written as an ellipsoid compensator.
Result<CalibrateOutcome> FieldPath(CalibrateOutcome out, const std::string& method, const CalibrateRequest& rq) {
  FieldCalibrationOptions fo = rq.field;
  fo.method = method;
  fo.field_norm_uT = rq.field_norm_uT;
  fo.prior_offset_uT = rq.prior_offset * out.units.to_uT;
  auto fc = CalibrateField(out.raw_uT, fo);
  if (!fc.ok()) return fc.status();
  out.field = std::move(*fc);
  const FieldCalibration& f = out.field;
  out.compensator = std::make_unique<EllipsoidCompensator>(f.method_used, f.A.inverse(), f.offset_uT);
  nlohmann::json& r = out.report;
  r["accepted"] = f.accepted;
  r["gate"] = f.method_used == "none" ? nlohmann::json{{"accepted", true}, {"criteria", nlohmann::json::array()}, {"failures", ""}}
                                      : GateToJson(f.fit.gate);
  r["fits"] = f.method_used == "none" ? nlohmann::json::array() : nlohmann::json::array({EllipsoidFitToJson(f.fit)});
  r["diagnostics"] = nlohmann::json::object();
  if (!f.method_used.empty() && f.method_used != "none") {
    r["coverage"] = {{"fraction", f.fit.coverage_fraction}, {"planes", 0}};
  }
  if (f.OffsetAxisUndetermined()) {
    const Vector3d& n = f.undetermined_axis;
    out.param_comments.push_back(fmt::format(
        "flat spin: the offset along the spin axis (body {:+.3f} {:+.3f} {:+.3f}) is UNDETERMINED; these offsets carry "
        "{:.2f} uT there, not a measured value: calibrate with the vehicle tilted too before flying",
        n(0), n(1), n(2), n.dot(f.offset_uT)));
  }
  out.exit_code = f.accepted ? 0 : 1;
  return out;
}

// The turntable path: LearnCompensator, then the ground fit's offset and soft iron as A and b.
Result<CalibrateOutcome> TurntablePath(CalibrateOutcome out, const std::vector<MagSample>& s, const std::string& method,
                                       const CalibrateRequest& rq) {
  LearnReport report;
  auto comp = LearnCompensator(method, s, rq.learn, &report);
  if (!comp.ok()) return comp.status();
  const nlohmann::json learnt = LearnReportToJson(report, **comp);
  out.compensator = std::move(*comp);
  FieldCalibration& f = out.field;
  f.method_used = method;
  f.why = method == rq.method ? "requested" : "turntable samples (3 or more planes, 2 or more control amounts): the paper's adaptive method";
  f.coverage = internal::CoverageAboutMedianNorm(out.raw_uT);
  f.norm_spread_before = NormSpread(out.raw_uT);
  std::vector<Vector3d> after;
  after.reserve(s.size());
  for (const auto& x : s) after.push_back(out.compensator->Correct(x.mag_B_uT, {x.control_u, x.current_A}));
  f.norm_spread_after = NormSpread(after);
  f.accepted = learnt.value("accepted", true);
  const auto& fits = learnt["fits"];
  if (!fits.empty() && fits[0].value("ok", false)) {
    for (int i = 0; i < 3; ++i) {
      f.offset_uT(i) = fits[0]["hard_iron_uT"][i].get<double>();
      for (int j = 0; j < 3; ++j) f.K(i, j) = fits[0]["soft_iron"][i][j].get<double>();
    }
    f.radius_uT = fits[0]["radius_uT"].get<double>();
    f.fitness_uT = fits[0]["rms_residual_uT"].get<double>();
    const double target = rq.field_norm_uT > 0.0 ? rq.field_norm_uT : f.radius_uT;
    f.A = f.K.inverse() * (target / f.radius_uT);
  }
  if (!f.accepted) f.warnings.push_back("acceptance gate: " + learnt["gate"].value("failures", std::string()));
  const nlohmann::json keep = out.report;
  out.report = learnt;
  for (const auto& [k, v] : keep.items()) out.report[k] = v;
  out.exit_code = f.accepted ? 0 : 1;
  return out;
}

// The methods learnt on the ground (traditional, adaptive, adaptive-current, compassmot, px4-ls) fit
// the field at fixed control amounts: they need turntable samples (a plane label per sample, as
// `hexsim turntable` writes) or a compassmot sweep (the vehicle held still while the throttle and the
// current vary: two or more control amounts, no attitude track). A flight log is neither.
Status CheckGroundSamples(const std::vector<MagSample>& s, const std::string& method, const CalibrateRequest& rq) {
  std::set<double> controls;
  for (const auto& x : s) {
    if (!x.plane.empty()) return Status::Ok();
    if (std::isfinite(x.control_u)) controls.insert(x.control_u);
  }
  if (!rq.flight.has_attitude && controls.size() >= 2) return Status::Ok();
  return Status::BadInput(fmt::format(
      "--method {}: needs turntable samples (hexsim turntable's samples.csv: plane, control_u, angle_deg) or a "
      "compassmot sweep (control_u and current_A at two or more throttles, vehicle held still); {}",
      method,
      rq.flight.has_attitude ? "this is a flight log: use --method flight (or auto)"
                             : "these are plain field samples: use --method auto, sphere, ellipsoid or robust"));
}

// The local field's norm, when given: the Earth's main field is 22-67 uT at the surface (WMM), so a
// value outside 20-70 uT is a mistake (mG or G for uT, a sign), not a place.
constexpr double kFieldNormMin_uT = 20.0;
constexpr double kFieldNormMax_uT = 70.0;

}  // namespace

bool HasTurntableColumns(const std::vector<MagSample>& s) {
  std::set<std::string> planes;
  std::set<double> controls;
  for (const auto& x : s) {
    if (!x.plane.empty()) planes.insert(x.plane);
    controls.insert(x.control_u);
  }
  return planes.size() >= 3 && controls.size() >= 2;
}

Result<CalibrateOutcome> Calibrate(std::vector<MagSample> samples, const CalibrateRequest& rq) {
  const auto learn_names = CompensatorNames();
  const bool turntable_method =
      std::find(learn_names.begin(), learn_names.end(), rq.method) != learn_names.end() && rq.method != "none";
  if (!IsFieldMethod(rq.method) && !turntable_method && rq.method != "flight") {
    std::string all;
    for (const auto& n : FieldMethodNames()) all += n + ", ";
    for (const auto& n : learn_names) {
      if (n != "none") all += n + ", ";
    }
    all += "flight";
    return Status::BadInput(fmt::format("--method: unknown method '{}' (one of: {})", rq.method, all));
  }
  if (samples.empty()) return Status::BadInput("no samples");
  if (rq.field_norm_uT != 0.0 && !(rq.field_norm_uT >= kFieldNormMin_uT && rq.field_norm_uT <= kFieldNormMax_uT)) {
    return Status::BadInput(fmt::format("--field-norm: {} uT is outside the Earth's field, {}..{} uT (hexsim field "
                                        "LAT LON ALT DATE gives the local value)",
                                        rq.field_norm_uT, kFieldNormMin_uT, kFieldNormMax_uT));
  }
  CalibrateOutcome out;
  for (const auto& s : samples) out.raw_uT.push_back(s.mag_B_uT);
  auto units = DetectUnits(out.raw_uT, rq.units, rq.field_norm_uT);
  if (!units.ok()) return units.status();
  out.units = *units;
  for (auto& b : out.raw_uT) b *= out.units.to_uT;
  for (size_t i = 0; i < samples.size(); ++i) samples[i].mag_B_uT = out.raw_uT[i];
  std::string method = rq.method;
  if (method == "auto" && HasTurntableColumns(samples)) method = "adaptive";
  if (method == "auto" && UsesFlightPath(samples, rq)) method = "flight";
  if (method != "flight" && !IsFieldMethod(method)) HEXSIM_RETURN_IF_ERROR(CheckGroundSamples(samples, method, rq));
  out.report = nlohmann::json::object();
  Result<CalibrateOutcome> done = method == "flight"      ? FlightPath(std::move(out), samples, rq)
                                  : IsFieldMethod(method) ? FieldPath(std::move(out), method, rq)
                                                          : TurntablePath(std::move(out), samples, method, rq);
  if (!done.ok()) return done.status();
  CalibrateOutcome& o = *done;
  const FieldCalibration& f = o.field;
  const Matrix3d params_A = o.params_keep_soft_iron ? o.params_A : f.A;
  o.ardupilot = ArduPilotCompassParams(f.offset_uT, params_A, rq.compass_index);
  o.px4 = Px4CompassParams(f.offset_uT, params_A, rq.px4_index >= 0 ? rq.px4_index : rq.compass_index);
  o.ardupilot.insert(o.ardupilot.end(), o.ardupilot_extra.begin(), o.ardupilot_extra.end());
  o.px4.insert(o.px4.end(), o.px4_extra.begin(), o.px4_extra.end());
  nlohmann::json& r = o.report;
  r["schema"] = "hexsim.calib/1";
  r["method"] = rq.method;
  r["method_used"] = f.method_used;
  r["why"] = f.why;
  r["units_assumed"] = o.units.unit;
  r["units_note"] = o.units.assumption;
  r["offset_uT"] = Vec(f.offset_uT);
  // A flat spin: the offset along the spin axis is not measured (the parameters carry the prior's).
  r["offset_undetermined_along"] = f.OffsetAxisUndetermined() ? Vec(f.undetermined_axis) : nlohmann::json(nullptr);
  r["A"] = Mat(f.A);
  r["K"] = Mat(f.K);
  r["radius_uT"] = f.radius_uT;
  r["fitness_uT"] = f.fitness_uT;
  r["rms_residual_uT"] = f.fitness_uT;
  r["norm_spread_before"] = f.norm_spread_before;
  r["norm_spread_after"] = f.norm_spread_after;
  r["coverage_eigenvalues"] = Vec(f.coverage.eigenvalues);
  if (!r.contains("coverage") || r["coverage"].is_null()) r["coverage"] = {{"fraction", nullptr}, {"planes", 0}};
  r["coverage"]["eigenvalues"] = Vec(f.coverage.eigenvalues);
  r["coverage"]["weak_axis"] = f.coverage.weak_axis;
  r["coverage"]["missing_rotation"] = f.coverage.eigenvalues(0) < rq.field.ellipsoid_eigen ? f.coverage.missing_rotation : "";
  r["warnings"] = f.warnings;
  nlohmann::json dw = nlohmann::json::array();
  for (size_t i = 0; i < f.downweighted.size() && i < 200; ++i) dw.push_back(f.downweighted[i]);
  r["downweighted"] = {{"count", f.downweighted.size()}, {"samples", dw}, {"indexing", "0-based, in input order, first 200"}};
  r["ardupilot_params"] = Params(o.ardupilot);
  r["px4_params"] = Params(o.px4);
  r["params"] = YamlToJson(CompensatorToYaml(*o.compensator));
  r["num_samples"] = o.raw_uT.size();
  return done;
}

}  // namespace hexsim::magnetics
