#include "hexsim/magnetics/flight_fit.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "hexsim/common/format.h"
#include "hexsim/common/statistics.h"

namespace hexsim::magnetics {
namespace {

using Eigen::Matrix3d;
using Eigen::MatrixXd;
using Eigen::Vector3d;
using Eigen::VectorXd;

// The regressor of the disturbance term at a sample (NaN: unknown).
double Regressor(const FlightFitSample& s, FlightTermForm form) {
  return form == FlightTermForm::kCurrent ? s.current_A : s.throttle;
}

// Rows of sample i for θ = [B_N, c, d]: y = Rᵀ·B_N + c + d·r (at most 9 columns: on the stack).
using DesignRows = Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, kFlightFitUnknowns>;
DesignRows Design(const FlightFitSample& s, double r, int p) {
  DesignRows X = DesignRows::Zero(3, p);
  X.block<3, 3>(0, 0) = s.R_NB.transpose();
  X.block<3, 3>(0, 3) = Matrix3d::Identity();
  if (p == 9) X.block<3, 3>(0, 6) = r * Matrix3d::Identity();
  return X;
}

// The fit's data: the samples and the regressor's members (one when the alignment is not profiled).
struct Problem {
  const std::vector<FlightFitSample>& s;
  std::vector<std::vector<double>> r;  // r[m][i]: sample i's regressor in member m (0 where p = 6)
  std::vector<double> shift_s;         // member m's shift
  int p = 6;
  const FlightFitOptions& o;
};

struct Solve {
  VectorXd theta;
  MatrixXd N_inv;          // inverse of the weighted normal matrix (prior included)
  double objective = 0.0;  // −θᵀ·rhs: the weighted SSE with the prior, less a part no member changes
  size_t member = 0;
};

// Weighted least squares of member m with the Gaussian prior on B_N; `use[i]` selects the samples.
Result<Solve> SolveWeighted(const Problem& pr, size_t m, const std::vector<char>& use, double sigma_m) {
  const int p = pr.p;
  MatrixXd N = MatrixXd::Zero(p, p);
  VectorXd rhs = VectorXd::Zero(p);
  const double wm = 1.0 / (sigma_m * sigma_m), wp = 1.0 / (pr.o.prior_sigma_uT * pr.o.prior_sigma_uT);
  for (size_t i = 0; i < pr.s.size(); ++i) {
    if (use[i] == 0) continue;
    const DesignRows X = Design(pr.s[i], pr.r[m][i], p);
    N.noalias() += wm * X.transpose() * X;
    rhs.noalias() += wm * X.transpose() * pr.s[i].y_uT;
  }
  if (!pr.o.field_free) {
    N.block<3, 3>(0, 0) += wp * Matrix3d::Identity();
    rhs.head<3>() += wp * pr.o.prior_field_N_uT;
  }
  // Scale-invariant check of the conditioning (unit diagonal).
  const VectorXd d = N.diagonal().cwiseSqrt().cwiseInverse();
  const MatrixXd Nn = d.asDiagonal() * N * d.asDiagonal();
  Eigen::LDLT<MatrixXd> ldlt(Nn);
  if (ldlt.info() != Eigen::Success || !(ldlt.rcond() > 1e-12)) {
    return Status::Numerical("flight fit: the offset and the disturbance term cannot be separated (singular normal matrix)");
  }
  Solve out;
  out.N_inv = d.asDiagonal() * ldlt.solve(MatrixXd::Identity(p, p)) * d.asDiagonal();
  out.theta = out.N_inv * rhs;
  out.objective = -out.theta.dot(rhs);
  out.member = m;
  return out;
}

// The member whose fit has the smallest objective on the samples `use` selects (the profile of the
// regressor's shift); a member whose system is singular is passed over.
Result<Solve> SolveBest(const Problem& pr, const std::vector<char>& use, double sigma_m) {
  Result<Solve> best = Status::Numerical("flight fit: no regressor member");
  for (size_t m = 0; m < pr.r.size(); ++m) {
    Result<Solve> sol = SolveWeighted(pr, m, use, sigma_m);
    if (!sol.ok()) {
      if (!best.ok()) best = sol.status();
      continue;
    }
    if (!best.ok() || sol->objective < best->objective) best = std::move(sol);
  }
  return best;
}

double RmsPerAxis(const Problem& pr, size_t m, const std::vector<char>& use, const VectorXd& theta,
                  std::vector<double>* norms = nullptr) {
  double ss = 0.0;
  int n = 0;
  if (norms != nullptr) norms->assign(pr.s.size(), 0.0);
  for (size_t i = 0; i < pr.s.size(); ++i) {
    if (use[i] == 0) continue;
    const Vector3d e = pr.s[i].y_uT - Design(pr.s[i], pr.r[m][i], pr.p) * theta;
    if (norms != nullptr) (*norms)[i] = e.norm();
    ss += e.squaredNorm();
    n += 3;
  }
  return n > 0 ? std::sqrt(ss / n) : 0.0;
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<size_t>(k)];
}

// Decides whether d is fitted (p = 9) and which samples carry it (those with a value in every
// member: the members are compared on the same samples); fills the span (the smallest member's) and
// the note. Without d the members collapse to the first, its values zero.
int ChooseTerm(const FlightFitOptions& o, Problem* pr, std::vector<char>* use, FlightFit* fit) {
  const size_t n = pr->s.size();
  std::vector<char> known(n, 1);
  for (const std::vector<double>& r : pr->r) {
    for (size_t i = 0; i < n; ++i) known[i] = known[i] != 0 && std::isfinite(r[i]) ? 1 : 0;
  }
  const auto n_known = static_cast<size_t>(std::count(known.begin(), known.end(), 1));
  fit->regressor_span = std::numeric_limits<double>::infinity();
  for (const std::vector<double>& r : pr->r) {
    std::vector<double> v;
    v.reserve(n_known);
    for (size_t i = 0; i < n; ++i) {
      if (known[i] != 0) v.push_back(r[i]);
    }
    fit->regressor_span = std::min(fit->regressor_span, v.empty() ? 0.0 : Quantile(v, 0.95) - Quantile(v, 0.05));
  }
  const bool current = o.form == FlightTermForm::kCurrent;
  const char* what = current ? "current" : "throttle";
  const double need = current ? o.min_current_span_A : o.min_throttle_span;
  if (static_cast<int>(n_known) < o.min_samples) {
    fit->term_note = Format("%s known at %zu samples, needs %d", what, n_known, o.min_samples);
  } else if (fit->regressor_span < need) {
    fit->term_note = current ? Format("the current spans %.1f A (5-95 %%), needs %.1f A to separate its field from the offset",
                                      fit->regressor_span, need)
                             : Format("the throttle spans %.3f (5-95 %%), needs %.3f to separate its field from the offset",
                                      fit->regressor_span, need);
  } else {
    for (size_t i = 0; i < n; ++i) {
      if (known[i] == 0) {
        (*use)[i] = 0;
        ++fit->without_regressor;
      }
    }
    return 9;
  }
  pr->r.resize(1);
  pr->shift_s.resize(1);
  pr->r[0].assign(n, 0.0);
  return 6;
}

// Drops samples whose residual norm is beyond outlier_sigma robust σ of the rest.
void DropOutliers(const std::vector<double>& norms, double outlier_sigma, std::vector<char>* use, int* outliers) {
  std::vector<double> kept;
  for (size_t i = 0; i < norms.size(); ++i) {
    if ((*use)[i] != 0) kept.push_back(norms[i]);
  }
  const double med = Quantile(kept, 0.5);
  std::vector<double> dev;
  dev.reserve(kept.size());
  for (double v : kept) dev.push_back(std::fabs(v - med));
  const double robust_sigma = 1.4826 * Quantile(dev, 0.5);
  for (size_t i = 0; i < norms.size(); ++i) {
    if ((*use)[i] != 0 && robust_sigma > 0.0 && norms[i] > med + outlier_sigma * robust_sigma) {
      (*use)[i] = 0;
      ++*outliers;
    }
  }
}

// The delete-one-block jackknife covariance, (G−1)/G·Σ_g (θ₋g − θ̄)(θ₋g − θ̄)ᵀ. The cluster sandwich
// N⁻¹(Σ s_g s_gᵀ)N⁻¹ was tried first: with 10-20 blocks in which the current's range differs block
// by block (high-leverage blocks) it rejected d = 0 in 12-16 % of synthetic flights without a
// current field at a nominal 5 %; the jackknife is the conservative (CR3-like) form of it.
Result<MatrixXd> JackknifeCov(const Problem& pr, const std::vector<char>& use, double sigma_m, FlightFit* fit) {
  const int p = pr.p;
  const size_t members = pr.r.size();
  const double t0 = pr.s.front().t_s;
  const double wm = 1.0 / (sigma_m * sigma_m);
  struct Block {
    MatrixXd N;
    VectorXd r;
  };
  // blocks[g][m]: block g's normal equations in member m.
  std::map<long, std::vector<Block>> blocks;
  for (size_t i = 0; i < pr.s.size(); ++i) {
    if (use[i] == 0) continue;
    const auto g = static_cast<long>(std::floor((pr.s[i].t_s - t0) / pr.o.block_s));
    auto it = blocks.find(g);
    if (it == blocks.end()) it = blocks.emplace(g, std::vector<Block>(members, Block{MatrixXd::Zero(p, p), VectorXd::Zero(p)})).first;
    for (size_t m = 0; m < members; ++m) {
      const DesignRows X = Design(pr.s[i], pr.r[m][i], p);
      it->second[m].N.noalias() += wm * X.transpose() * X;
      it->second[m].r.noalias() += wm * X.transpose() * pr.s[i].y_uT;
    }
  }
  fit->blocks = static_cast<int>(blocks.size());
  if (fit->samples_used < pr.o.min_samples || fit->blocks < pr.o.min_blocks) {
    return Status::BadInput(Format("flight fit: %d samples in %d blocks of %.0f s after outliers, needs %d samples in %d blocks",
                                   fit->samples_used, fit->blocks, pr.o.block_s, pr.o.min_samples, pr.o.min_blocks));
  }
  std::vector<MatrixXd> N(members, MatrixXd::Zero(p, p));
  std::vector<VectorXd> rhs(members, VectorXd::Zero(p));
  const double wp = 1.0 / (pr.o.prior_sigma_uT * pr.o.prior_sigma_uT);
  for (size_t m = 0; m < members; ++m) {
    for (const auto& [g, b] : blocks) {
      N[m] += b[m].N;
      rhs[m] += b[m].r;
    }
    if (!pr.o.field_free) {
      N[m].block<3, 3>(0, 0) += wp * Matrix3d::Identity();
      rhs[m].head<3>() += wp * pr.o.prior_field_N_uT;
    }
  }
  // Each delete-one-block fit takes the member with the smallest objective on its own blocks.
  std::vector<VectorXd> leave_out;
  VectorXd mean = VectorXd::Zero(p);
  fit->regressor_shift_range_s[0] = std::numeric_limits<double>::infinity();
  fit->regressor_shift_range_s[1] = -std::numeric_limits<double>::infinity();
  for (const auto& [g, b] : blocks) {
    VectorXd best;
    double best_objective = 0.0, best_shift = 0.0;
    for (size_t m = 0; m < members; ++m) {
      const VectorXd r = rhs[m] - b[m].r;
      Eigen::LDLT<MatrixXd> ldlt(N[m] - b[m].N);
      if (ldlt.info() != Eigen::Success) continue;
      VectorXd theta = ldlt.solve(r);
      const double objective = -theta.dot(r);
      if (best.size() == 0 || objective < best_objective) {
        best = std::move(theta);
        best_objective = objective;
        best_shift = pr.shift_s[m];
      }
    }
    if (best.size() == 0) return Status::Numerical("flight fit: a leave-one-block-out system is singular");
    fit->regressor_shift_range_s[0] = std::min(fit->regressor_shift_range_s[0], best_shift);
    fit->regressor_shift_range_s[1] = std::max(fit->regressor_shift_range_s[1], best_shift);
    mean += best;
    leave_out.push_back(std::move(best));
  }
  mean /= static_cast<double>(fit->blocks);
  MatrixXd cov = MatrixXd::Zero(p, p);
  for (const VectorXd& v : leave_out) cov.noalias() += (v - mean) * (v - mean).transpose();
  cov *= static_cast<double>(fit->blocks - 1) / static_cast<double>(fit->blocks);
  return cov;
}

void FillIntervals(const MatrixXd& cov, int p, FlightFit* fit) {
  const double t975 = StudentT975(static_cast<double>(fit->blocks - 1));
  auto half = [&](int k) { return t975 * std::sqrt(std::max(cov(k, k), 0.0)); };
  for (int k = 0; k < 3; ++k) {
    fit->field_ci_half_uT(k) = half(k);
    fit->offset_ci_half_uT(k) = half(3 + k);
  }
  if (p != 9) return;
  fit->term_cov = cov.block<3, 3>(6, 6);
  const TermNorm tn = TermNormOf(fit->term_uT, fit->term_cov, fit->blocks);
  fit->term_ci_half_uT = tn.axis_half;
  fit->term_max_abs_t = tn.max_abs_t;
  fit->term_t_threshold = tn.t_threshold;
  fit->term_resolved = tn.resolved;
  fit->term_norm_ci95[0] = tn.ci95[0];
  fit->term_norm_ci95[1] = tn.ci95[1];
}

// Whether the attitudes differ at all: the free Earth field (field_free) is told from the offset only
// through R_NBᵀ·B_N changing with the attitude. The smallest eigenvalue of the attitudes' spread,
// mean (R − R̄)ᵀ(R − R̄), is zero when every attitude is the same; anything above rounding (1e-9)
// lets the fit try, and the jackknife interval says how well the field was separated.
bool AttitudeVaries(const std::vector<FlightFitSample>& samples) {
  Matrix3d mean = Matrix3d::Zero();
  for (const auto& s : samples) mean += s.R_NB;
  mean /= static_cast<double>(samples.size());
  Matrix3d spread = Matrix3d::Zero();
  for (const auto& s : samples) spread += (s.R_NB - mean).transpose() * (s.R_NB - mean);
  spread /= static_cast<double>(samples.size());
  const Eigen::SelfAdjointEigenSolver<Matrix3d> eig(spread);
  return eig.eigenvalues()(0) > 1e-9;
}

}  // namespace

TermNorm TermNormOf(const Eigen::Vector3d& term, const Eigen::Matrix3d& cov, int blocks) {
  TermNorm out;
  out.norm = term.norm();
  if (blocks < 2) return out;
  const double dof = static_cast<double>(blocks - 1);
  const double t975 = StudentT975(dof);
  out.t_threshold = StudentTQuantile(1.0 - 0.05 / 6.0, dof);
  double axis_low = 0.0;
  bool zero_inside = true;
  for (int k = 0; k < 3; ++k) {
    const double se = std::sqrt(std::max(cov(k, k), 0.0));
    out.axis_half(k) = t975 * se;
    if (se > 0.0) out.max_abs_t = std::max(out.max_abs_t, std::fabs(term(k)) / se);
    zero_inside = zero_inside && std::fabs(term(k)) <= out.axis_half(k);
    axis_low = std::max(axis_low, std::fabs(term(k)) - out.axis_half(k));
  }
  out.resolved = out.max_abs_t >= out.t_threshold;
  double h = 0.0;
  if (out.norm > 0.0) {
    const Vector3d g = term / out.norm;
    h = t975 * std::sqrt(std::max(static_cast<double>(g.transpose() * cov * g), 0.0));
  }
  out.ci95 = {out.resolved && !zero_inside ? std::max({0.0, out.norm - h, axis_low}) : 0.0, out.norm + h};
  return out;
}

const char* FlightTermFormName(FlightTermForm form) { return form == FlightTermForm::kCurrent ? "current" : "throttle"; }
const char* FlightTermUnit(FlightTermForm form) { return form == FlightTermForm::kCurrent ? "uT/A" : "uT/throttle"; }

Eigen::Vector3d FlightFit::Predict(const FlightFitSample& s) const {
  const double r = Regressor(s, form);
  return s.R_NB.transpose() * field_N_uT + offset_y_uT + (term_fitted && std::isfinite(r) ? Vector3d(term_uT * r) : Vector3d::Zero());
}

double FlightFitness_uT(const FlightFit& fit, const std::vector<FlightFitSample>& samples, bool apply_term) {
  const double radius = fit.field_N_uT.norm();
  double ss = 0.0;
  int n = 0;
  for (const FlightFitSample& s : samples) {
    const double r = Regressor(s, fit.form);
    Vector3d c = s.y_uT - fit.offset_y_uT;
    if (apply_term && fit.term_fitted && std::isfinite(r)) c -= fit.term_uT * r;
    const double e = c.norm() - radius;
    ss += e * e;
    ++n;
  }
  return n > 0 ? std::sqrt(ss / n) : 0.0;
}

namespace {

Status CheckInput(const std::vector<FlightFitSample>& samples, const FlightFitOptions& o) {
  for (const auto& s : samples) {
    if (!s.y_uT.allFinite() || !s.R_NB.allFinite() || !std::isfinite(s.t_s)) {
      return Status::BadInput("flight fit: a sample holds a non-finite field, attitude or time");
    }
  }
  if (static_cast<int>(samples.size()) < o.min_samples) {
    return Status::BadInput(Format("flight fit: %zu samples, needs at least %d", samples.size(), o.min_samples));
  }
  if (!o.prior_field_N_uT.allFinite() || !(o.prior_sigma_uT > 0.0) || !(o.block_s > 0.0)) {
    return Status::BadInput("flight fit: prior field, prior sigma and block length must be finite and positive");
  }
  if (o.field_free && !AttitudeVaries(samples)) {
    return Status::BadInput("flight fit: no place and date for the Earth field (no GPS fix) and an attitude that never "
                            "changes: the field cannot be told from the offset");
  }
  return Status::Ok();
}

// The fit of FitFlightCompass and FitFlightCompassProfiled on `pr` (its members filled).
Result<FlightFit> FitMembers(Problem pr) {
  const FlightFitOptions& o = pr.o;
  FlightFit fit;
  fit.form = o.form;
  std::vector<char> use(pr.s.size(), 1);
  pr.p = ChooseTerm(o, &pr, &use, &fit);
  const int p = pr.p;
  fit.regressor_members = static_cast<int>(pr.r.size());
  VectorXd theta0 = VectorXd::Zero(p);
  if (!o.field_free) theta0.head<3>() = o.prior_field_N_uT;
  fit.rms_prior_uT = RmsPerAxis(pr, 0, use, theta0);

  // Pass 1 at a nominal noise, pass 2 at the measured one with outliers dropped, pass 3 final; each
  // on the member whose objective is smallest.
  double sigma_m = 1.0;
  Result<Solve> sol = SolveBest(pr, use, sigma_m);
  if (!sol.ok()) return sol.status();
  std::vector<double> norms;
  sigma_m = std::max(RmsPerAxis(pr, sol->member, use, sol->theta, &norms), 1e-3);
  DropOutliers(norms, o.outlier_sigma, &use, &fit.outliers);
  for (int pass = 0; pass < 2; ++pass) {
    sol = SolveBest(pr, use, sigma_m);
    if (!sol.ok()) return sol.status();
    sigma_m = std::max(RmsPerAxis(pr, sol->member, use, sol->theta), 1e-3);
  }
  const VectorXd& th = sol->theta;
  fit.rms_after_uT = sigma_m;
  fit.samples_used = static_cast<int>(std::count(use.begin(), use.end(), 1));
  fit.used = use;
  fit.field_N_uT = th.segment<3>(0);
  fit.offset_y_uT = th.segment<3>(3);
  fit.regressor_shift_s = pr.shift_s[sol->member];
  fit.regressor_shift_range_s[0] = fit.regressor_shift_range_s[1] = fit.regressor_shift_s;
  if (p == 9) {
    fit.term_fitted = true;
    fit.term_uT = th.segment<3>(6);
    fit.term_norm_uT = fit.term_uT.norm();
  }
  if (!o.intervals) return fit;
  auto cov = JackknifeCov(pr, use, sigma_m, &fit);
  if (!cov.ok()) return cov.status();
  FillIntervals(*cov, p, &fit);
  return fit;
}

}  // namespace

Result<FlightFit> FitFlightCompass(const std::vector<FlightFitSample>& samples, const FlightFitOptions& o) {
  if (Status st = CheckInput(samples, o); !st.ok()) return st;
  Problem pr{samples, {{}}, {0.0}, 6, o};
  pr.r[0].reserve(samples.size());
  for (const auto& s : samples) pr.r[0].push_back(Regressor(s, o.form));
  return FitMembers(std::move(pr));
}

Result<FlightFit> FitFlightCompassProfiled(const std::vector<FlightFitSample>& samples, const RegressorMembers& members,
                                           const FlightFitOptions& o) {
  if (Status st = CheckInput(samples, o); !st.ok()) return st;
  if (members.shift_s.empty() || members.value.size() != members.shift_s.size() ||
      !std::is_sorted(members.shift_s.begin(), members.shift_s.end())) {
    return Status::BadInput("flight fit: the regressor's members need one ascending shift each");
  }
  for (const std::vector<double>& v : members.value) {
    if (v.size() != samples.size()) return Status::BadInput("flight fit: a regressor member does not hold one value per sample");
  }
  return FitMembers(Problem{samples, members.value, members.shift_s, 6, o});
}

}  // namespace hexsim::magnetics
