#include "hexsim/magnetics/field_calibration.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/SVD>

#include "hexsim/common/format.h"

#include "hexsim/common/plausibility.h"

namespace hexsim::magnetics {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

// A sample whose robust weight ends below this is reported as an outlier (Tukey: |e| beyond ≈ 4.4 σ).
constexpr double kOutlierWeight = 0.1;

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(m), v.end());
  const double hi = v[m];
  if (v.size() % 2 == 1) return hi;
  return 0.5 * (hi + *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(m)));
}

std::vector<double> Norms(const std::vector<Vector3d>& B) {
  std::vector<double> n;
  n.reserve(B.size());
  for (const auto& b : B) n.push_back(b.norm());
  return n;
}

enum class Base { kSphere, kCircle, kEllipsoid };

// Residuals |K⁻¹(h − β)| − r of a fit; a circle's in its plane (normal = the weak coverage axis).
std::vector<double> Residuals(const std::vector<Vector3d>& H, const EllipsoidFit& f, Base base, const Coverage& cov) {
  std::vector<double> e;
  e.reserve(H.size());
  for (const auto& h : H) {
    e.push_back(f.Correct(base == Base::kCircle ? ProjectOntoPlane(h, cov.axes.col(0)) : h).norm() - f.radius_uT);
  }
  return e;
}

// Robust scale of residuals: 1.4826·MAD (σ of a Gaussian), floored at 1e-9·r so weights stay finite.
double RobustSigma(const std::vector<double>& e, double r) {
  const double med = Median(e);
  std::vector<double> dev;
  dev.reserve(e.size());
  for (double x : e) dev.push_back(std::abs(x - med));
  return std::max(1.4826 * Median(dev), 1e-9 * std::max(r, 1.0));
}

const char* BaseName(Base b) {
  switch (b) {
    case Base::kSphere: return "sphere";
    case Base::kCircle: return "circle";
    case Base::kEllipsoid: return "ellipsoid";
  }
  return "?";
}

EllipsoidFit RunBase(Base base, const std::vector<Vector3d>& H, const Coverage& cov, EllipsoidFitOptions o,
                     const std::vector<double>& w) {
  o.weights = w;
  // A sphere needs less than the ellipsoid's coverage; poor coverage is a warning of its own.
  if (base != Base::kEllipsoid) o.min_coverage_fraction = 0.0;
  switch (base) {
    case Base::kSphere: return FitSphere(H, o);
    case Base::kCircle: return FitCircle(H, cov.axes.col(0), o);
    case Base::kEllipsoid: return FitEllipsoid(H, o);
  }
  return {};
}

// Iteratively reweighted fit: Huber weights for the first three rounds (a least-squares start may
// be pulled by outliers), then Tukey's biweight w = (1 − (e/c)²)² for |e| < c = tukey_c·σ, else 0.
// Samples screened as gross glitches (`screened`, sorted) weigh 0 in the Huber rounds (even a Huber
// weight leaves a glitch thousands of σ out dominating); Tukey's rounds judge them afresh.
EllipsoidFit RobustFit(Base base, const std::vector<Vector3d>& H, const Coverage& cov, const FieldCalibrationOptions& o,
                       EllipsoidFit f, const std::vector<size_t>& screened, std::vector<double>* w) {
  w->assign(H.size(), 1.0);
  for (int it = 0; it < o.robust_iterations && f.status.ok(); ++it) {
    const auto e = Residuals(H, f, base, cov);
    const double med = Median(e);
    const double sigma = std::max(RobustSigma(e, f.radius_uT), o.sigma_floor_uT);
    std::vector<double> next(H.size());
    for (size_t i = 0; i < H.size(); ++i) {
      const double z = std::abs(e[i] - med) / sigma;
      if (it < 3) {
        next[i] = std::binary_search(screened.begin(), screened.end(), i) ? 0.0 : z <= 1.345 ? 1.0 : 1.345 / z;
      } else {
        const double u = z / o.tukey_c;
        next[i] = u < 1.0 ? (1.0 - u * u) * (1.0 - u * u) : 0.0;
      }
    }
    double change = 0.0;
    for (size_t i = 0; i < H.size(); ++i) change = std::max(change, std::abs(next[i] - (*w)[i]));
    *w = next;
    const auto kept = std::count_if(w->begin(), w->end(), [](double x) { return x > 0.0; });
    if (kept < o.min_ellipsoid_samples) break;
    f = RunBase(base, H, cov, o.fit, *w);
    if (it >= 3 && change < 1e-6) break;
  }
  return f;
}

std::string Eigs(const Vector3d& l) { return Format("%.3f, %.3f, %.3f", l(0), l(1), l(2)); }

}  // namespace

std::vector<std::string> FieldMethodNames() {
  return {"auto", "sphere", "ellipsoid", "robust", "robust-sphere", "robust-ellipsoid", "none"};
}

double NormSpread(const std::vector<Vector3d>& B) {
  if (B.empty()) return 0.0;
  double s = 0.0, ss = 0.0;
  for (const auto& b : B) {
    s += b.norm();
    ss += b.squaredNorm();
  }
  const double n = static_cast<double>(B.size());
  const double mean = s / n;
  return mean > 0.0 ? std::sqrt(std::max(0.0, ss / n - mean * mean)) / mean : 0.0;
}

Result<UnitGuess> DetectUnits(const std::vector<Vector3d>& raw, const std::string& units, double field_norm_uT) {
  const auto& earth = CalibrationRange("earth_field_norm");
  const auto& window = CalibrationRange("raw_field_norm");
  struct Unit {
    const char* name;
    double to_uT;
  };
  static const Unit kUnits[] = {{"uT", 1.0}, {"mG", 0.1}, {"G", 100.0}, {"nT", 0.001}};
  UnitGuess g;
  std::vector<double> norms = Norms(raw);
  std::sort(norms.begin(), norms.end());
  g.median_norm = Median(norms);
  // Every sample the same (beyond rounding): a compass absent, disabled or stuck, not a field.
  if (raw.size() >= 2 && std::all_of(raw.begin(), raw.end(), [&](const Vector3d& v) {
        return (v - raw.front()).norm() <= 1e-9 * std::max(1.0, raw.front().norm());
      })) {
    return Status::BadInput(Format("field: every one of the %zu samples is (%.4g, %.4g, %.4g): the compass is absent, "
                                   "disabled or stuck",
                                   raw.size(), raw.front()(0), raw.front()(1), raw.front()(2)));
  }
  const double lo_uT = window.lo, hi_uT = window.hi;
  if (units == "counts") {
    if (!(field_norm_uT > 0.0)) return Status::BadInput("--units counts needs --field-norm F (the local field in uT, e.g. from hexsim field)");
    if (!(g.median_norm > 0.0)) return Status::BadInput("all samples are zero");
    g.unit = "counts";
    g.to_uT = field_norm_uT / g.median_norm;
    g.assumption = Format("raw counts (median norm %.4g), scaled to the local field %.4g uT", g.median_norm, field_norm_uT);
    return g;
  }
  for (const auto& u : kUnits) {
    const double m_uT = g.median_norm * u.to_uT;
    if (units == u.name || (units == "auto" && m_uT >= lo_uT && m_uT <= hi_uT)) {
      g.unit = u.name;
      g.to_uT = u.to_uT;
      g.assumption = Format("%s %s (median norm %.4g = %.4g uT)", units == "auto" ? "assuming" : "given",
                            std::string(u.name).c_str(), g.median_norm, m_uT);
      if (g.unit == "mG" && units == "auto") {
        g.assumption += "; raw counts can look like milligauss: if these are counts, give --units counts --field-norm F";
      }
      // Given units (or a log's own): the window's floor is for telling units apart; a hard iron that
      // nearly cancels the Earth field puts a real compass's median raw norm below it, but as the
      // vehicle turns its raw norm still reaches |offset| + |field| (a quantile of the norms, not the
      // median). Outside the window only where even the 95th percentile is below it (or above it).
      const double p95_uT = norms.empty() ? 0.0 : norms[(norms.size() - 1) * 95 / 100] * u.to_uT;
      if (units == u.name && m_uT < lo_uT && p95_uT >= lo_uT && m_uT > 1e-6) {
        g.assumption += Format("; the median norm is below the %g uT floor but the 95th percentile reads %.4g uT (a hard "
                               "iron nearly cancelling the field)",
                               lo_uT, p95_uT);
        return g;
      }
      if (m_uT < lo_uT || m_uT > hi_uT) {
        // Given units (or a log's own) that put the median outside what any compass reads: the
        // numbers are no field (a compass absent, disabled or logged as zeros) or not in that unit.
        return Status::BadInput(Format(
            "field norm: median %.4g %s = %.4g uT, outside the %g-%g uT a compass reads (%s): %s", g.median_norm,
            u.name, m_uT, lo_uT, hi_uT, window.reason.c_str(),
            m_uT < 1e-6 ? "every sample is zero: the compass is absent, disabled or not logged"
                        : "not a compass field in these units (give the right --units)"));
      }
      return g;
    }
  }
  if (units != "auto") return Status::BadInput(Format("--units: unknown unit '%s' (uT, mG, G, nT, counts)", units.c_str()));
  return Status::BadInput(Format(
      "median field norm %.4g matches no unit (Earth's %g-%g uT is %g-%g in uT, x10 in mG, /100 in G, x1000 in nT): "
      "give --units, or --units counts --field-norm F",
      g.median_norm, earth.lo, earth.hi, lo_uT, hi_uT));
}

Coverage ComputeCoverage(const std::vector<Vector3d>& B, double median_norm) {
  Coverage c;
  if (B.size() < 2 || !(median_norm > 0.0)) return c;
  Vector3d mean = Vector3d::Zero();
  for (const auto& b : B) mean += b;
  mean /= static_cast<double>(B.size());
  Matrix3d C = Matrix3d::Zero();
  for (const auto& b : B) C += (b - mean) * (b - mean).transpose();
  C /= static_cast<double>(B.size()) * median_norm * median_norm;
  Eigen::SelfAdjointEigenSolver<Matrix3d> es(C);
  c.eigenvalues = es.eigenvalues().cwiseMax(0.0);
  c.axes = es.eigenvectors();
  Eigen::Index k = 0;
  c.axes.col(0).cwiseAbs().maxCoeff(&k);
  static const char* kAxis[3] = {"x", "y", "z"};
  static const char* kHow[3] = {
      "pitch the nose up and down and yaw it round (the x axis never pointed along the field)",
      "roll onto each side and yaw round (the y axis never pointed along the field)",
      "pitch and roll: nose up and down, onto each side, upside down (the z axis never pointed along the field)"};
  c.weak_axis = kAxis[k];
  c.missing_rotation = Format("little spread along body %s: %s", c.weak_axis.c_str(), kHow[k]);
  return c;
}

namespace {

// Samples far from the rest before any fit (a serial glitch: a dropped byte, a read of another
// register): their distance from the coordinate-wise median of the samples is beyond
// outlier_sigmas robust σ of those distances. Only a minority can be glitches: when more than
// max_screened_fraction would be flagged the samples are taken as they are (empty result).
std::vector<size_t> GrossOutliers(const std::vector<Vector3d>& H, const FieldCalibrationOptions& o) {
  std::vector<size_t> out;
  if (H.size() < 3) return out;
  Vector3d centre;
  for (int k = 0; k < 3; ++k) {
    std::vector<double> v;
    v.reserve(H.size());
    for (const auto& h : H) v.push_back(h(k));
    centre(k) = Median(v);
  }
  std::vector<double> d;
  d.reserve(H.size());
  for (const auto& h : H) d.push_back((h - centre).norm());
  const double med = Median(d), sigma = RobustSigma(d, med);
  for (size_t i = 0; i < H.size(); ++i) {
    if (std::abs(d[i] - med) > o.outlier_sigmas * sigma) out.push_back(i);
  }
  if (static_cast<double>(out.size()) > o.max_screened_fraction * static_cast<double>(H.size())) out.clear();
  return out;
}

// The finest step in the readings (the smallest non-zero difference between sorted values of one
// axis, over the three): a quantised sensor's LSB. 0 when the values are not on a grid that coarse.
double ReadingStep_uT(const std::vector<Vector3d>& H) {
  double step = INFINITY;
  for (int k = 0; k < 3; ++k) {
    std::vector<double> v;
    v.reserve(H.size());
    for (const auto& h : H) v.push_back(h(k));
    std::sort(v.begin(), v.end());
    for (size_t i = 1; i < v.size(); ++i) {
      const double dv = v[i] - v[i - 1];
      if (dv > 1e-9 * std::max(1.0, std::abs(v[i]))) step = std::min(step, dv);
    }
  }
  return std::isfinite(step) ? step : 0.0;
}

// "none": no fit, the offset in force stays.
FieldCalibration NoFit(const std::vector<Vector3d>& H, const FieldCalibrationOptions& o, FieldCalibration c, bool consistent,
                       const std::string& spread_note) {
  c.method_used = "none";
  c.why = o.method == "none" ? "requested"
                             : Format("little rotation (coverage eigenvalues %s) and %s", Eigs(c.coverage.eigenvalues).c_str(),
                                      spread_note.c_str());
  double mean = 0.0;
  for (const auto& h : H) mean += h.norm();
  c.radius_uT = H.empty() ? 0.0 : mean / static_cast<double>(H.size());
  c.fitness_uT = c.norm_spread_before * c.radius_uT;
  c.norm_spread_after = c.norm_spread_before;
  if (consistent) c.warnings.push_back(spread_note);
  // No fit: the offset in force stays (an autopilot log's own; zero for a plain dump), so the
  // parameters written reproduce it instead of resetting it.
  c.offset_uT = o.prior_offset_uT;
  if (!o.prior_offset_uT.isZero()) {
    c.warnings.emplace_back("no fit: the autopilot's offset in force is kept in the parameters written (its soft iron is not)");
  }
  return c;
}

// The base fit the method and the coverage allow; BadInput when an explicit method cannot be had.
Status ChooseBase(const FieldCalibrationOptions& o, int n, FieldCalibration* c, Base* base) {
  const Vector3d& l = c->coverage.eigenvalues;
  const bool want_ellipsoid = o.method == "ellipsoid" || o.method == "robust-ellipsoid";
  const bool want_sphere = o.method == "sphere" || o.method == "robust-sphere";
  const std::string poor =
      Format("poor coverage (coverage eigenvalues %s): %s", Eigs(l).c_str(), c->coverage.missing_rotation.c_str());
  *base = Base::kEllipsoid;
  if (want_ellipsoid) {
    if (n < o.min_ellipsoid_samples) {
      return Status::BadInput(Format("too few samples for an ellipsoid: %d (need at least %d)", n, o.min_ellipsoid_samples));
    }
    if (l(0) < o.ellipsoid_eigen) {
      return Status::BadInput(Format("%s; an ellipsoid needs the smallest >= %g: add that rotation, or use --method sphere",
                                     poor.c_str(), o.ellipsoid_eigen));
    }
    c->why = "requested";
  } else if (want_sphere) {
    *base = Base::kSphere;
    c->why = "requested";
  } else if (l(0) < o.ellipsoid_eigen) {
    *base = Base::kSphere;
    c->why = Format("coverage too poor for an ellipsoid (smallest eigenvalue %.3f < %g): offset only", l(0), o.ellipsoid_eigen);
    c->warnings.push_back(poor + "; fitted a sphere (offset only)");
  } else if (n < o.auto_ellipsoid_samples) {
    *base = Base::kSphere;
    c->why = Format("%d samples (an ellipsoid wants %d or more): offset only", n, o.auto_ellipsoid_samples);
    c->warnings.push_back(c->why);
  } else {
    c->why = Format("full coverage (coverage eigenvalues %s) and %d samples: hard and soft iron", Eigs(l).c_str(), n);
  }
  if (*base == Base::kSphere && l(0) < o.sphere_eigen) {
    // A flat spin: the samples trace a circle; its centre is the offset in the plane of rotation.
    *base = Base::kCircle;
    c->undetermined_axis = c->coverage.axes.col(0);
    for (auto& w : c->warnings) {
      if (w == poor + "; fitted a sphere (offset only)") w = poor + "; fitted a circle (the offset in the plane of rotation)";
    }
    c->why += "; a flat spin: circle fit in the plane of rotation";
    c->warnings.push_back(Format(
        "flat rotation: the offset along the spin axis (body %+.3f %+.3f %+.3f, nearest body %s) is undetermined by these "
        "samples; the parameters carry %.2f uT there (%s), not a measured value",
        c->undetermined_axis(0), c->undetermined_axis(1), c->undetermined_axis(2), c->coverage.weak_axis.c_str(),
        c->undetermined_axis.dot(o.prior_offset_uT),
        o.prior_offset_uT.isZero() ? "nothing known" : "the autopilot's current offset"));
  }
  return Status::Ok();
}

// Offset, A, fitness and the physical-range warnings from the final fit.
void Finish(const std::vector<Vector3d>& H, const FieldCalibrationOptions& o, Base base, const EllipsoidFit& f,
            const std::vector<double>& w, FieldCalibration* c) {
  c->fit = f;
  c->accepted = f.gate.accepted;
  if (!c->accepted) c->warnings.push_back("acceptance gate: " + f.gate.Failures());
  c->offset_uT = f.hard_iron_uT;
  c->K = f.soft_iron;
  c->radius_uT = f.radius_uT;
  const double target = o.field_norm_uT > 0.0 ? o.field_norm_uT : f.radius_uT;
  c->A = f.soft_iron_inv * (target / f.radius_uT);
  const std::vector<double> e = Residuals(H, f, base, c->coverage);
  if (base == Base::kCircle) {
    // The circle's centre has no component along the axis: the prior's (0 for a plain dump) is
    // carried there. The radius is the field in the plane, so it scales nothing.
    const Vector3d& n = c->undetermined_axis;
    c->offset_uT += n.dot(o.prior_offset_uT) * n;
    c->A.setIdentity();
    if (o.field_norm_uT > 0.0) {
      c->warnings.emplace_back("the field norm given is not applied: a flat spin does not determine the field along its axis");
    }
  }
  double ss = 0.0, sw = 0.0;
  std::vector<Vector3d> after;
  for (size_t i = 0; i < H.size(); ++i) {
    const double wi = w.empty() ? 1.0 : w[i];
    // The fit's own residual: about the target norm (a circle: its radius, in the plane).
    const double r = base == Base::kCircle ? e[i] : c->Correct(H[i]).norm() - target;
    ss += wi * r * r;
    sw += wi;
    if (wi >= kOutlierWeight) after.push_back(c->Correct(H[i]));
  }
  c->fitness_uT = sw > 0.0 ? std::sqrt(ss / sw) : 0.0;
  c->norm_spread_after = NormSpread(after);
  // Physical ranges (plausibility table): outside them the fit describes no real compass.
  const double offset_uT = c->offset_uT.norm();
  if (!plausibility::IsPlausible("compass_offset", offset_uT)) {
    c->warnings.push_back(Format("model mismatch: offset |b| = %.1f uT outside %s (%s)", offset_uT,
                                 plausibility::RangeText("compass_offset").c_str(),
                                 CalibrationRange("compass_offset").reason.c_str()));
  }
  const Vector3d sv = Eigen::JacobiSVD<Matrix3d>(c->K).singularValues();
  const double condition = sv(2) > 0.0 ? sv(0) / sv(2) : INFINITY;
  if (!plausibility::IsPlausible("soft_iron_condition", condition)) {
    c->warnings.push_back(Format("model mismatch: soft-iron condition %.3g outside %s (%s)", condition,
                                 plausibility::RangeText("soft_iron_condition").c_str(),
                                 CalibrationRange("soft_iron_condition").reason.c_str()));
  }
}

// The distinct readings in first-seen order; of[i] is input sample i's reading. A quantised sensor at
// rest repeats one reading: its repetitions carry no independent noise, and counted each they would
// pull the fit toward that heading and shrink the residuals' MAD to the LSB.
std::vector<Vector3d> Distinct(const std::vector<Vector3d>& H, std::vector<size_t>* of) {
  std::vector<size_t> order(H.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  const auto less = [&](size_t a, size_t b) {
    return std::lexicographical_compare(H[a].data(), H[a].data() + 3, H[b].data(), H[b].data() + 3);
  };
  std::stable_sort(order.begin(), order.end(), less);
  std::vector<size_t> first(H.size());
  for (size_t k = 0; k < order.size(); ++k) {
    first[order[k]] = k > 0 && H[order[k]] == H[order[k - 1]] ? first[order[k - 1]] : order[k];
  }
  std::vector<Vector3d> out;
  std::vector<size_t> slot(H.size(), 0);
  of->assign(H.size(), 0);
  for (size_t i = 0; i < H.size(); ++i) {
    if (first[i] == i) {
      slot[i] = out.size();
      out.push_back(H[i]);
    }
    (*of)[i] = slot[first[i]];
  }
  return out;
}

std::vector<Vector3d> Without(const std::vector<Vector3d>& H, const std::vector<size_t>& drop) {
  std::vector<Vector3d> kept;
  kept.reserve(H.size());
  size_t k = 0;
  for (size_t i = 0; i < H.size(); ++i) {
    if (k < drop.size() && drop[k] == i) {
      ++k;
    } else {
      kept.push_back(H[i]);
    }
  }
  return kept;
}

}  // namespace

Result<FieldCalibration> CalibrateField(const std::vector<Vector3d>& H_in, const FieldCalibrationOptions& o) {
  const auto names = FieldMethodNames();
  if (std::find(names.begin(), names.end(), o.method) == names.end()) {
    return Status::BadInput(Format("--method: unknown method '%s' (one of: %s)", o.method.c_str(), Join(names, ", ").c_str()));
  }
  for (size_t i = 0; i < H_in.size(); ++i) {
    if (!H_in[i].allFinite()) return Status::BadInput(Format("sample %zu: non-finite field", i + 1));
  }
  std::vector<size_t> of;
  const std::vector<Vector3d> H = Distinct(H_in, &of);
  const int n = static_cast<int>(H.size());
  bool robust = o.method.rfind("robust", 0) == 0;
  // Glitches distort the coverage and pull a least-squares start: auto and robust judge coverage
  // and start from the other samples; every sample still enters the robust fit.
  const std::vector<size_t> screened = o.method == "auto" || robust ? GrossOutliers(H, o) : std::vector<size_t>{};
  const std::vector<Vector3d> Hs = screened.empty() ? H : Without(H, screened);
  FieldCalibration c;
  c.norm_spread_before = NormSpread(Hs);
  c.coverage = ComputeCoverage(Hs, Median(Norms(Hs)));
  const Vector3d l = c.coverage.eigenvalues;
  const bool consistent = c.norm_spread_before < o.consistent_spread;
  const std::string spread_note =
      Format("the field norm is already consistent (spread %.2f %%): the data may already be calibrated",
             100.0 * c.norm_spread_before);
  if (o.method == "none" || (o.method == "auto" && n >= 1 && consistent && l(1) < o.sphere_eigen)) {
    c.norm_spread_before = NormSpread(H_in);
    return NoFit(H_in, o, c, consistent, spread_note);
  }
  if (n < o.min_sphere_samples) {
    return Status::BadInput(Format("too few samples: %d (a sphere fit needs at least %d, an ellipsoid %d)", n,
                                   o.min_sphere_samples, o.min_ellipsoid_samples));
  }
  if (l(1) < o.sphere_eigen) {
    return Status::BadInput(Format("too little rotation for any fit (coverage eigenvalues %s, need the middle one >= %g): "
                                   "turn the vehicle through all attitudes%s",
                                   Eigs(l).c_str(), o.sphere_eigen, consistent ? ("; " + spread_note).c_str() : ""));
  }
  // The first look scaled the covariance by the median raw norm, which includes the hard iron: a
  // 40 uT offset on a 30 uT field shrinks every eigenvalue fourfold and calls a good dump poor.
  // Judge the coverage about the field itself: scaled by a first sphere's radius (a circle's for
  // a flat spin), the eigenvalues are those of the sample directions about the fitted centre.
  {
    const EllipsoidFit first = RunBase(l(0) < o.sphere_eigen ? Base::kCircle : Base::kSphere, Hs, c.coverage, o.fit, {});
    if (first.status.ok() && first.radius_uT > 0.0) c.coverage = ComputeCoverage(Hs, first.radius_uT);
  }
  c.norm_spread_before = NormSpread(H_in);
  if (consistent) c.warnings.push_back(spread_note);
  Base base = Base::kEllipsoid;
  HEXSIM_RETURN_IF_ERROR(ChooseBase(o, n, &c, &base));
  if (H.size() < H_in.size()) {
    c.why += Format("; %zu readings repeat an earlier one exactly (a quantised sensor at rest): each distinct reading "
                    "counted once",
                    H_in.size() - H.size());
  }
  if (!screened.empty()) {
    robust = true;
    c.why += Format("; %zu sample(s) far from the rest (beyond %g sigma of their distances from the median sample): "
                    "coverage judged without them, fitted with robust weights",
                    screened.size(), o.outlier_sigmas);
  }
  EllipsoidFit f = RunBase(base, Hs, c.coverage, o.fit, {});
  if (!f.status.ok() && f.status.code() == StatusCode::kNumerical && o.method == "auto" && base == Base::kEllipsoid) {
    c.warnings.push_back("ellipsoid fit failed (" + f.status.message() + "): fell back to a sphere");
    base = Base::kSphere;
    f = RunBase(base, Hs, c.coverage, o.fit, {});
  }
  if (!f.status.ok() && f.status.code() == StatusCode::kNumerical) {
    // Usable but weak coverage (a cap or a band of directions): the radius and the offset along the
    // weak axis trade off and the fit creeps; say so rather than only that it did not converge.
    return Status::Numerical(Format("%s: %s (coverage eigenvalues %s: %s; more rotation lets it converge)",
                                    BaseName(base), f.status.message().c_str(), Eigs(c.coverage.eigenvalues).c_str(),
                                    c.coverage.missing_rotation.c_str()));
  }
  if (!f.status.ok()) return f.status.WithContext(BaseName(base));
  FieldCalibrationOptions ro = o;
  // σ never below what the readings can resolve: a quantised sensor at rest repeats one value, and a
  // MAD of zero would make every sample off that value an outlier (a uniform LSB error: step/√12).
  ro.sigma_floor_uT = std::max(o.sigma_floor_uT, ReadingStep_uT(H) / std::sqrt(12.0));
  if (o.method == "auto" && !robust) {
    const auto e = Residuals(H, f, base, c.coverage);
    const double med = Median(e), sigma = std::max(RobustSigma(e, f.radius_uT), ro.sigma_floor_uT);
    const auto far = std::count_if(e.begin(), e.end(), [&](double x) { return std::abs(x - med) > o.outlier_sigmas * sigma; });
    if (far > 0) {
      robust = true;
      c.why += Format("; %ld sample(s) beyond %g sigma: reweighted (robust)", static_cast<long>(far), o.outlier_sigmas);
    }
  }
  std::vector<double> w;
  if (robust) {
    EllipsoidFit rf = RobustFit(base, H, c.coverage, ro, f, screened, &w);
    if (!rf.status.ok() && (o.method != "auto" || rf.status.code() != StatusCode::kNumerical)) {
      return rf.status.WithContext(std::string("robust ") + BaseName(base));
    }
    if (rf.status.ok()) {
      f = rf;
    } else {  // auto: the unweighted fit stands, said so
      c.warnings.push_back("robust reweighting failed (" + rf.status.message() + "): the unweighted fit is kept");
      robust = false;
      w.clear();
    }
    for (size_t i = 0; i < H_in.size() && !w.empty(); ++i) {
      if (w[of[i]] < kOutlierWeight) c.downweighted.push_back(i);
    }
    if (!c.downweighted.empty()) {
      c.warnings.push_back(Format("%zu sample(s) down-weighted as outliers (weight < %g)", c.downweighted.size(), kOutlierWeight));
    }
  }
  c.method_used = (robust ? std::string("robust-") : std::string()) + BaseName(base);
  Finish(H, o, base, f, w, &c);
  return c;
}

}  // namespace hexsim::magnetics
