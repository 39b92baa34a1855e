#include "hexsim/magnetics/ellipsoid_fit.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/SVD>

#include "hexsim/common/format.h"

namespace hexsim::magnetics {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

constexpr double kGoldenAngle_rad = 2.39996322972865332;  // π(3 − √5)

Status CheckSamples(const std::vector<Vector3d>& H, const EllipsoidFitOptions& o) {
  HEXSIM_RETURN_IF_ERROR(o.IsValid());
  if (static_cast<int>(H.size()) < o.min_samples) {
    return Status::BadInput(Format("too few samples: %zu (need at least %d)", H.size(), o.min_samples));
  }
  for (size_t i = 0; i < H.size(); ++i) {
    if (!H[i].allFinite()) return Status::BadInput(Format("sample %zu is not finite", i));
  }
  if (!o.weights.empty() && o.weights.size() != H.size()) {
    return Status::BadInput(Format("weights: %zu given for %zu samples", o.weights.size(), H.size()));
  }
  for (double w : o.weights) {
    if (!(w >= 0.0 && std::isfinite(w))) return Status::BadInput("weights: must be finite and >= 0");
  }
  return Status::Ok();
}

// Centroid and RMS distance from it, for conditioning.
void CentreAndScale(const std::vector<Vector3d>& H, Vector3d* mean, double* scale) {
  Vector3d m = Vector3d::Zero();
  for (const auto& h : H) m += h;
  m /= static_cast<double>(H.size());
  double ss = 0.0;
  for (const auto& h : H) ss += (h - m).squaredNorm();
  *mean = m;
  *scale = std::sqrt(ss / static_cast<double>(H.size()));
}

// Smallest / largest principal standard deviation of the cloud.
double SpreadRatio(const std::vector<Vector3d>& H, const Vector3d& mean) {
  Matrix3d C = Matrix3d::Zero();
  for (const auto& h : H) C += (h - mean) * (h - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Matrix3d> es(C, Eigen::EigenvaluesOnly);  // (same values, no vectors)
  const Vector3d ev = es.eigenvalues().cwiseMax(0.0);
  if (ev(2) <= 0.0) return 0.0;
  return std::sqrt(ev(0) / ev(2));
}

Matrix3d SymFromParams(const Eigen::Matrix<double, 9, 1>& p) {
  Matrix3d M;
  M << p(0), p(3), p(4),  //
      p(3), p(1), p(5),   //
      p(4), p(5), p(2);
  return M;
}

// Symmetric square root of a symmetric positive definite matrix; false when not positive definite.
bool SqrtSpd(const Matrix3d& A, Matrix3d* out) {
  Eigen::SelfAdjointEigenSolver<Matrix3d> es(A);
  if (es.info() != Eigen::Success || !(es.eigenvalues().minCoeff() > 0.0)) return false;
  *out = es.eigenvectors() * es.eigenvalues().cwiseSqrt().asDiagonal() * es.eigenvectors().transpose();
  return true;
}

// Li & Griffiths (2004): least-squares ellipsoid a x² + b y² + c z² + 2f yz + 2g xz + 2h xy
// + 2p x + 2q y + 2r z + d = 0 subject to 4J − I² = 1. On centred, scaled data x_n.
// Out: centre β_n and M_n with ‖M_n(x_n − β_n)‖ = 1 on the ellipsoid.
Status AlgebraicEllipsoid(const std::vector<Vector3d>& xn, const std::vector<double>& w, Vector3d* beta_n,
                          Matrix3d* M_n) {
  const Eigen::Index n = static_cast<Eigen::Index>(xn.size());
  Eigen::MatrixXd D(n, 10);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double x = xn[i](0), y = xn[i](1), z = xn[i](2);
    D.row(i) << x * x, y * y, z * z, 2 * y * z, 2 * x * z, 2 * x * y, 2 * x, 2 * y, 2 * z, 1.0;
    if (!w.empty()) D.row(i) *= std::sqrt(w[static_cast<size_t>(i)]);
  }
  // S = DᵀD from column dot products, upper triangle mirrored (half a GEMM, no packing).
  Eigen::Matrix<double, 10, 10> S;
  for (int c = 0; c < 10; ++c) {
    for (int r = 0; r <= c; ++r) S(r, c) = S(c, r) = D.col(r).dot(D.col(c));
  }
  const Eigen::Matrix<double, 6, 6> S11 = S.topLeftCorner<6, 6>();
  const Eigen::Matrix<double, 6, 4> S12 = S.topRightCorner<6, 4>();
  const Eigen::Matrix<double, 4, 4> S22 = S.bottomRightCorner<4, 4>();
  Eigen::FullPivLU<Eigen::Matrix<double, 4, 4>> lu22(S22);
  if (!lu22.isInvertible()) return Status::Numerical("algebraic fit: singular linear block (degenerate samples)");
  const Eigen::Matrix<double, 4, 6> S22inv_S21 = lu22.solve(S12.transpose());
  const Eigen::Matrix<double, 6, 6> Sred = S11 - S12 * S22inv_S21;
  // Constraint matrix C1 (k = 4).
  Eigen::Matrix<double, 6, 6> C1 = Eigen::Matrix<double, 6, 6>::Zero();
  C1.topLeftCorner<3, 3>() << -1, 1, 1, 1, -1, 1, 1, 1, -1;
  C1(3, 3) = C1(4, 4) = C1(5, 5) = -4.0;
  const Eigen::Matrix<double, 6, 6> E = C1.inverse() * Sred;
  Eigen::EigenSolver<Eigen::Matrix<double, 6, 6>> es(E);
  if (es.info() != Eigen::Success) return Status::Numerical("algebraic fit: eigen-decomposition failed");
  int best = -1;
  double best_val = 0.0;
  for (int i = 0; i < 6; ++i) {
    const double re = es.eigenvalues()(i).real();
    if (std::abs(es.eigenvalues()(i).imag()) < 1e-9 * (1.0 + std::abs(re)) && re > best_val) {
      best_val = re;
      best = i;
    }
  }
  if (best < 0) return Status::Numerical("algebraic fit: no ellipsoid solution (no positive eigenvalue)");
  const Eigen::Matrix<double, 6, 1> v1 = es.eigenvectors().col(best).real();
  const Eigen::Matrix<double, 4, 1> v2 = -S22inv_S21 * v1;
  Matrix3d A;
  A << v1(0), v1(5), v1(4), v1(5), v1(1), v1(3), v1(4), v1(3), v1(2);
  const Vector3d b(v2(0), v2(1), v2(2));
  const double d = v2(3);
  Eigen::FullPivLU<Matrix3d> luA(A);
  if (!luA.isInvertible()) return Status::Numerical("algebraic fit: singular quadric");
  const Vector3d centre = -luA.solve(b);
  // (x − c)ᵀ A (x − c) = cᵀ A c − d = g.
  const double g = centre.dot(A * centre) - d;
  Matrix3d Mn;
  if (!(std::abs(g) > 0.0) || !SqrtSpd(A / g, &Mn)) {
    return Status::Numerical("algebraic fit: quadric is not an ellipsoid");
  }
  *beta_n = centre;
  *M_n = Mn;
  return Status::Ok();
}

struct LmResult {
  Status status;
  int iterations = 0;
  bool converged = false;
  double condition_number = 0.0;
};

// Residuals e_i = ‖M(H_i − β)‖ − 1 and Jacobian J (n×9, every column written: the caller's buffer
// is reused) at p = [M00 M11 M22 M01 M02 M12 βx βy βz]; `sphere`: M = m I (column 0 only).
void LmResiduals(const std::vector<Vector3d>& H, const EllipsoidFitOptions& o, bool sphere,
                 const Eigen::Matrix<double, 9, 1>& p, Eigen::VectorXd* e, Eigen::MatrixXd* J) {
  const Eigen::Index n = static_cast<Eigen::Index>(H.size());
  const Matrix3d M = SymFromParams(p);
  const Vector3d beta = p.tail<3>();
  e->resize(n);
  J->resize(n, 9);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vector3d v = H[i] - beta;
    const Vector3d w = M * v;
    const double nw = w.norm();
    (*e)(i) = nw - 1.0;
    const Vector3d u = nw > 0.0 ? Vector3d(w / nw) : Vector3d::Zero();
    if (sphere) {
      const double dm = u.dot(v);  // d/dm of ‖m v‖ with M = m I
      (*J)(i, 0) = dm;
      for (int c = 1; c < 6; ++c) (*J)(i, c) = 0.0;
    } else {
      (*J)(i, 0) = u(0) * v(0);
      (*J)(i, 1) = u(1) * v(1);
      (*J)(i, 2) = u(2) * v(2);
      (*J)(i, 3) = u(0) * v(1) + u(1) * v(0);
      (*J)(i, 4) = u(0) * v(2) + u(2) * v(0);
      (*J)(i, 5) = u(1) * v(2) + u(2) * v(1);
    }
    J->block<1, 3>(i, 6) = -(u.transpose() * M);
    if (!o.weights.empty()) {  // Σ w e²: rows scaled by √w
      const double sw = std::sqrt(o.weights[static_cast<size_t>(i)]);
      (*e)(i) *= sw;
      J->row(i) *= sw;
    }
  }
}

// Condition number of the column-scaled Jacobian Ja·D⁻¹ (D = its column norms √(JaᵀJa)_kk) from
// the active parameters' normal matrix JaᵀJa: cond = sqrt(λmax/λmin) of D⁻¹·JaᵀJa·D⁻¹, the same
// number as an SVD of the scaled n×9 Jacobian.
template <typename MatA>
double ScaledConditionNumber(MatA JtJ) {
  for (Eigen::Index k = 0; k < JtJ.rows(); ++k) {
    const double cn = std::sqrt(JtJ(k, k));
    if (cn > 0.0) {
      JtJ.row(k) /= cn;
      JtJ.col(k) /= cn;
    }
  }
  Eigen::SelfAdjointEigenSolver<MatA> eig(JtJ, Eigen::EigenvaluesOnly);
  const auto& ev = eig.eigenvalues();  // ascending
  return ev(0) > 0.0 ? std::sqrt(ev(ev.size() - 1) / ev(0)) : std::numeric_limits<double>::infinity();
}

// Levenberg–Marquardt on e_i = ‖M(H_i − β)‖ − 1, p = [M00 M11 M22 M01 M02 M12 βx βy βz].
// `sphere` keeps M at a multiple of I (only M00 = M11 = M22 free); `planar` also keeps βz fixed.
LmResult RefineLm(const std::vector<Vector3d>& H, const EllipsoidFitOptions& o, bool sphere,
                  Eigen::Matrix<double, 9, 1>* params, bool planar = false) {
  using Vec9 = Eigen::Matrix<double, 9, 1>;
  using Mat9 = Eigen::Matrix<double, 9, 9>;
  auto evaluate = [&](const Vec9& p, Eigen::VectorXd* e, Eigen::MatrixXd* J) { LmResiduals(H, o, sphere, p, e, J); };
  // Normal equations of the full 9 columns, JᵀJ and Jᵀe, as column dot products (contiguous
  // columns; upper triangle mirrored): half the work of a GEMM and none of its packing.
  auto normal = [&](const Eigen::MatrixXd& J, const Eigen::VectorXd& e, Mat9* JtJ, Vec9* Jte) {
    for (int c = 0; c < 9; ++c) {
      for (int r = 0; r <= c; ++r) (*JtJ)(r, c) = (*JtJ)(c, r) = J.col(r).dot(J.col(c));
      (*Jte)(c) = J.col(c).dot(e);
    }
  };
  // Active parameter mask.
  std::vector<int> active = sphere ? std::vector<int>{0, 6, 7, 8} : std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7, 8};
  if (planar) active = {0, 6, 7};
  const Eigen::Index na = static_cast<Eigen::Index>(active.size());
  // Active-parameter sized (≤ 9) matrices and vectors, stored inline: no heap in the iterations.
  using MatA = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 9, 9>;
  using VecA = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 9, 1>;
  auto apply_step = [&](const Vec9& p, const VecA& dx) {
    Vec9 q = p;
    for (Eigen::Index k = 0; k < na; ++k) q(active[k]) += dx(k);
    if (sphere) q(1) = q(2) = q(0);
    return q;
  };
  // The active parameters' block of the normal equations (na×na, na×1).
  auto reduce = [&](const Mat9& JtJ9, const Vec9& Jte9, MatA* JtJ, VecA* g) {
    JtJ->resize(na, na);
    g->resize(na);
    for (Eigen::Index k = 0; k < na; ++k) {
      (*g)(k) = Jte9(active[k]);
      for (Eigen::Index l = 0; l < na; ++l) (*JtJ)(k, l) = JtJ9(active[k], active[l]);
    }
  };

  LmResult r;
  Vec9 p = *params;
  // The trial step's residuals and Jacobian are evaluated together (a trial is usually accepted,
  // and then its Jacobian is the next one): J_new, e_new are swapped in on acceptance.
  Eigen::VectorXd e, e_new;
  Eigen::MatrixXd J, J_new;
  Mat9 JtJ9;
  Vec9 Jte9;
  evaluate(p, &e, &J);
  normal(J, e, &JtJ9, &Jte9);
  double cost = e.squaredNorm();
  double lambda = 1e-3;
  MatA JtJ;
  VecA g;
  for (r.iterations = 1; r.iterations <= o.max_iterations; ++r.iterations) {
    reduce(JtJ9, Jte9, &JtJ, &g);
    bool accepted = false;
    VecA dx;
    Vec9 p_new;
    for (int tries = 0; tries < 30 && !accepted; ++tries) {
      MatA A = JtJ;
      for (Eigen::Index k = 0; k < na; ++k) A(k, k) += lambda * std::max(JtJ(k, k), 1e-300);
      dx = -A.ldlt().solve(g);
      if (!dx.allFinite()) {
        lambda *= 10.0;
        continue;
      }
      p_new = apply_step(p, dx);
      // Constrained to the positive definite region (an ellipsoid, never a hyperboloid): a step
      // that leaves it is rejected like one that raises the cost.
      if (!sphere && SymFromParams(p_new).llt().info() != Eigen::Success) {
        lambda *= 10.0;
        continue;
      }
      evaluate(p_new, &e_new, &J_new);
      const double cost_new = e_new.squaredNorm();
      if (std::isfinite(cost_new) && cost_new <= cost) {
        accepted = true;
        const double rel_decrease = (cost - cost_new) / std::max(cost, 1e-300);
        const double rel_step = dx.norm() / (p.norm() + 1e-300);
        p = p_new;
        cost = cost_new;
        lambda = std::max(lambda / 10.0, 1e-12);
        e.swap(e_new);
        J.swap(J_new);
        normal(J, e, &JtJ9, &Jte9);
        if (rel_decrease < o.function_tolerance || rel_step < o.parameter_tolerance || cost == 0.0) {
          r.converged = true;
        }
      } else {
        lambda *= 10.0;
      }
    }
    if (!accepted) {
      // No step lowers the cost: we are at a minimum to machine precision.
      r.converged = true;
    }
    if (r.converged) break;
  }
  if (r.iterations > o.max_iterations) r.iterations = o.max_iterations;
  reduce(JtJ9, Jte9, &JtJ, &g);
  r.condition_number = ScaledConditionNumber(JtJ);
  *params = p;
  if (!p.allFinite()) {
    r.status = Status::Numerical("ellipsoid refinement produced non-finite parameters");
  } else if (!r.converged) {
    r.status = Status::Numerical(Format("ellipsoid refinement did not converge in %d iterations", o.max_iterations));
  }
  return r;
}

GateCriterion Criterion(const std::string& name, double value, double lo, double hi) {
  GateCriterion c;
  c.name = name;
  c.value = value;
  c.min = lo;
  c.max = hi;
  if (!std::isfinite(value)) {
    c.pass = false;
    c.failed_bound = "finite";
  } else if (value < lo) {
    c.failed_bound = "min";
  } else if (value > hi) {
    c.failed_bound = "max";
  } else {
    c.pass = true;
  }
  return c;
}

void EvaluateGate(const EllipsoidFitOptions& o, EllipsoidFit* f) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  FitGate& g = f->gate;
  g.criteria.clear();
  g.criteria.push_back(Criterion("radius_uT", f->radius_uT, o.min_radius_uT, o.max_radius_uT));
  const char* axes[3] = {"x", "y", "z"};
  double max_off = 0.0;
  for (int i = 0; i < 3; ++i) {
    g.criteria.push_back(Criterion(std::string("soft_iron_diag_") + axes[i], f->soft_iron(i, i), o.min_diagonal, o.max_diagonal));
    for (int j = i + 1; j < 3; ++j) max_off = std::max(max_off, std::abs(f->soft_iron(i, j)));
  }
  g.criteria.push_back(Criterion("soft_iron_offdiag_abs_max", max_off, -kInf, o.max_off_diagonal));
  g.criteria.push_back(Criterion("rms_residual_uT", f->rms_residual_uT, -kInf, o.max_rms_residual_uT));
  g.criteria.push_back(Criterion("condition_number", f->condition_number, -kInf, o.max_condition_number));
  GateCriterion cov = Criterion("coverage", f->coverage_fraction, o.min_coverage_fraction, kInf);
  if (!cov.pass && o.planes_present >= o.min_planes_for_coverage) {
    cov.pass = true;
    cov.failed_bound.clear();
    cov.note = Format("passes by rig planes: %d", o.planes_present);
  }
  g.criteria.push_back(cov);
  g.accepted = std::all_of(g.criteria.begin(), g.criteria.end(), [](const GateCriterion& c) { return c.pass; });
}

void FinishFit(const std::vector<Vector3d>& H, const EllipsoidFitOptions& o, EllipsoidFit* f) {
  std::vector<Vector3d> corrected;
  corrected.reserve(H.size());
  double ss = 0.0, sw = 0.0, mx = 0.0;
  for (size_t i = 0; i < H.size(); ++i) {
    const Vector3d c = f->Correct(H[i]);
    const double w = o.weights.empty() ? 1.0 : o.weights[i];
    const double e = c.norm() - f->radius_uT;
    // Weighted (robust fits): a down-weighted sample counts neither in the RMS nor in coverage.
    ss += w * e * e;
    sw += w;
    if (w > 0.5) {
      corrected.push_back(c);
      mx = std::max(mx, std::abs(e));
    }
  }
  f->rms_residual_uT = sw > 0.0 ? std::sqrt(ss / sw) : 0.0;
  f->max_residual_uT = mx;
  f->coverage_fraction = DirectionCoverage(corrected, o.coverage_bins);
  EvaluateGate(o, f);
}

}  // namespace

Status EllipsoidFitOptions::IsValid() const {
  if (min_samples < 10) return Status::BadInput("min_samples: must be >= 10 (9 parameters)");
  if (max_iterations < 1) return Status::BadInput("max_iterations: must be >= 1");
  if (!(function_tolerance >= 0.0) || !(parameter_tolerance >= 0.0)) return Status::BadInput("tolerances: must be >= 0");
  if (!(planarity_tolerance > 0.0 && planarity_tolerance < 1.0)) return Status::BadInput("planarity_tolerance: must be in (0, 1)");
  if (!(min_radius_uT >= 0.0 && max_radius_uT > min_radius_uT)) return Status::BadInput("radius bounds: need 0 <= min < max");
  if (!(min_diagonal > 0.0 && max_diagonal > min_diagonal)) return Status::BadInput("diagonal bounds: need 0 < min < max");
  if (!(max_off_diagonal >= 0.0)) return Status::BadInput("max_off_diagonal: must be >= 0");
  if (!(max_rms_residual_uT > 0.0)) return Status::BadInput("max_rms_residual_uT: must be > 0");
  if (!(max_condition_number > 1.0)) return Status::BadInput("max_condition_number: must be > 1");
  if (coverage_bins < 4) return Status::BadInput("coverage_bins: must be >= 4");
  if (!(min_coverage_fraction >= 0.0 && min_coverage_fraction <= 1.0)) return Status::BadInput("min_coverage_fraction: must be in [0, 1]");
  if (planes_present < 0 || min_planes_for_coverage < 1) return Status::BadInput("planes: counts must be >= 0 / >= 1");
  return Status::Ok();
}

const GateCriterion* FitGate::Find(const std::string& name) const {
  for (const auto& c : criteria) {
    if (c.name == name) return &c;
  }
  return nullptr;
}

std::string FitGate::Failures() const {
  std::string out;
  for (const auto& c : criteria) {
    if (c.pass) continue;
    if (!out.empty()) out += "; ";
    if (c.failed_bound == "min") {
      out += Format("%s = %.6g below min %.6g", c.name.c_str(), c.value, c.min);
    } else if (c.failed_bound == "max") {
      out += Format("%s = %.6g above max %.6g", c.name.c_str(), c.value, c.max);
    } else {
      out += c.name + " = " + ShortestDouble(c.value) + " is not finite";
    }
  }
  return out;
}

double DirectionCoverage(const std::vector<Vector3d>& v, int bins) {
  if (bins < 1 || v.empty()) return 0.0;
  std::vector<Vector3d> centres(static_cast<size_t>(bins));
  std::vector<double> centre_rho(static_cast<size_t>(bins));
  for (int k = 0; k < bins; ++k) {
    const double z = 1.0 - (2.0 * k + 1.0) / bins;
    const double rho = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = kGoldenAngle_rad * k;
    centres[static_cast<size_t>(k)] = Vector3d(rho * std::cos(phi), rho * std::sin(phi), z);
    centre_rho[static_cast<size_t>(k)] = rho;
  }
  std::vector<bool> hit(static_cast<size_t>(bins), false);
  // The bin of u is the centre of largest c·u (the first one on ties). Centres are sorted by
  // polar angle θ_k (z falls with k) and c_k·u ≤ cos(θ_k − θ_u) = z_k u_z + ρ_k ρ_u, a bound that
  // falls monotonically on either side of u's polar angle: search outward from the centre nearest
  // in z and stop each way once the bound is below the best dot (by a margin far above rounding).
  // Same bins as comparing u with every centre, at a fraction of the cost.
  constexpr double kMargin = 1e-12;
  const int last = bins - 1;
  for (const auto& x : v) {
    const double nx = x.norm();
    if (!(nx > 0.0)) continue;
    const Vector3d u = x / nx;
    size_t best = 0;
    double best_dot = -2.0;
    auto consider = [&](size_t k) {
      const double d = centres[k].dot(u);
      if (d > best_dot || (d == best_dot && k < best)) {
        best_dot = d;
        best = k;
      }
    };
    if (!u.allFinite()) {  // (all dots NaN: bin 0, as a full scan gives)
      for (size_t k = 0; k < centres.size(); ++k) consider(k);
      hit[best] = true;
      continue;
    }
    const double rho_u = std::sqrt(std::max(0.0, 1.0 - u.z() * u.z()));
    // The bound falls monotonically once θ_k is past θ_u (z_k ≤ u_z going up in k, z_k ≥ u_z going
    // down); before that every centre is compared.
    auto beaten = [&](int k) {
      const size_t i = static_cast<size_t>(k);
      return centres[i].z() * u.z() + centre_rho[i] * rho_u < best_dot - kMargin;
    };
    // Any start is correct (the pruning only needs the side of θ_u); the nearest in z is fastest.
    const int k0 = std::clamp(static_cast<int>(0.5 * (1.0 - u.z()) * bins), 0, last);
    consider(static_cast<size_t>(k0));
    for (int k = k0 + 1; k <= last; ++k) {
      if (centres[static_cast<size_t>(k)].z() <= u.z() && beaten(k)) break;
      consider(static_cast<size_t>(k));
    }
    for (int k = k0 - 1; k >= 0; --k) {
      if (centres[static_cast<size_t>(k)].z() >= u.z() && beaten(k)) break;
      consider(static_cast<size_t>(k));
    }
    hit[best] = true;
  }
  return static_cast<double>(std::count(hit.begin(), hit.end(), true)) / bins;
}

// Common start of every fit: count, validate, centre and scale. False (with f->status set) when
// the samples cannot be fitted.
static bool PrepareFit(const std::vector<Vector3d>& H, const EllipsoidFitOptions& o, EllipsoidFit* f, Vector3d* mean,
                       double* scale) {
  f->num_samples = static_cast<int>(H.size());
  f->status = CheckSamples(H, o);
  if (!f->status.ok()) return false;
  CentreAndScale(H, mean, scale);
  if (!(*scale > 0.0)) {
    f->status = Status::BadInput("all samples are identical");
    return false;
  }
  return true;
}

EllipsoidFit FitEllipsoid(const std::vector<Vector3d>& H, const EllipsoidFitOptions& o) {
  EllipsoidFit f;
  Vector3d mean;
  double scale = 0.0;
  if (!PrepareFit(H, o, &f, &mean, &scale)) return f;
  const double spread = SpreadRatio(H, mean);
  if (spread < o.planarity_tolerance) {
    f.status = Status::BadInput(Format(
        "samples lie in one plane (spread ratio %.3g): rotate the vehicle about more than one axis", spread));
    return f;
  }
  std::vector<Vector3d> xn;
  xn.reserve(H.size());
  for (const auto& h : H) xn.emplace_back((h - mean) / scale);
  Vector3d beta_n;
  Matrix3d M_n;
  f.status = AlgebraicEllipsoid(xn, o.weights, &beta_n, &M_n);
  if (!f.status.ok()) return f;
  // Back to µT: M_n (x_n − β_n) = (M_n / s)(H − (μ + s β_n)).
  Eigen::Matrix<double, 9, 1> p;
  const Matrix3d M0 = M_n / scale;
  const Vector3d beta0 = mean + scale * beta_n;
  p << M0(0, 0), M0(1, 1), M0(2, 2), M0(0, 1), M0(0, 2), M0(1, 2), beta0;
  const LmResult lm = RefineLm(H, o, /*sphere=*/false, &p);
  f.iterations = lm.iterations;
  f.converged = lm.converged;
  f.condition_number = lm.condition_number;
  if (!lm.status.ok()) {
    f.status = lm.status;
    return f;
  }
  const Matrix3d M = SymFromParams(p);
  Eigen::SelfAdjointEigenSolver<Matrix3d> es(M, Eigen::EigenvaluesOnly);  // (same values, no vectors)
  if (!(es.eigenvalues().minCoeff() > 0.0)) {
    f.status = Status::Numerical("ellipsoid refinement left the positive-definite region");
    return f;
  }
  // M = K⁻¹ / r and det K = 1 → r³ = det(M⁻¹)·... : K_unit = M⁻¹, s = cbrt(det K_unit), K = K_unit / s, r = s.
  const Matrix3d K_unit = M.inverse();
  const double s = std::cbrt(K_unit.determinant());
  f.soft_iron = K_unit / s;
  f.soft_iron_inv = M * s;
  f.radius_uT = s;
  f.hard_iron_uT = p.tail<3>();
  FinishFit(H, o, &f);
  return f;
}

EllipsoidFit FitSphere(const std::vector<Vector3d>& H, const EllipsoidFitOptions& o) {
  EllipsoidFit f;
  Vector3d mean;
  double scale = 0.0;
  if (!PrepareFit(H, o, &f, &mean, &scale)) return f;
  // ‖x‖² = 2 cᵀx + (r² − ‖c‖²), on centred, scaled data.
  const Eigen::Index n = static_cast<Eigen::Index>(H.size());
  Eigen::MatrixXd A(n, 4);
  Eigen::VectorXd b(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vector3d x = (H[i] - mean) / scale;
    A.row(i) << 2 * x(0), 2 * x(1), 2 * x(2), 1.0;
    b(i) = x.squaredNorm();
    if (!o.weights.empty()) {
      const double sw = std::sqrt(o.weights[static_cast<size_t>(i)]);
      A.row(i) *= sw;
      b(i) *= sw;
    }
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const auto& sv = svd.singularValues();
  if (!(sv(3) > 1e-9 * sv(0))) {
    f.status = Status::BadInput("samples do not determine a sphere (degenerate geometry)");
    return f;
  }
  const Eigen::Vector4d sol = svd.solve(b);
  const Vector3d c_n = sol.head<3>();
  const double r2 = sol(3) + c_n.squaredNorm();
  if (!(r2 > 0.0)) {
    f.status = Status::Numerical("sphere fit: negative squared radius");
    return f;
  }
  Eigen::Matrix<double, 9, 1> p;
  const double m0 = 1.0 / (std::sqrt(r2) * scale);
  const Vector3d beta0 = mean + scale * c_n;
  p << m0, m0, m0, 0, 0, 0, beta0;
  const LmResult lm = RefineLm(H, o, /*sphere=*/true, &p);
  f.iterations = lm.iterations;
  f.converged = lm.converged;
  f.condition_number = lm.condition_number;
  if (!lm.status.ok()) {
    f.status = lm.status;
    return f;
  }
  if (!(p(0) > 0.0)) {
    f.status = Status::Numerical("sphere fit: non-positive radius");
    return f;
  }
  f.soft_iron.setIdentity();
  f.soft_iron_inv.setIdentity();
  f.radius_uT = 1.0 / p(0);
  f.hard_iron_uT = p.tail<3>();
  FinishFit(H, o, &f);
  return f;
}

EllipsoidFit FitCircle(const std::vector<Vector3d>& H, const Vector3d& normal, const EllipsoidFitOptions& o) {
  EllipsoidFit f;
  if (!(normal.norm() > 0.0) || !normal.allFinite()) {
    f.status = Status::BadInput("circle fit: the plane's normal must be a non-zero vector");
    return f;
  }
  // The samples projected onto the plane: what a spin about `normal` determines.
  const Vector3d nz = normal.normalized();
  std::vector<Vector3d> P;
  P.reserve(H.size());
  for (const auto& h : H) P.push_back(ProjectOntoPlane(h, nz));
  Vector3d mean;
  double scale = 0.0;
  if (!PrepareFit(P, o, &f, &mean, &scale)) return f;
  // Frame with z' along the normal: the projected samples have z' = n·mean, dropped.
  const Vector3d ax = (std::abs(nz.x()) < 0.9 ? Vector3d::UnitX() : Vector3d::UnitY()).cross(nz).normalized();
  Matrix3d R;
  R.col(0) = ax;
  R.col(1) = nz.cross(ax);
  R.col(2) = nz;
  std::vector<Vector3d> Pr;
  Pr.reserve(P.size());
  for (const auto& p : P) {
    const Vector3d q = R.transpose() * (p - mean) / scale;
    Pr.emplace_back(q(0), q(1), 0.0);
  }
  // Kåsa: x'² + y'² = 2 cx x' + 2 cy y' + (ρ² − cx² − cy²), on centred, scaled data.
  const Eigen::Index n = static_cast<Eigen::Index>(P.size());
  Eigen::MatrixXd A(n, 3);
  Eigen::VectorXd b(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Vector3d& x = Pr[static_cast<size_t>(i)];
    const double sw = o.weights.empty() ? 1.0 : std::sqrt(o.weights[static_cast<size_t>(i)]);
    A.row(i) << 2 * x(0) * sw, 2 * x(1) * sw, sw;
    b(i) = x.squaredNorm() * sw;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinU | Eigen::ComputeThinV);
  if (!(svd.singularValues()(2) > 1e-9 * svd.singularValues()(0))) {
    f.status = Status::BadInput("samples do not determine a circle in the plane (degenerate geometry)");
    return f;
  }
  const Eigen::Vector3d sol = svd.solve(b);
  const double r2 = sol(2) + sol(0) * sol(0) + sol(1) * sol(1);
  if (!(r2 > 0.0)) {
    f.status = Status::Numerical("circle fit: negative squared radius");
    return f;
  }
  for (auto& x : Pr) x *= scale;
  // Geometric refinement: the planar sphere LM on z' = 0 points is the circle ‖(x', y') − c‖ = ρ.
  Eigen::Matrix<double, 9, 1> p;
  const double m0 = 1.0 / (std::sqrt(r2) * scale);
  p << m0, m0, m0, 0, 0, 0, sol(0) * scale, sol(1) * scale, 0.0;
  const LmResult lm = RefineLm(Pr, o, /*sphere=*/true, &p, /*planar=*/true);
  f.iterations = lm.iterations;
  f.converged = lm.converged;
  f.condition_number = lm.condition_number;
  if (!lm.status.ok() || !(p(0) > 0.0)) {
    f.status = lm.status.ok() ? Status::Numerical("circle fit: non-positive radius") : lm.status;
    return f;
  }
  f.soft_iron.setIdentity();
  f.soft_iron_inv.setIdentity();
  f.radius_uT = 1.0 / p(0);
  // The centre in the plane (no component along the normal).
  f.hard_iron_uT = ProjectOntoPlane(mean, nz) + R * Vector3d(p(6), p(7), 0.0);
  FinishFit(P, o, &f);
  return f;
}

}  // namespace hexsim::magnetics
