#include "hexsim/experiments/table1.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <fmt/format.h>

#include "hexsim/magnetics/heading_error.h"

namespace hexsim::experiments {

namespace {
// Two control amounts closer than this are one (the paper's units, 0…1000).
constexpr double kSameControl_u = 0.5;
bool SameControl(double a, double b) { return std::fabs(a - b) < kSameControl_u; }
}  // namespace

std::vector<double> DistinctControls(const std::vector<magnetics::MagSample>& samples) {
  std::vector<double> u;
  for (const auto& s : samples) {
    if (std::none_of(u.begin(), u.end(), [&](double v) { return SameControl(v, s.control_u); })) u.push_back(s.control_u);
  }
  std::sort(u.begin(), u.end());
  return u;
}

double MeanCurrent(const std::vector<magnetics::MagSample>& samples, double control_u) {
  double sum = 0.0;
  int n = 0;
  for (const auto& s : samples) {
    if (SameControl(s.control_u, control_u)) {
      sum += s.current_A;
      ++n;
    }
  }
  return n > 0 ? sum / n : 0.0;
}

namespace {

Result<HeadingCurves> Curves(const GroundCalibration& cal, const magnetics::Compensator& comp,
                             const std::vector<magnetics::MagSample>& turn) {
  HeadingCurves m;
  m.calibration = cal.requested;
  for (double u : DistinctControls(turn)) {
    std::vector<std::pair<double, double>> pts;  // (angle, error)
    for (const auto& s : turn) {
      if (SameControl(s.control_u, u)) pts.emplace_back(s.angle_deg, magnetics::SampleHeadingErrorDeg(comp, s));
    }
    std::sort(pts.begin(), pts.end());
    std::vector<double> angles, errs;
    double mx = 0.0;
    for (const auto& [a, e] : pts) {
      angles.push_back(a);
      errs.push_back(e);
      mx = std::max(mx, std::fabs(e));
    }
    if (m.angle_deg.empty()) m.angle_deg = angles;
    if (angles != m.angle_deg) return Status::BadInput("table 1: turntable turns differ in their table angles");
    m.control_u.push_back(u);
    m.current_A.push_back(MeanCurrent(turn, u));
    m.error_deg.push_back(std::move(errs));
    m.max_abs_deg.push_back(mx);
  }
  return m;
}

}  // namespace

Result<Table1> EvaluateTable1(const std::vector<GroundCalibration>& calibrations,
                              const std::vector<double>& control_u, const std::vector<magnetics::MagSample>& turn) {
  Table1 out;
  out.table.control_u = control_u;
  const std::shared_ptr<const magnetics::Compensator> none(magnetics::MakeNoneCompensator());
  for (const auto& cal : calibrations) {
    const magnetics::Compensator& comp = cal.compensator ? *cal.compensator : *none;
    auto eval = magnetics::EvaluateHeadingError(comp, turn, magnetics::HeadingErrorOptions{});
    if (!eval.ok()) return eval.status();
    HeadingErrorRow row;
    row.name = cal.requested == "none" ? "uncorrected" : cal.requested;
    row.method = cal.requested;
    for (const auto& e : *eval) {
      row.max_deg.push_back(e.max_abs_deg);
      row.rms_deg.push_back(e.rms_deg);
      row.current_A.push_back(e.mean_current_A);
    }
    out.table.rows.push_back(std::move(row));
    auto curves = Curves(cal, comp, turn);
    if (!curves.ok()) return curves.status();
    out.curves.push_back(std::move(*curves));
  }
  return out;
}

Result<GroundSessionFits> FitGroundSession(const std::vector<magnetics::MagSample>& ground) {
  GroundSessionFits out;
  std::vector<Eigen::Vector3d> centres;
  for (double u : DistinctControls(ground)) {
    ControlFit c;
    c.control_u = u;
    c.mean_current_A = MeanCurrent(ground, u);
    std::set<std::string> planes;
    for (const auto& s : ground) {
      if (!SameControl(s.control_u, u)) continue;
      c.mag_B_uT.push_back(s.mag_B_uT);
      planes.insert(s.plane);
    }
    magnetics::EllipsoidFitOptions opt;
    opt.planes_present = static_cast<int>(planes.size());
    c.fit = magnetics::FitEllipsoid(c.mag_B_uT, opt);
    if (!c.fit.status.ok()) return c.fit.status.WithContext(fmt::format("ground session: ellipsoid fit at control {:g}", u));
    centres.push_back(c.fit.hard_iron_uT);
    out.per_control.push_back(std::move(c));
  }
  if (centres.size() >= 2) {
    out.line = magnetics::FitLineSvd(centres);
    if (!out.line.status.ok()) return out.line.status.WithContext("ground session: centre line");
    out.has_line = true;
  }
  return out;
}

}  // namespace hexsim::experiments
