#include "hexsim/magnetics/line_fit.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/SVD>

#include "hexsim/common/format.h"

namespace hexsim::magnetics {
namespace {

using Eigen::Vector3d;

Status CheckPoints(const std::vector<Vector3d>& p) {
  if (p.size() < 2) return Status::BadInput(Format("line fit: need at least 2 points, got %zu", p.size()));
  for (size_t i = 0; i < p.size(); ++i) {
    if (!p[i].allFinite()) return Status::BadInput(Format("line fit: point %zu is not finite", i));
  }
  return Status::Ok();
}

Vector3d Centroid(const std::vector<Vector3d>& p) {
  Vector3d m = Vector3d::Zero();
  for (const auto& x : p) m += x;
  return m / static_cast<double>(p.size());
}

double RmsDistance(const SpaceLine& line, const std::vector<Vector3d>& p) {
  double ss = 0.0;
  for (const auto& x : p) ss += std::pow(line.DistanceTo(x), 2);
  return std::sqrt(ss / static_cast<double>(p.size()));
}

Status CheckScalars(const std::vector<double>& x, const std::vector<double>& s) {
  if (x.size() != s.size()) return Status::BadInput("along-line fit: x and s differ in length");
  for (size_t i = 0; i < x.size(); ++i) {
    if (!std::isfinite(x[i]) || !std::isfinite(s[i])) return Status::BadInput(Format("along-line fit: value %zu is not finite", i));
  }
  return Status::Ok();
}

// Distinct x (sorted) with the mean s at each.
void AverageByX(const std::vector<double>& x, const std::vector<double>& s, std::vector<double>* ux,
                std::vector<double>* us, std::vector<double>* weight) {
  std::map<double, std::pair<double, int>> acc;
  for (size_t i = 0; i < x.size(); ++i) {
    auto& a = acc[x[i]];
    a.first += s[i];
    a.second += 1;
  }
  ux->clear();
  us->clear();
  weight->clear();
  for (const auto& [xv, a] : acc) {
    ux->push_back(xv);
    us->push_back(a.first / a.second);
    weight->push_back(a.second);
  }
}

// Weighted pool-adjacent-violators: the non-decreasing sequence closest to y in weighted L2.
std::vector<double> IsotonicIncreasing(const std::vector<double>& y, const std::vector<double>& w) {
  struct Block { double sum_wy, sum_w; size_t count; };
  std::vector<Block> blocks;
  for (size_t i = 0; i < y.size(); ++i) {
    blocks.push_back({w[i] * y[i], w[i], 1});
    while (blocks.size() > 1) {
      const Block& b = blocks.back();
      const Block& a = blocks[blocks.size() - 2];
      if (a.sum_wy / a.sum_w <= b.sum_wy / b.sum_w) break;
      Block merged{a.sum_wy + b.sum_wy, a.sum_w + b.sum_w, a.count + b.count};
      blocks.pop_back();
      blocks.back() = merged;
    }
  }
  std::vector<double> out;
  for (const auto& b : blocks) out.insert(out.end(), b.count, b.sum_wy / b.sum_w);
  return out;
}

// Fritsch–Carlson monotone slopes.
std::vector<double> PchipSlopes(const std::vector<double>& x, const std::vector<double>& y) {
  const size_t n = x.size();
  std::vector<double> h(n - 1), delta(n - 1), m(n, 0.0);
  for (size_t i = 0; i + 1 < n; ++i) {
    h[i] = x[i + 1] - x[i];
    delta[i] = (y[i + 1] - y[i]) / h[i];
  }
  if (n == 2) {
    m[0] = m[1] = delta[0];
    return m;
  }
  for (size_t i = 1; i + 1 < n; ++i) {
    if (delta[i - 1] * delta[i] <= 0.0) {
      m[i] = 0.0;
    } else {
      const double w1 = 2 * h[i] + h[i - 1], w2 = h[i] + 2 * h[i - 1];
      m[i] = (w1 + w2) / (w1 / delta[i - 1] + w2 / delta[i]);
    }
  }
  // One-sided three-point end slopes, limited to keep monotonicity.
  auto end_slope = [](double h0, double h1, double d0, double d1) {
    double e = ((2 * h0 + h1) * d0 - h0 * d1) / (h0 + h1);
    if (e * d0 <= 0.0) e = 0.0;
    else if (d0 * d1 <= 0.0 && std::abs(e) > std::abs(3 * d0)) e = 3 * d0;
    return e;
  };
  m[0] = end_slope(h[0], h[1], delta[0], delta[1]);
  m[n - 1] = end_slope(h[n - 2], h[n - 3], delta[n - 2], delta[n - 3]);
  return m;
}

}  // namespace

double SpaceLine::DistanceTo(const Vector3d& p) const {
  const Vector3d r = p - point_uT;
  return (r - direction.dot(r) * direction).norm();
}

Status LineFitOptions::IsValid() const {
  if (max_iterations < 1) return Status::BadInput("line fit: max_iterations must be >= 1");
  if (!(tolerance > 0.0)) return Status::BadInput("line fit: tolerance must be > 0");
  if (!(singular_tolerance > 0.0 && singular_tolerance < 1.0)) return Status::BadInput("line fit: singular_tolerance must be in (0, 1)");
  return Status::Ok();
}

PaperLineFit FitLinePaperTls(const std::vector<Vector3d>& points_uT, const LineFitOptions& options) {
  PaperLineFit f;
  f.status = options.IsValid();
  if (!f.status.ok()) return f;
  f.status = CheckPoints(points_uT);
  if (!f.status.ok()) return f;
  const Vector3d mu = Centroid(points_uT);
  const Eigen::Index n = static_cast<Eigen::Index>(points_uT.size());
  double ss_all = 0.0, ss_z = 0.0;
  for (const auto& p : points_uT) {
    ss_all += (p - mu).squaredNorm();
    ss_z += std::pow(p(2) - mu(2), 2);
  }
  if (!(ss_all > 0.0)) {
    f.status = Status::BadInput("line fit: all points coincide");
    return f;
  }
  if (std::sqrt(ss_z / ss_all) < options.singular_tolerance) {
    f.status = Status::Numerical(
        "paper line form x = a z + b, y = c z + d is singular: z does not vary along the points "
        "(centres move in the X-Y plane); use the direction-vector fit");
    return f;
  }
  // V = B ξ − L (eq. 14). The paper's B has rows [z 1 0 0] → x and [0 0 z 1] → y; its constant
  // columns are exact (not measurements), and its update (eq. 16) perturbs them too, which lets the
  // intercepts run away on noisy data (the all-columns TLS minimum is degenerate along them). We
  // therefore centre the points (the TLS line passes through the centroid, so the centred
  // intercepts are 0), iterate eq. 15–16 on ξ = [a c] with rows [z 0] → x and [0 z] → y, and
  // restore b, d from the centroid.
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(2 * n, 2);
  Eigen::VectorXd L(2 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vector3d p = points_uT[static_cast<size_t>(i)] - mu;
    B(2 * i, 0) = p(2);
    B(2 * i + 1, 1) = p(2);
    L(2 * i) = p(0);
    L(2 * i + 1) = p(1);
  }
  auto solve_normal = [&](const Eigen::MatrixXd& Bh, Eigen::Vector2d* xi) {
    const Eigen::Matrix2d N = Bh.transpose() * Bh;
    Eigen::FullPivLU<Eigen::Matrix2d> lu(N);
    lu.setThreshold(1e-12);
    if (!lu.isInvertible()) return false;
    *xi = lu.solve(Bh.transpose() * L);
    return xi->allFinite();
  };
  Eigen::Vector2d xi;
  if (!solve_normal(B, &xi)) {
    f.status = Status::Numerical("paper line form: singular normal matrix BᵀB (z does not vary)");
    return f;
  }
  for (f.iterations = 1; f.iterations <= options.max_iterations; ++f.iterations) {
    // (E + ξξᵀ) B̂ᵀ = Bᵀ + ξ Lᵀ  (eq. 16)
    const Eigen::Matrix2d E = Eigen::Matrix2d::Identity() + xi * xi.transpose();
    const Eigen::MatrixXd Bh = E.ldlt().solve(B.transpose() + xi * L.transpose()).transpose();
    // B̂ᵀB̂ ξ = B̂ᵀL  (eq. 15)
    Eigen::Vector2d xi_new;
    if (!solve_normal(Bh, &xi_new)) {
      f.status = Status::Numerical("paper line form: singular normal matrix B̂ᵀB̂ during iteration");
      return f;
    }
    const double step = (xi_new - xi).norm();
    xi = xi_new;
    if (step < options.tolerance * (1.0 + xi.norm())) {
      f.converged = true;
      break;
    }
  }
  if (!f.converged) {
    f.iterations = options.max_iterations;
    f.status = Status::Numerical(Format("paper line TLS did not converge in %d iterations", options.max_iterations));
    return f;
  }
  // Restore intercepts: x − μx = a (z − μz).
  f.a = xi(0);
  f.c = xi(1);
  f.b_uT = mu(0) - f.a * mu(2);
  f.d_uT = mu(1) - f.c * mu(2);
  f.line.point_uT = Vector3d(f.b_uT, f.d_uT, 0.0);
  f.line.direction = Vector3d(f.a, f.c, 1.0).normalized();
  f.rms_residual_uT = RmsDistance(f.line, points_uT);
  return f;
}

SvdLineFit FitLineSvd(const std::vector<Vector3d>& points_uT) {
  SvdLineFit f;
  f.status = CheckPoints(points_uT);
  if (!f.status.ok()) return f;
  const Vector3d mu = Centroid(points_uT);
  Eigen::MatrixXd X(static_cast<Eigen::Index>(points_uT.size()), 3);
  for (size_t i = 0; i < points_uT.size(); ++i) X.row(static_cast<Eigen::Index>(i)) = (points_uT[i] - mu).transpose();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(X, Eigen::ComputeThinV);
  f.singular_values = svd.singularValues();
  if (!(f.singular_values(0) > 0.0)) {
    f.status = Status::BadInput("line fit: all points coincide");
    return f;
  }
  Vector3d dir = svd.matrixV().col(0);
  Eigen::Index imax = 0;
  dir.cwiseAbs().maxCoeff(&imax);
  if (dir(imax) < 0.0) dir = -dir;
  f.line.point_uT = mu;
  f.line.direction = dir.normalized();
  f.rms_residual_uT = RmsDistance(f.line, points_uT);
  return f;
}

double AlongModel::Eval(double x) const {
  if (kind == AlongKind::kLinear) return s0_uT + k_uT_per_x * x;
  const size_t n = knots_x.size();
  HEXSIM_CHECK(n >= 2 && knots_s_uT.size() == n && slopes.size() == n);
  if (x <= knots_x.front()) return knots_s_uT.front() + slopes.front() * (x - knots_x.front());
  if (x >= knots_x.back()) return knots_s_uT.back() + slopes.back() * (x - knots_x.back());
  const size_t i = static_cast<size_t>(std::upper_bound(knots_x.begin(), knots_x.end(), x) - knots_x.begin()) - 1;
  const double h = knots_x[i + 1] - knots_x[i];
  const double t = (x - knots_x[i]) / h;
  const double t2 = t * t, t3 = t2 * t;
  // Cubic Hermite basis.
  return (2 * t3 - 3 * t2 + 1) * knots_s_uT[i] + (t3 - 2 * t2 + t) * h * slopes[i] +
         (-2 * t3 + 3 * t2) * knots_s_uT[i + 1] + (t3 - t2) * h * slopes[i + 1];
}

AlongFit FitLinearAlong(const std::vector<double>& x, const std::vector<double>& s) {
  AlongFit f;
  f.status = CheckScalars(x, s);
  if (!f.status.ok()) return f;
  const size_t n = x.size();
  const double mx = n ? std::accumulate(x.begin(), x.end(), 0.0) / n : 0.0;
  const double ms = n ? std::accumulate(s.begin(), s.end(), 0.0) / n : 0.0;
  double sxx = 0.0, sxs = 0.0;
  for (size_t i = 0; i < n; ++i) {
    sxx += (x[i] - mx) * (x[i] - mx);
    sxs += (x[i] - mx) * (s[i] - ms);
  }
  const double scale_x = std::max(1.0, std::abs(mx));
  if (n < 2 || !(sxx > 1e-18 * scale_x * scale_x * static_cast<double>(n))) {
    f.status = Status::BadInput("along-line fit: needs at least two distinct values of the index (control amount or current)");
    return f;
  }
  f.model.kind = AlongKind::kLinear;
  f.model.k_uT_per_x = sxs / sxx;
  f.model.s0_uT = ms - f.model.k_uT_per_x * mx;
  double ss = 0.0;
  for (size_t i = 0; i < n; ++i) ss += std::pow(s[i] - f.model.Eval(x[i]), 2);
  f.rms_residual_uT = std::sqrt(ss / static_cast<double>(n));
  return f;
}

AlongFit FitMonotoneAlong(const std::vector<double>& x, const std::vector<double>& s) {
  AlongFit f;
  f.status = CheckScalars(x, s);
  if (!f.status.ok()) return f;
  std::vector<double> ux, us, w;
  AverageByX(x, s, &ux, &us, &w);
  if (ux.size() < 2) {
    f.status = Status::BadInput("along-line fit: needs at least two distinct values of the index (control amount or current)");
    return f;
  }
  // Trend direction from the least-squares slope.
  const AlongFit lin = FitLinearAlong(x, s);
  const double sign = (lin.status.ok() && lin.model.k_uT_per_x < 0.0) ? -1.0 : 1.0;
  std::vector<double> y(us.size());
  for (size_t i = 0; i < us.size(); ++i) y[i] = sign * us[i];
  y = IsotonicIncreasing(y, w);
  for (auto& v : y) v *= sign;
  f.model.kind = AlongKind::kMonotone;
  f.model.knots_x = ux;
  f.model.knots_s_uT = y;
  f.model.slopes = PchipSlopes(ux, y);
  double ss = 0.0;
  for (size_t i = 0; i < x.size(); ++i) ss += std::pow(s[i] - f.model.Eval(x[i]), 2);
  f.rms_residual_uT = std::sqrt(ss / static_cast<double>(x.size()));
  return f;
}

}  // namespace hexsim::magnetics
