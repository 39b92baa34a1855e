// Nuisance baseline findings and the timing scan of compass channels (private to gap/).
//
// Nuisance: the baseline fit r = β + M·R_NBᵀ·δB_N gives the residual offset β (sensor frame), the
// fitted Earth field B_fit = B_wmm + δB_N, its norm ratio field_scale = |B_fit|/|B_wmm| (a uniform
// sensor scale and a norm error look the same), and the part of δB_N across the WMM direction
// (an anomaly or a declination/inclination error). Judged against realdata's normal ranges, or, with
// nuisance_ranges = "exact" (a configured model that is the calibrated truth), by Wald tests.
// Timing: the current staleness S from a lag scan of current against throttle (the compass latency's
// scan is compass_timing.cc).
#include "nuisance.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <fmt/format.h>

#include "detection.h"
#include "hexsim/common/plausibility.h"
#include "hexsim/realdata/compass_flight.h"
#include "stats.h"

namespace hexsim::gap::internal {
namespace {

double WaldSub(const Eigen::VectorXd& b, const Eigen::MatrixXd& V, int G) {
  const int q = static_cast<int>(b.size());
  const double tr = V.trace();
  if (!(tr > 0)) return 1.0;
  const double t2 = b.dot((V + Eigen::MatrixXd::Identity(q, q) * 1e-9 * tr / q).ldlt().solve(b));
  if (G - q < 1) return ChiSquareSf(t2, q);
  return FSf(t2 * static_cast<double>(G - q) / (static_cast<double>(q) * (G - 1)), q, G - q);
}

CandidateResult Term(const std::string& effect, double value, double sd, double t975, const std::string& unit) {
  const bool norm = !Info(EffectFromName(effect)).signed_magnitude;
  CandidateResult r;
  r.effect = effect;
  r.id = EffectFromName(effect);
  r.magnitude = value;
  r.magnitude_ci95[0] = norm ? std::max(0.0, value - t975 * sd) : value - t975 * sd;
  r.magnitude_ci95[1] = value + t975 * sd;
  r.magnitude_unit = unit;
  r.plausible = plausibility::IsPlausible(effect, value);
  r.physical_range = plausibility::RangeText(effect);
  r.parameters = 3;
  r.probability = std::nan("");
  r.nuisance_term = true;
  return r;
}

// Exact ranges (the configured vehicle is the calibrated truth): a term is beyond its range when
// significant, each at alpha/3 (Bonferroni over the three); the most significant is the one named.
void JudgeExact(const Vec3& b, const Eigen::Matrix3d& Vb, const Vec3& d, const Eigen::Matrix3d& Vd, const Vec3& Bhat,
                double s_along, double s_sd, int G, double alpha, NuisanceReport* out) {
  NuisanceReport& nr = *out;
  const double p_off = WaldSub(b, Vb, G);
  Eigen::Matrix<double, 3, 2> E;
  E.col(0) = Bhat.unitOrthogonal();
  E.col(1) = Bhat.cross(E.col(0));
  const Eigen::Vector2d dp = E.transpose() * d;
  const double p_perp = WaldSub(dp, E.transpose() * Vd * E, G);
  const double p_scale = s_sd > 0 ? 2 * NormalSf(std::fabs(s_along) / s_sd) : 1.0;
  const double a = alpha / 3.0;  // Bonferroni over the three terms
  double p_best = a;
  if (p_off < a) nr.beyond_normal.emplace_back("hard_iron_offset");
  if (p_perp < a) nr.beyond_normal.emplace_back("local_anomaly");
  if (p_perp >= a && p_scale < a) nr.beyond_normal.emplace_back("field_scale");
  if (p_off < p_best) {
    p_best = p_off;
    nr.out_of_range = "hard_iron_offset";
  }
  if (p_perp < p_best) {
    p_best = p_perp;
    nr.out_of_range = "local_anomaly";
  }
  if (p_perp >= a && p_scale < p_best) nr.out_of_range = "field_scale";
}

}  // namespace

Interval JudgedInterval(double value, double sd_sandwich, double sd_jackknife, double t975) {
  const double half = t975 * std::max(sd_sandwich, sd_jackknife);
  return {value - half, value + half};
}

OffsetReading ReadOffset(double offset_uT, const Interval& judged) {
  if (!plausibility::IsPlausible("hard_iron_offset", offset_uT)) return OffsetReading::kImplausible;
  const plausibility::PhysicalRange* off = plausibility::FindRange("hard_iron_offset");
  return judged.lo > off->normal_hi ? OffsetReading::kBeyondNormal : OffsetReading::kNormal;
}

namespace {

// The baseline's terms read off its fit: the offset b, the field correction d, their covariances
// (sandwich V, jackknife J: the reported intervals'), and the scale and cross-field parts of d.
struct BaselineTerms {
  int G = 0;
  double t975 = 0;
  Vec3 b, d, B, Bhat;
  Eigen::Matrix3d Vb, Vd;
  double Bn = 0, scale = 1, s_along = 0, Bs2 = 0;
  double b_norm = 0, b_sd = 0, d_norm = 0, s_sd = 0, perp_norm = 0, perp_sd = 0;
  double b_ci_sd = 0, d_ci_sd = 0, s_ci_sd = 0;
};

BaselineTerms ReadBaseline(const ChannelData& ch, const Evaluated& base) {
  BaselineTerms t;
  t.G = static_cast<int>(base.blocks.size());
  t.t975 = StudentT975(static_cast<double>(t.G - 1));
  t.b = base.full.beta.head<3>();
  t.d = base.full.beta.segment<3>(3);
  t.Vb = base.cov.block<3, 3>(0, 0);
  t.Vd = base.cov.block<3, 3>(3, 3);
  // The reported intervals' (JackknifeCov); the range tests take the wider of it and the sandwich.
  const Eigen::MatrixXd Vjk = JackknifeCov(base);
  const Eigen::Matrix3d Jb = Vjk.block<3, 3>(0, 0), Jd = Vjk.block<3, 3>(3, 3);
  t.B = ch.field_N_uT;
  t.Bn = t.B.norm();
  t.Bhat = t.Bn > 0 ? Vec3(t.B / t.Bn) : Vec3::UnitZ();
  const Vec3 Bfit = t.B + t.d;
  t.scale = t.Bn > 0 ? Bfit.norm() / t.Bn : 1.0;
  // The sensor scale, read from the horizontal field: the correction along the WMM field's horizontal
  // part, as a scale. A flight stays nearly level, so the vertical field's column differs from a
  // body-z offset only by 1 − cos(tilt) and the tilts' sines, and any current-driven field the
  // replay mispredicts (the current grows as 1/cos(tilt) with the thrust) leaks into it; the
  // horizontal field turns with every change of heading. Near the magnetic poles (horizontal
  // field under kMinHorizontalShare of the norm) the projection on the whole field is used.
  constexpr double kMinHorizontalShare = 0.2;
  const Vec3 B_h(t.B.x(), t.B.y(), 0.0);
  const Vec3 B_s = B_h.norm() >= kMinHorizontalShare * t.Bn ? B_h : t.B;
  t.Bs2 = B_s.squaredNorm();
  t.s_along = t.Bs2 > 0 ? t.d.dot(B_s) / t.Bs2 : 0.0;
  const Vec3 d_perp = t.d - t.d.dot(t.Bhat) * t.Bhat;
  t.b_norm = t.b.norm();
  t.b_sd = t.b_norm > 0 ? std::sqrt(std::max(0.0, (t.b / t.b_norm).dot(t.Vb * (t.b / t.b_norm)))) : 0.0;
  t.d_norm = t.d.norm();
  t.s_sd = t.Bs2 > 0 ? std::sqrt(std::max(0.0, B_s.dot(t.Vd * B_s))) / t.Bs2 : 0.0;
  // The same along the reported directions, from the jackknife (the intervals).
  auto along = [](const Eigen::Matrix3d& V, const Vec3& u) { return std::sqrt(std::max(0.0, u.dot(V * u))); };
  t.b_ci_sd = t.b_norm > 0 ? along(Jb, t.b / t.b_norm) : 0.0;
  t.d_ci_sd = t.d_norm > 0 ? along(Jd, t.d / t.d_norm) : 0.0;
  t.s_ci_sd = t.Bs2 > 0 ? along(Jd, B_s) / t.Bs2 : 0.0;
  t.perp_norm = d_perp.norm();
  t.perp_sd =
      t.perp_norm > 0 ? std::sqrt(std::max(0.0, (d_perp / t.perp_norm).dot(t.Vd * (d_perp / t.perp_norm)))) : 0.0;
  return t;
}

// The nuisance block and the three terms (offset, field correction, field scale − 1) as reported.
void AddTerms(const ChannelData& ch, const BaselineTerms& t, const DiagnoseOptions& o, NuisanceReport* out) {
  NuisanceReport& nr = *out;
  Nuisance& nu = nr.nuisance;
  nu.present = true;
  nu.offset_uT = t.b;
  nu.offset_ci95_uT = {std::max(0.0, t.b_norm - t.t975 * t.b_ci_sd), t.b_norm + t.t975 * t.b_ci_sd};
  nu.field_scale = t.scale;
  nu.field_scale_horizontal = 1.0 + t.s_along;
  nu.field_vector_N_uT = t.B + t.d;
  nu.field_prior_N_uT = t.B;
  nu.field_correction_N_uT = t.d;
  nu.field_direction_error_uT = t.perp_norm;
  nu.undone_compensation = ch.undone_compensation;
  nu.ranges = o.nuisance_ranges;
  nr.terms.push_back(Term("hard_iron_offset", t.b_norm, t.b_ci_sd, t.t975, "uT"));
  nr.terms.back().params["b_x_uT"] = t.b.x();
  nr.terms.back().params["b_y_uT"] = t.b.y();
  nr.terms.back().params["b_z_uT"] = t.b.z();
  nr.terms.push_back(Term("local_anomaly", t.d_norm, t.d_ci_sd, t.t975, "uT"));
  nr.terms.back().params["anomaly_N_uT"] = t.d.x();
  nr.terms.back().params["anomaly_E_uT"] = t.d.y();
  nr.terms.back().params["anomaly_D_uT"] = t.d.z();
  nr.terms.push_back(Term("field_scale", t.s_along, t.s_ci_sd, t.t975, "1"));
  nr.terms.back().parameters = 1;
  // The term reports scale − 1; its physical range is the field_scale row's ratio range less one.
  const plausibility::PhysicalRange* fs = plausibility::FindRange("field_scale");
  nr.terms.back().plausible = 1.0 + t.s_along >= fs->lo && 1.0 + t.s_along <= fs->hi;
  nr.terms.back().physical_range = fmt::format("{:.2g}..{:.2g} 1 (field scale − 1)", fs->lo - 1.0, fs->hi - 1.0);
  nr.terms.back().params["scale_minus_1"] = t.s_along;
}

// Which term is out of its normal range (realdata's ranges). Each term is judged by JudgedInterval:
// beyond a range only where the interval it is printed with says so too.
void JudgeNormal(const ChannelData& ch, const BaselineTerms& t, NuisanceReport* out) {
  NuisanceReport& nr = *out;
  const plausibility::PhysicalRange* off = plausibility::FindRange("hard_iron_offset");
  const plausibility::PhysicalRange* an = plausibility::FindRange("local_anomaly");
  const plausibility::PhysicalRange* sc = plausibility::FindRange("field_scale");
  const OffsetReading offset = ReadOffset(t.b_norm, JudgedInterval(t.b_norm, t.b_sd, t.b_ci_sd, t.t975));
  if (offset == OffsetReading::kImplausible) {
    nr.offset_implausible = true;
    nr.findings.push_back(fmt::format("{}: residual offset ({:.0f}, {:.0f}, {:.0f}) mG, outside the physical range {}: "
                                      "implausible, model mismatch (too little rotation to separate an offset from "
                                      "the field, or the log's compass units)",
                                      ch.name, kMilliGaussPerMicroTesla * t.b.x(), kMilliGaussPerMicroTesla * t.b.y(),
                                      kMilliGaussPerMicroTesla * t.b.z(), plausibility::RangeText("hard_iron_offset")));
  } else if (offset == OffsetReading::kBeyondNormal) {
    nr.out_of_range = "hard_iron_offset";
    nr.beyond_normal.emplace_back("hard_iron_offset");
    nr.offset_finding = static_cast<int>(nr.findings.size());
    nr.findings.push_back(fmt::format("{}: residual offset ({:.0f}, {:.0f}, {:.0f}) mG, beyond the normal {:.0f} mG: "
                                      "recalibrate the compass",
                                      ch.name, kMilliGaussPerMicroTesla * t.b.x(), kMilliGaussPerMicroTesla * t.b.y(),
                                      kMilliGaussPerMicroTesla * t.b.z(), kMilliGaussPerMicroTesla * off->normal_hi));
  }
  // A field correction across the WMM direction beyond its normal range is an anomaly (or a
  // heading error), which a sensor scale cannot produce; the anomaly explains the norm change along
  // the field as well, so it is named before the scale (one cause for both parts).
  const bool anomaly_out = JudgedInterval(t.perp_norm, t.perp_sd, t.d_ci_sd, t.t975).lo > an->normal_hi;
  // The scale term (horizontal field) is judged by its interval, as the offset and the anomaly are:
  // a point beyond a range whose interval still reaches into it is not resolved beyond it.
  const double scale_h = 1.0 + t.s_along;
  const Interval scale_ci = JudgedInterval(scale_h, t.s_sd, t.s_ci_sd, t.t975);
  const double scale_lo = scale_ci.lo, scale_hi = scale_ci.hi;
  // The norm only inside its physical range (FieldScaleText's rule: in a nearly level flight the
  // vertical field trades with the z offset).
  const std::string norm_text = plausibility::IsPlausible("field_scale", t.scale)
                                    ? fmt::format("norm {:+.1f} %", 100 * (t.scale - 1))
                                    : std::string("norm not resolved");
  if (scale_hi < sc->lo || scale_lo > sc->hi) {
    // Beyond what a compass reads of the Earth field: never a finding to act on.
    // At or below zero the horizontal part points against the WMM field's: no percentage of it.
    const std::string size = scale_h > 0 ? fmt::format("fitted field {:.1f} % {} the WMM field (horizontal part; {})",
                                                       100 * std::fabs(t.s_along), t.s_along < 0 ? "below" : "above",
                                                       norm_text)
                                         : std::string("fitted horizontal field points against the WMM field's");
    nr.findings.push_back(fmt::format("{}: {}, outside the physical range {}: implausible, model mismatch (the field "
                                      "model's place or date, the heading of the attitude, or the log's compass units)",
                                      ch.name, size, plausibility::RangeText("field_scale")));
  } else if (scale_hi < sc->normal_lo || scale_lo > sc->normal_hi) {
    if (nr.out_of_range.empty() && !anomaly_out) nr.out_of_range = "field_scale";
    if (!anomaly_out) nr.beyond_normal.emplace_back("field_scale");
    nr.findings.push_back(fmt::format("{}: fitted field {:.1f} % {} the WMM field (horizontal part; {}): "
                                      "recalibrate (scale) or check for a local anomaly",
                                      ch.name, 100 * std::fabs(t.s_along), t.s_along < 0 ? "below" : "above",
                                      norm_text));
  }
  if (anomaly_out) {
    if (nr.out_of_range.empty()) nr.out_of_range = "local_anomaly";
    nr.beyond_normal.emplace_back("local_anomaly");
    nr.findings.push_back(fmt::format("{}: fitted field direction differs from WMM by {:.1f} uT ({:.1f} deg): a local "
                                      "anomaly, or a yaw misalignment of the compass",
                                      ch.name, t.perp_norm, std::atan2(t.perp_norm, t.Bn) * 57.29577951308232));
  }
}

}  // namespace

NuisanceReport DescribeNuisance(const ChannelData& ch, const Evaluated& base, const DiagnoseOptions& o) {
  NuisanceReport nr;
  if (base.p() < 6 || !base.full.ok) return nr;
  const BaselineTerms t = ReadBaseline(ch, base);
  AddTerms(ch, t, o, &nr);
  if (o.nuisance_ranges == "exact") {
    nr.offset_implausible = !plausibility::IsPlausible("hard_iron_offset", t.b_norm);
    JudgeExact(t.b, t.Vb, t.d, t.Vd, t.Bhat, t.s_along, t.s_sd, t.G, o.alpha, &nr);
  } else {
    JudgeNormal(ch, t, &nr);
  }
  return nr;
}

void RejudgeOffsetAtZeroCurrent(const ChannelData& ch, const Evaluated& joint, const DiagnoseOptions& o,
                                NuisanceReport* nr, std::vector<std::string>* findings) {
  auto& beyond = nr->beyond_normal;
  const auto it = std::find(beyond.begin(), beyond.end(), std::string("hard_iron_offset"));
  // The joint fit's first six columns are the baseline's (offset, field correction): read as the
  // baseline is, and judged by JudgeNormal's rule.
  if (o.nuisance_ranges != "normal" || it == beyond.end() || !joint.full.ok || joint.full.beta.size() < 6 ||
      joint.cov.rows() < 6 || joint.blocks.size() < 2) {
    return;
  }
  const BaselineTerms t = ReadBaseline(ch, joint);
  if (!(t.b_norm > 0)) return;
  if (ReadOffset(t.b_norm, JudgedInterval(t.b_norm, t.b_sd, t.b_ci_sd, t.t975)) != OffsetReading::kNormal) return;
  const Vec3& b = t.b;
  beyond.erase(it);
  if (nr->out_of_range == "hard_iron_offset") nr->out_of_range.clear();
  if (nr->offset_finding < 0 || static_cast<size_t>(nr->offset_finding) >= findings->size()) return;
  const auto base = std::find_if(nr->terms.begin(), nr->terms.end(),
                                 [](const CandidateResult& k) { return k.effect == "hard_iron_offset"; });
  if (base == nr->terms.end()) return;
  const plausibility::PhysicalRange* off = plausibility::FindRange("hard_iron_offset");
  (*findings)[static_cast<size_t>(nr->offset_finding)] = fmt::format(
      "{}: residual offset ({:.0f}, {:.0f}, {:.0f}) mG on the current-free baseline, ({:.0f}, {:.0f}, {:.0f}) mG at zero "
      "current with the current field fitted: within the normal {:.0f} mG; the excess was the flight's mean current "
      "field, which the current term compensates: no recalibration",
      ch.name, kMilliGaussPerMicroTesla * base->params.at("b_x_uT"), kMilliGaussPerMicroTesla * base->params.at("b_y_uT"),
      kMilliGaussPerMicroTesla * base->params.at("b_z_uT"), kMilliGaussPerMicroTesla * b.x(),
      kMilliGaussPerMicroTesla * b.y(), kMilliGaussPerMicroTesla * b.z(), kMilliGaussPerMicroTesla * off->normal_hi);
}

realdata::LagEstimate CurrentStaleness(const logs::FlightLog& log, const std::vector<realdata::RowKind>& kinds,
                                       const DiagnoseOptions& o) {
  realdata::StalenessOptions so;
  so.seed = o.seed;
  so.resamples = o.bootstrap_samples;
  return realdata::CurrentStaleness(log, kinds, so);
}

double FitShareExponent(const logs::FlightLog& log, const LogInputs& in, const vehicle::VehicleParams& v,
                        const std::vector<realdata::RowKind>& kinds, double shift_s) {
  if (!SplitsBatteryCurrent(in, v)) return std::nan("");
  const auto& t = log.Column("t_s");
  const std::vector<double>& I = *in.current;
  constexpr size_t kMinRows = 100;
  constexpr double kMinOutput = 0.05;  // a motor at (or near) zero output: spool-up, not the law
  std::vector<double> y;
  std::vector<std::vector<double>> logu;  // per row, log u_i
  size_t j = 0;
  for (size_t i = 0; i < log.rows() && i < kinds.size(); ++i) {
    if (kinds[i] != realdata::RowKind::kFlight) continue;
    const double ts = t[i] + shift_s;
    while (j + 1 < t.size() && t[j + 1] <= ts) ++j;
    if (j + 1 >= t.size() || t[j] > ts) continue;
    const double w = t[j + 1] > t[j] ? (ts - t[j]) / (t[j + 1] - t[j]) : 0.0;
    const double Ii = (1 - w) * I[j] + w * I[j + 1] - v.avionics_current_A;
    if (!std::isfinite(Ii)) continue;
    std::vector<double> lu;
    for (const auto* u : in.motor_u) {
      const double ui = (*u)[i];
      if (!(ui >= kMinOutput && ui <= 1.0)) break;
      lu.push_back(std::log(ui));
    }
    if (lu.size() != in.motor_u.size()) continue;
    y.push_back(Ii);
    logu.push_back(std::move(lu));
  }
  if (y.size() < kMinRows) return std::nan("");
  // The motors must draw a current that varies: a log without a power monitor (0 A) has none.
  double yy = 0, ysum = 0;
  for (double yi : y) {
    yy += yi * yi;
    ysum += yi;
  }
  const double ymean = ysum / static_cast<double>(y.size());
  if (!(ymean > 0) || !(yy - ysum * ymean > 1e-12 * yy)) return std::nan("");
  // Profile over p: c = Σxy/Σxx in closed form at each p.
  constexpr double kStep = 0.05;
  double best_p = kShareExponent, best_sse = std::numeric_limits<double>::infinity();
  const int steps = static_cast<int>(std::lround((kShareExponentHi - kShareExponentLo) / kStep));
  for (int g = 0; g <= steps; ++g) {
    const double p = kShareExponentLo + kStep * g;
    double xy = 0, xx = 0;
    for (size_t k = 0; k < y.size(); ++k) {
      double x = 0;
      for (double lu : logu[k]) x += std::exp(p * lu);
      xy += x * y[k];
      xx += x * x;
    }
    if (!(xx > 0)) continue;
    const double sse = yy - xy * xy / xx;
    if (sse < best_sse) {
      best_sse = sse;
      best_p = p;
    }
  }
  return best_p;
}

void DescaleMisalignment(double field_scale, CandidateResult* r) {
  if (r->id != Effect::kMisalignment || !(field_scale > 0) || !std::isfinite(field_scale)) return;
  r->magnitude /= field_scale;
  r->magnitude_ci95[0] /= field_scale;
  r->magnitude_ci95[1] /= field_scale;
  for (auto& [name, v] : r->params) v /= field_scale;
  for (auto& [name, ci] : r->ci95) ci = {ci.lo / field_scale, ci.hi / field_scale};
}

GroundVsFlight CompareGroundFlight(const ChannelData& flight, const ChannelData& ground, const Nuisance& nuisance) {
  GroundVsFlight j;
  constexpr size_t kMinSamples = 20;
  constexpr double kMinCurrentStep_A = 1.0;  // below this the ratio is noise
  if (ground.t.size() < kMinSamples || flight.t.size() < kMinSamples || !nuisance.present) return j;
  Eigen::VectorXd beta(6);
  beta << nuisance.offset_uT, nuisance.field_correction_N_uT;
  auto mean_residual = [&](const ChannelData& ch, double* mean_I) {
    Vec3 m = Vec3::Zero();
    double I = 0;
    for (size_t k = 0; k < ch.t.size(); ++k) {
      m += ch.y[k] - ch.baseline.X[k] * beta;
      I += ch.current_A[k];
    }
    *mean_I = I / static_cast<double>(ch.t.size());
    return Vec3(m / static_cast<double>(ch.t.size()));
  };
  double I_f = 0, I_g = 0;
  const Vec3 r_f = mean_residual(flight, &I_f);
  const Vec3 r_g = mean_residual(ground, &I_g);
  const Vec3 dB = r_f - r_g;
  const double dI = I_f - I_g;
  j.present = true;
  j.ground_samples = static_cast<int>(ground.t.size());
  j.delta_B_uT = dB;
  j.delta_I_A = dI;
  if (std::fabs(dI) >= kMinCurrentStep_A) j.mG_per_A = kMilliGaussPerMicroTesla * dB.norm() / std::fabs(dI);
  return j;
}

}  // namespace hexsim::gap::internal
