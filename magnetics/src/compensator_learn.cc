// LearnCompensator: turntable samples → a compensator and its hexsim.calib/1 report.
#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <Eigen/LU>

#include "hexsim/common/format.h"
#include "hexsim/magnetics/compensator.h"
#include "hexsim/magnetics/compensators.h"

namespace hexsim::magnetics {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Indices = std::vector<size_t>;

// One ellipsoid fit over a group of samples, with its context for the report.
using GroupFit = LearnedFit;

Status ValidateSamples(const std::vector<MagSample>& s) {
  if (s.empty()) return Status::BadInput("no samples");
  for (size_t i = 0; i < s.size(); ++i) {
    if (!s[i].mag_B_uT.allFinite() || !std::isfinite(s[i].control_u) || !std::isfinite(s[i].current_A) ||
        !std::isfinite(s[i].angle_deg)) {
      return Status::BadInput(Format("sample %zu: non-finite field, control, current or angle", i));
    }
  }
  return Status::Ok();
}

// Samples grouped by control amount (ascending).
std::map<double, Indices> GroupByControl(const std::vector<MagSample>& s) {
  std::map<double, Indices> g;
  for (size_t i = 0; i < s.size(); ++i) g[s[i].control_u].push_back(i);
  return g;
}

Result<GroupFit> FitGroup(const std::vector<MagSample>& s, const Indices& idx, const LearnOptions& o) {
  GroupFit g;
  g.control_u = s[idx.front()].control_u;
  const std::string where = "control_u " + ShortestDouble(g.control_u);
  if (static_cast<int>(idx.size()) < o.min_samples_per_fit) {
    return Status::BadInput(Format("%s: too few samples: %zu (need at least %d)", where.c_str(), idx.size(), o.min_samples_per_fit));
  }
  std::set<std::string> planes;
  bool labelled = false;
  std::vector<Vector3d> H;
  double sum_I = 0.0;
  for (size_t i : idx) {
    H.push_back(s[i].mag_B_uT);
    sum_I += s[i].current_A;
    if (!s[i].plane.empty()) {
      labelled = true;
      planes.insert(s[i].plane);
    }
  }
  g.mean_current_A = sum_I / static_cast<double>(idx.size());
  g.planes = static_cast<int>(planes.size());
  if (labelled && g.planes < o.min_planes) {
    return Status::BadInput(Format("%s: samples from %d plane(s) only (%s): rotate the vehicle in at least %d of xy, yz, xz", where.c_str(),
                                   g.planes, Join({planes.begin(), planes.end()}, ",").c_str(), o.min_planes));
  }
  EllipsoidFitOptions eo = o.ellipsoid;
  eo.planes_present = g.planes;
  g.fit = FitEllipsoid(H, eo);
  if (!g.fit.status.ok()) return g.fit.status.WithContext(where);
  return g;
}

Result<GroupFit> FitGround(const std::vector<MagSample>& s, const LearnOptions& o) {
  Indices zero;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i].control_u <= o.control_zero_max_u) zero.push_back(i);
  }
  if (zero.empty()) {
    return Status::BadInput("no ground samples at control 0 (control_u <= " + ShortestDouble(o.control_zero_max_u) + ")");
  }
  return FitGroup(s, zero, o);
}

Status NeedControlAmounts(const std::string& method, size_t n, const LearnOptions& o) {
  if (static_cast<int>(n) < o.min_control_amounts) {
    return Status::BadInput(Format("%s needs samples at %d or more control amounts, got %zu", method.c_str(),
                                   o.min_control_amounts, n));
  }
  return Status::Ok();
}

double WrapDeg360(double a) {
  double w = std::fmod(a, 360.0);
  return w < 0.0 ? w + 360.0 : w;
}

double AngleDiffDeg(double a, double b) {
  const double d = std::abs(WrapDeg360(a) - WrapDeg360(b));
  return std::min(d, 360.0 - d);
}

struct Learnt {
  std::unique_ptr<Compensator> comp;
  std::vector<GroupFit> fits;  // fits[0] is the ground (or lowest-control) fit
  LearnDiagnostics diagnostics;
};

Result<Learnt> LearnTraditional(const std::vector<MagSample>& s, const LearnOptions& o) {
  auto ground = FitGround(s, o);
  if (!ground.ok()) return ground.status();
  Learnt l;
  l.comp = std::make_unique<EllipsoidCompensator>("traditional", ground->fit.soft_iron, ground->fit.hard_iron_uT);
  l.fits.push_back(std::move(ground.value()));
  return l;
}

Result<Learnt> LearnLine(const std::string& method, const std::vector<MagSample>& s, const LearnOptions& o) {
  const auto groups = GroupByControl(s);
  HEXSIM_RETURN_IF_ERROR(NeedControlAmounts(method, groups.size(), o));
  Learnt l;
  std::vector<Vector3d> centres;
  for (const auto& [u, idx] : groups) {
    auto g = FitGroup(s, idx, o);
    if (!g.ok()) return g.status();
    centres.push_back(g->fit.hard_iron_uT);
    l.fits.push_back(std::move(g.value()));
  }
  const bool by_current = method == "adaptive-current";
  // The line: direction-vector TLS; the paper's form only when asked (and then checked against it).
  const SvdLineFit svd = FitLineSvd(centres);
  HEXSIM_RETURN_IF_ERROR(svd.status.WithContext("hard-iron line"));
  SpaceLine line = svd.line;
  l.diagnostics.line_svd_rms_residual_uT = svd.rms_residual_uT;
  if (o.line_form == LineForm::kPaper) {
    const PaperLineFit paper = FitLinePaperTls(centres, o.line);
    HEXSIM_RETURN_IF_ERROR(paper.status.WithContext("hard-iron line (paper form)"));
    line = paper.line;
    const double cosang = std::min(1.0, std::abs(paper.line.direction.dot(svd.line.direction)));
    l.diagnostics.line_paper = PaperLineSummary{paper.a,         paper.b_uT,         paper.c,
                                                paper.d_uT,      paper.iterations,   paper.rms_residual_uT,
                                                std::acos(cosang) * 180.0 / 3.14159265358979323846};
  }
  std::vector<double> x, pos;
  for (size_t i = 0; i < centres.size(); ++i) {
    x.push_back(by_current ? l.fits[i].mean_current_A : l.fits[i].control_u);
    pos.push_back(line.PositionOf(centres[i]));
  }
  if (by_current) {
    const auto [lo, hi] = std::minmax_element(x.begin(), x.end());
    if (*hi - *lo < o.min_current_span_A) {
      return Status::BadInput(Format("adaptive-current: the mean current varies by %.3g A across control amounts (need >= %s A)",
                                     *hi - *lo, ShortestDouble(o.min_current_span_A).c_str()));
    }
  }
  // Position along the line: linear in current; monotone (PCHIP) or linear in control amount.
  const AlongFit along = (by_current || o.along_control == AlongKind::kLinear) ? FitLinearAlong(x, pos) : FitMonotoneAlong(x, pos);
  HEXSIM_RETURN_IF_ERROR(along.status);
  l.diagnostics.along_rms_residual_uT = along.rms_residual_uT;
  l.diagnostics.along_index = by_current ? "current_A" : "control_u";
  l.diagnostics.along_model = along.model.kind == AlongKind::kLinear ? "linear" : "monotone";
  // Soft iron from the ground (lowest control amount) fit.
  l.comp = std::make_unique<LineCompensator>(method, l.fits.front().fit.soft_iron, HardIronLine{line, along.model},
                                             by_current ? LineIndex::kCurrent : LineIndex::kControl);
  return l;
}

Result<Learnt> LearnCurrentSlope(const std::string& method, const std::vector<MagSample>& s, const LearnOptions& o) {
  HEXSIM_RETURN_IF_ERROR(NeedControlAmounts(method, GroupByControl(s).size(), o));
  auto ground = FitGround(s, o);
  if (!ground.ok()) return ground.status();
  const EllipsoidFit& gf = ground->fit;
  const double I0 = ground->mean_current_A;
  Vector3d c = Vector3d::Zero();
  double sum_dI2 = 0.0, max_dI = 0.0;
  int pairs = 0;
  Learnt l;
  if (method == "compassmot") {
    // Matched pairs (same plane, same table angle): K⁻¹(H(I) − H(0)) = c·(I − I_0,pair).
    std::vector<size_t> zero;
    for (size_t i = 0; i < s.size(); ++i) {
      if (s[i].control_u <= o.control_zero_max_u) zero.push_back(i);
    }
    Vector3d sum = Vector3d::Zero();
    std::vector<std::pair<double, Vector3d>> dd;
    for (size_t i = 0; i < s.size(); ++i) {
      if (s[i].control_u <= o.control_zero_max_u) continue;
      for (size_t j : zero) {
        if (s[j].plane != s[i].plane || AngleDiffDeg(s[j].angle_deg, s[i].angle_deg) > o.angle_match_deg) continue;
        const double dI = s[i].current_A - s[j].current_A;
        const Vector3d dH = gf.soft_iron_inv * (s[i].mag_B_uT - s[j].mag_B_uT);
        sum += dI * dH;
        sum_dI2 += dI * dI;
        max_dI = std::max(max_dI, std::abs(dI));
        dd.emplace_back(dI, dH);
        ++pairs;
        break;
      }
    }
    if (pairs == 0 || max_dI < o.min_current_span_A) {
      return Status::BadInput(Format(
          "compassmot: needs samples at the same plane and angle (within %s deg) at control 0 and at a current at least %s A higher; found %d pairs, largest current change %.3g A",
          ShortestDouble(o.angle_match_deg).c_str(), ShortestDouble(o.min_current_span_A).c_str(), pairs, max_dI));
    }
    c = sum / sum_dI2;
    double ss = 0.0;
    for (const auto& [dI, dH] : dd) ss += (dH - c * dI).squaredNorm();
    l.diagnostics.pair_rms_residual_uT = std::sqrt(ss / static_cast<double>(dd.size()));
    l.comp = std::make_unique<CurrentSlopeCompensator>(method, gf.soft_iron, gf.hard_iron_uT, c, I0, CurrentFrame::kCorrected);
  } else {
    // PX4 style: raw H = o_pose + c·I per axis, a free offset per (plane, angle) pose.
    std::map<std::pair<std::string, long>, Indices> poses;
    const double bin_deg = std::max(o.angle_match_deg, 1e-6);
    for (size_t i = 0; i < s.size(); ++i) {
      long key = std::lround(WrapDeg360(s[i].angle_deg) / bin_deg);
      if (key * bin_deg >= 360.0 - 0.5 * bin_deg) key = 0;
      poses[{s[i].plane, key}].push_back(i);
    }
    Vector3d sum = Vector3d::Zero();
    std::vector<std::pair<double, Vector3d>> dd;
    for (const auto& [key, idx] : poses) {
      if (idx.size() < 2) continue;
      double mI = 0.0;
      Vector3d mH = Vector3d::Zero();
      for (size_t i : idx) {
        mI += s[i].current_A;
        mH += s[i].mag_B_uT;
      }
      mI /= static_cast<double>(idx.size());
      mH /= static_cast<double>(idx.size());
      for (size_t i : idx) {
        const double dI = s[i].current_A - mI;
        sum += dI * (s[i].mag_B_uT - mH);
        sum_dI2 += dI * dI;
        max_dI = std::max(max_dI, std::abs(dI));
        dd.emplace_back(dI, s[i].mag_B_uT - mH);
        ++pairs;
      }
    }
    if (pairs == 0 || 2.0 * max_dI < o.min_current_span_A) {
      return Status::BadInput(Format(
          "px4-ls: needs repeated poses (same plane and angle within %s deg) at currents spanning at least %s A",
          ShortestDouble(o.angle_match_deg).c_str(), ShortestDouble(o.min_current_span_A).c_str()));
    }
    c = sum / sum_dI2;
    double ss = 0.0;
    for (const auto& [dI, dH] : dd) ss += (dH - c * dI).squaredNorm();
    l.diagnostics.pose_rms_residual_uT = std::sqrt(ss / static_cast<double>(dd.size()));
    l.comp = std::make_unique<CurrentSlopeCompensator>(method, gf.soft_iron, gf.hard_iron_uT, c, I0, CurrentFrame::kRaw);
  }
  l.diagnostics.samples_used_for_c = pairs;
  l.fits.push_back(std::move(ground.value()));
  return l;
}

}  // namespace

bool LearnReport::accepted() const {
  return std::all_of(fits.begin(), fits.end(), [](const LearnedFit& f) { return f.fit.gate.accepted; });
}

Status LearnOptions::IsValid() const {
  HEXSIM_RETURN_IF_ERROR(ellipsoid.IsValid());
  HEXSIM_RETURN_IF_ERROR(line.IsValid());
  if (min_samples_per_fit < ellipsoid.min_samples) return Status::BadInput("min_samples_per_fit: must be >= ellipsoid.min_samples");
  if (min_planes < 1 || min_planes > 3) return Status::BadInput("min_planes: must be in 1..3");
  if (min_control_amounts < 2) return Status::BadInput("min_control_amounts: must be >= 2");
  if (!(control_zero_max_u >= 0.0)) return Status::BadInput("control_zero_max_u: must be >= 0");
  if (!(angle_match_deg > 0.0 && angle_match_deg < 90.0)) return Status::BadInput("angle_match_deg: must be in (0, 90)");
  if (!(min_current_span_A > 0.0)) return Status::BadInput("min_current_span_A: must be > 0");
  return Status::Ok();
}

Result<std::unique_ptr<Compensator>> LearnCompensator(const std::string& method, const std::vector<MagSample>& samples,
                                                      const LearnOptions& options, LearnReport* report) {
  const auto names = CompensatorNames();
  if (std::find(names.begin(), names.end(), method) == names.end()) {
    return Status::BadInput(Format("unknown calibration method '%s' (one of: %s)", method.c_str(), Join(names, ", ").c_str()));
  }
  HEXSIM_RETURN_IF_ERROR(options.IsValid());
  HEXSIM_RETURN_IF_ERROR(ValidateSamples(samples));
  Result<Learnt> learnt = Status::BadInput("unreachable");
  if (method == "none") {
    Learnt l;
    l.comp = MakeNoneCompensator();
    learnt = std::move(l);
  } else if (method == "traditional") {
    learnt = LearnTraditional(samples, options);
  } else if (method == "adaptive" || method == "adaptive-current") {
    learnt = LearnLine(method, samples, options);
  } else {
    learnt = LearnCurrentSlope(method, samples, options);
  }
  if (!learnt.ok()) return learnt.status().WithContext(method);
  Learnt& l = learnt.value();
  if (report) {
    report->method = method;
    report->fits = std::move(l.fits);
    report->diagnostics = std::move(l.diagnostics);
    report->num_samples = samples.size();
  }
  return Result<std::unique_ptr<Compensator>>(std::move(l.comp));
}

}  // namespace hexsim::magnetics
