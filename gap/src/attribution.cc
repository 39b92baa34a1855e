// Which and how much: nested fits over the baseline, blocked CV, block bootstrap, intervals.
#include "attribution.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "replay_util.h"
#include "stats.h"

namespace hexsim::gap::internal {
namespace {

double HeldOutSse(const Block& b, const Eigen::VectorXd& beta) {
  return std::max(0.0, b.s - 2 * beta.dot(b.g) + beta.dot(b.A * beta));
}

// Block index of each sample: G contiguous blocks of (nearly) equal sample count.
std::vector<int> BlockIndex(size_t n, int G) {
  std::vector<int> idx(n);
  for (size_t k = 0; k < n; ++k) idx[k] = static_cast<int>(k * static_cast<size_t>(G) / n);
  return idx;
}

}  // namespace

int BlockCount(const std::vector<double>& t, const DiagnoseOptions& o) {
  const size_t n = t.size();
  if (n < 2) return kMinAnalysisBlocks;
  // The time the samples cover: each sample's step to the next, a gap (held-out blocks between,
  // a dropout) counted as one typical step.
  std::vector<double> dt;
  dt.reserve(n - 1);
  for (size_t k = 1; k < n; ++k) dt.push_back(t[k] - t[k - 1]);
  const double step = std::max(0.0, MedianFinite(dt));
  double covered = step;
  for (double d : dt) covered += (d > 0 && d <= 5.0 * step) ? d : step;
  const double by_time = std::floor(covered / o.min_block_s);
  const double by_samples = std::floor(static_cast<double>(n) / o.min_block_samples);
  const double g = std::min({static_cast<double>(o.blocks), by_time, by_samples});
  return std::max(kMinAnalysisBlocks, static_cast<int>(g));
}

Block SumBlocks(const std::vector<Block>& blocks, const std::vector<double>& w, int p) {
  Block t{Eigen::MatrixXd::Zero(p, p), Eigen::VectorXd::Zero(p), 0, 0};
  for (size_t b = 0; b < blocks.size(); ++b) {
    if (w[b] == 0) continue;
    t.A += w[b] * blocks[b].A;
    t.g += w[b] * blocks[b].g;
    t.s += w[b] * blocks[b].s;
    t.n += w[b] * blocks[b].n;
  }
  return t;
}

namespace {

// Up to this many parameters the sums and their factorisation live on the stack (no allocation per
// solve: the bootstrap and the CV folds solve thousands of small systems); the arithmetic is the
// same as with heap matrices.
constexpr int kSmallP = 24;
using SmallA = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kSmallP, kSmallP>;
using SmallV = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kSmallP, 1>;

// The regularised LDLT solve of Solve, on A and g of any storage.
template <typename MatA, typename VecG>
Fit SolveNormal(const MatA& A, const VecG& g, double s, double n, int p) {
  Fit f;
  f.n = n;
  if (p == 0) {
    f.beta = Eigen::VectorXd();
    f.sse = s;
    f.ok = true;
    return f;
  }
  const double tr = A.trace();
  if (!(tr > 0)) return f;
  using Plain = typename MatA::PlainObject;
  Eigen::LDLT<Plain> ldlt(A + Plain::Identity(p, p) * (1e-12 * tr / p));
  if (ldlt.info() != Eigen::Success) return f;
  f.beta = ldlt.solve(g);
  f.sse = std::max(0.0, s - f.beta.dot(g));
  f.ok = f.beta.allFinite();
  return f;
}

}  // namespace

Fit SolveSums(const Block& sums, int p) { return SolveNormal(sums.A, sums.g, sums.s, sums.n, p); }

namespace {

// The baseline's normal equations under one set of block weights, factorised once and shared by
// every member's NestedSse (the bootstrap solves each member over the same baseline sums).
struct BaseFactor {
  Eigen::LDLT<SmallA> ldlt;
  SmallV g;
  double sse = 0;
  bool ok = false;
};

BaseFactor FactorBase(const Block& base_sums, int p0) {
  BaseFactor bf;
  const double tr = base_sums.A.trace();
  if (p0 == 0 || p0 > kSmallP || !(tr > 0)) return bf;
  bf.ldlt.compute(SmallA(base_sums.A) + SmallA::Identity(p0, p0) * (1e-12 * tr / p0));
  if (bf.ldlt.info() != Eigen::Success) return bf;
  bf.g = base_sums.g;
  const SmallV beta = bf.ldlt.solve(bf.g);
  bf.sse = std::max(0.0, base_sums.s - beta.dot(bf.g));
  bf.ok = beta.allFinite();
  return bf;
}

// The in-sample SSE of baseline + candidate under weights w, by the Schur complement of the shared
// baseline factorisation: with Z = A_bb⁻¹·A_bc, S = A_cc − A_cbᵀ·Z and g̃ = g_c − Zᵀ·g_b, the
// candidate's part solves S·β_c = g̃ and SSE = SSE_baseline − g̃ᵀ·β_c (the same least squares as
// SolveNested, whose baseline rows are these sums). False where it cannot be solved so.
bool NestedSse(const std::vector<Block>& blocks, const std::vector<double>& w, int p0, int pc, const BaseFactor& bf,
               double* sse) {
  if (!bf.ok || pc <= 0 || pc > kSmallP) return false;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kSmallP, kSmallP> Abc(p0, pc);
  SmallA Acc(pc, pc);
  SmallV gc(pc);
  Abc.setZero();
  Acc.setZero();
  gc.setZero();
  for (size_t b = 0; b < blocks.size(); ++b) {
    if (w[b] == 0) continue;
    Abc += w[b] * blocks[b].A.topRightCorner(p0, pc);
    Acc += w[b] * blocks[b].A.bottomRightCorner(pc, pc);
    gc += w[b] * blocks[b].g.tail(pc);
  }
  const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kSmallP, kSmallP> Z = bf.ldlt.solve(Abc);
  SmallA S = Acc - Abc.transpose() * Z;
  const SmallV gt = gc - Z.transpose() * bf.g;
  const double tr = S.trace();
  if (!(tr > 0)) return false;
  S += SmallA::Identity(pc, pc) * (1e-12 * tr / pc);
  const Eigen::LDLT<SmallA> ldlt(S);
  if (ldlt.info() != Eigen::Success) return false;
  const SmallV beta = ldlt.solve(gt);
  if (!beta.allFinite()) return false;
  *sse = std::max(0.0, bf.sse - gt.dot(beta));
  return true;
}

}  // namespace

Fit Solve(const std::vector<Block>& blocks, const std::vector<double>& w, int p) { return SolveSums(SumBlocks(blocks, w, p), p); }

Eigen::MatrixXd JackknifeCov(const Evaluated& e) {
  const int p = e.p();
  const int G = static_cast<int>(e.blocks.size());
  if (p == 0 || G < 3 || !e.full.ok) return e.cov;
  const Block all = SumBlocks(e.blocks, std::vector<double>(static_cast<size_t>(G), 1.0), p);
  Eigen::MatrixXd V = Eigen::MatrixXd::Zero(p, p);
  for (const Block& b : e.blocks) {
    const Fit f = SolveNormal(Eigen::MatrixXd(all.A - b.A), Eigen::VectorXd(all.g - b.g), all.s - b.s, all.n - b.n, p);
    if (!f.ok) return e.cov;
    const Eigen::VectorXd d = f.beta - e.full.beta;
    V += d * d.transpose();
  }
  return V * (static_cast<double>(G - 1) / G);
}

Fit SolveNested(const std::vector<Block>& blocks, const std::vector<double>& w, int p, const Block& base_sums) {
  const int p0 = static_cast<int>(base_sums.g.size());
  const int pc = p - p0;
  if (pc <= 0) return SolveSums(base_sums, p0);
  auto sum = [&](auto& A, auto& g) {
    A.topLeftCorner(p0, p0) = base_sums.A;
    A.rightCols(pc).setZero();
    A.bottomLeftCorner(pc, p0).setZero();
    g.head(p0) = base_sums.g;
    g.tail(pc).setZero();
    for (size_t b = 0; b < blocks.size(); ++b) {
      if (w[b] == 0) continue;
      A.rightCols(pc) += w[b] * blocks[b].A.rightCols(pc);
      A.bottomLeftCorner(pc, p0) += w[b] * blocks[b].A.bottomLeftCorner(pc, p0);
      g.tail(pc) += w[b] * blocks[b].g.tail(pc);
    }
  };
  if (p <= kSmallP) {
    SmallA A(p, p);
    SmallV g(p);
    sum(A, g);
    return SolveNormal(A, g, base_sums.s, base_sums.n, p);
  }
  Eigen::MatrixXd A(p, p);
  Eigen::VectorXd g(p);
  sum(A, g);
  return SolveNormal(A, g, base_sums.s, base_sums.n, p);
}

int Dof(const Candidate& c) {
  const bool exponent = (c.grid_name == "exponent" && c.grid_value != 1.0) || (c.grid2_name == "exponent" && c.grid2_value != 1.0);
  const bool lag = c.grid_name == "tau_s" && c.grid_value != 0.0;
  return c.p() + (exponent ? 1 : 0) + (lag ? 1 : 0);
}

Candidate Join(const Candidate& a, const Candidate& b) {
  Candidate j = a;
  j.effect = a.effect + "+" + b.effect;
  j.X_joint.clear();  // the joint candidate's columns are X
  j.names.insert(j.names.end(), b.names.begin(), b.names.end());
  j.scale.insert(j.scale.end(), b.scale.begin(), b.scale.end());
  for (size_t k = 0; k < j.X.size(); ++k) {
    Mat3X x(3, a.p() + b.p());
    x << a.X[k], (b.X_joint.size() == b.X.size() ? b.X_joint[k] : b.X[k]);
    j.X[k] = x;
  }
  return j;
}

// Cluster-robust Wald test that the parameters `idx` are zero: Hotelling's T² over G blocks,
// F = T²·(G − q)/(q·(G − 1)) ~ F(q, G − q). Blocks are long against the residual's correlation
// time, so the test stays valid when the residual is coloured, unlike an F test that assumes white
// noise.
double WaldP(const Eigen::VectorXd& beta, const Eigen::MatrixXd& cov, const std::vector<int>& idx, int G) {
  const int q = static_cast<int>(idx.size());
  if (q == 0) return 1.0;
  Eigen::VectorXd b(q);
  Eigen::MatrixXd V(q, q);
  for (int i = 0; i < q; ++i) {
    b[i] = beta[idx[i]];
    for (int j = 0; j < q; ++j) V(i, j) = cov(idx[i], idx[j]);
  }
  const double tr = V.trace();
  if (!(tr > 0) || !b.allFinite()) return 1.0;
  Eigen::LDLT<Eigen::MatrixXd> ldlt(V + Eigen::MatrixXd::Identity(q, q) * (1e-9 * tr / q));
  if (ldlt.info() != Eigen::Success) return 1.0;
  // The cluster-robust covariance is a sum over G blocks: its rank is at most G − 1, so q ≥ G
  // parameters cannot be tested at all (the small ridge above would make any t² huge: p = 0 for an
  // effect the data cannot show). Not testable: p = 1.
  if (G - q < 1) return 1.0;
  const double t2 = b.dot(ldlt.solve(b));
  const double f = t2 * static_cast<double>(G - q) / (static_cast<double>(q) * (G - 1));
  return FSf(f, q, G - q);
}

namespace {

// One sample's candidate rows and columns of the normal equations added to block b: the
// baseline-candidate cross terms xbᵀ·xc, the upper triangle of xcᵀ·xc (the caller mirrors it) and
// xcᵀ·y, as plain loops over the three rows (far below the size where Eigen's dynamic-size products pay).
void AddCandidateRows(const Mat3X& xb, const Mat3X& xc, const Vec3& y, int p0, Block* b) {
  const int pc = static_cast<int>(xc.cols());
  double* A = b->A.data();
  const Eigen::Index ld = b->A.outerStride();
  const double* xbd = xb.data();
  for (int j = 0; j < pc; ++j) {
    const double* c = xc.data() + 3 * j;
    double* col = A + (p0 + j) * ld;
    for (int i = 0; i < p0; ++i) col[i] += xbd[3 * i] * c[0] + xbd[3 * i + 1] * c[1] + xbd[3 * i + 2] * c[2];
    for (int i = 0; i <= j; ++i) {
      const double* a = xc.data() + 3 * i;
      col[p0 + i] += a[0] * c[0] + a[1] * c[1] + a[2] * c[2];
    }
    b->g[p0 + j] += c[0] * y[0] + c[1] * y[1] + c[2] * y[2];
  }
}

}  // namespace

std::vector<int> Range(int a, int b) {
  std::vector<int> v;
  for (int i = a; i < b; ++i) v.push_back(i);
  return v;
}

Analyzer::Analyzer(const ChannelData& ch, const DiagnoseOptions& o) : ch_(ch) {
  n_ = ch.t.size();
  G_ = BlockCount(ch.t, o);
  block_ = BlockIndex(n_, G_);
  y_raw_ = ch.y;
  if (ch.baseline.p() > 0 && ch.baseline.X.size() == n_) baseline_ = &ch.baseline;
  y_ = ch.y;
  if (baseline_) {
    base_eval_ = EvaluateX(nullptr);
    y_ = After(base_eval_);
    const int p0 = baseline_->p();
    base_all_ = SumBlocks(base_eval_.blocks, std::vector<double>(static_cast<size_t>(G_), 1.0), p0);
    for (size_t f = 0; f < static_cast<size_t>(G_); f += 2) {
      std::vector<double> wf(static_cast<size_t>(G_), 1.0);
      wf[f] = 0;
      if (f + 1 < wf.size()) wf[f + 1] = 0;
      base_folds_.push_back(SumBlocks(base_eval_.blocks, wf, p0));
    }
  } else if (ch.bias_nuisance) {
    // Inertial and dynamics channels: the nuisance intercept removed when the configured sensor has a bias.
    Vec3 mean = Vec3::Zero();
    for (const auto& v : y_) mean += v;
    mean /= static_cast<double>(std::max<size_t>(1, n_));
    for (auto& v : y_) v -= mean;
  }
  base_.assign(G_, 0.0);
  base_n_.assign(G_, 0.0);
  for (size_t k = 0; k < n_; ++k) {
    base_[block_[k]] += y_[k].squaredNorm();
    base_n_[block_[k]] += 3;
  }
  total_base_ = std::accumulate(base_.begin(), base_.end(), 0.0);
  total_n_ = 3.0 * static_cast<double>(n_);
}

Evaluated Analyzer::Evaluate(const Candidate& c) const { return EvaluateX(&c); }

Evaluated Analyzer::FitOnly(const Candidate& c) const { return EvaluateX(&c, true); }

Evaluated Analyzer::EvaluateX(const Candidate* c, bool full_only) const {
  Evaluated e;
  e.cand = c;
  const int p0 = baseline_ ? baseline_->p() : 0;
  const int pc = c ? c->p() : 0;
  const int p = p0 + pc;
  e.off = p0;
  e.blocks.assign(G_, Block{Eigen::MatrixXd::Zero(p, p), Eigen::VectorXd::Zero(p), 0, 0});
  Mat3X mean_x = Mat3X::Zero(3, pc);
  const bool demean = !baseline_ && ch_.bias_nuisance;
  if (demean && c) {
    for (const auto& x : c->X) mean_x += x;
    mean_x /= static_cast<double>(n_);
  }
  const std::vector<Vec3>& y = baseline_ ? y_raw_ : y_;
  // Coefficient-wise products: a 3-row block is far below the size where the blocked GEMM pays.
  if (baseline_ && c && base_eval_.blocks.size() == static_cast<size_t>(G_)) {
    // The baseline's own part of the normal equations is the same under every candidate: taken
    // from its evaluation, only the candidate's rows and columns are summed (the same sums).
    for (int g = 0; g < G_; ++g) {
      const Block& bb = base_eval_.blocks[static_cast<size_t>(g)];
      Block& b = e.blocks[static_cast<size_t>(g)];
      b.A.topLeftCorner(p0, p0) = bb.A;
      b.g.head(p0) = bb.g;
      b.s = bb.s;
      b.n = bb.n;
    }
    for (size_t k = 0; k < n_; ++k) AddCandidateRows(baseline_->X[k], c->X[k], y[k], p0, &e.blocks[block_[k]]);
    for (Block& b : e.blocks) {
      b.A.block(p0, 0, pc, p0) = b.A.block(0, p0, p0, pc).transpose();
      b.A.bottomRightCorner(pc, pc).triangularView<Eigen::StrictlyLower>() = b.A.bottomRightCorner(pc, pc).transpose();
    }
  } else {
    Mat3X x(3, p);
    for (size_t k = 0; k < n_; ++k) {
      if (baseline_) x.leftCols(p0) = baseline_->X[k];
      if (c) x.rightCols(pc) = c->X[k] - mean_x;
      Block& b = e.blocks[block_[k]];
      b.A.noalias() += x.transpose().lazyProduct(x);
      b.g.noalias() += x.transpose().lazyProduct(y[k]);
      b.s += y[k].squaredNorm();
      b.n += 3;
    }
  }
  // The baseline's part of the sums is the same under every candidate (its blocks copied above).
  const bool reuse = baseline_ && c && base_folds_.size() == static_cast<size_t>((G_ + 1) / 2);
  std::vector<double> w(G_, 1.0);
  e.full = reuse ? SolveNested(e.blocks, w, p, base_all_) : Solve(e.blocks, w, p);
  if (!e.full.ok || full_only) return e;
  // Blocked CV: G/2 folds of two adjacent blocks each.
  e.cv_sse = 0;
  for (int f = 0; f < G_; f += 2) {
    std::vector<double> wf(G_, 1.0);
    wf[f] = 0;
    if (f + 1 < G_) wf[f + 1] = 0;
    const Fit fit = reuse ? SolveNested(e.blocks, wf, p, base_folds_[static_cast<size_t>(f / 2)]) : Solve(e.blocks, wf, p);
    double fold = 0;
    for (int b = f; b < std::min(G_, f + 2); ++b) fold += fit.ok ? HeldOutSse(e.blocks[b], fit.beta) : e.blocks[b].s;
    e.fold_sse.push_back(fold);
    e.cv_sse += fold;
  }
  // Large-sample chi-square test of the candidate against the baseline (reported only).
  const double dof = total_n_ - p - (demean ? 3 : 0);
  const double sigma2 = e.full.sse / std::max(1.0, dof);
  const double sse0 = baseline_ ? base_eval_.full.sse : total_base_;
  const double chi2 = sigma2 > 0 && c ? (sse0 - e.full.sse) / sigma2 : 0.0;
  e.p_value = c ? ChiSquareSf(chi2, pc) : 1.0;
  e.bic = total_n_ * std::log(std::max(e.full.sse, 1e-300) / total_n_) + p * std::log(total_n_);
  if (p == 0) return e;
  // Cluster-robust covariance over blocks: A⁻¹ (Σ u_b u_bᵀ) A⁻¹ · G/(G−1), u_b = g_b − A_b β.
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(p, p);
  Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(p, p);
  for (const Block& b : e.blocks) {
    A += b.A;
    const Eigen::VectorXd u = b.g - b.A * e.full.beta;
    meat += u * u.transpose();
  }
  const Eigen::MatrixXd Ainv = A.inverse();
  e.cov = Ainv * meat * Ainv * (static_cast<double>(G_) / (G_ - 1));
  // The test asks for the effect's own parameters, those its magnitude holds: a form column beside
  // them (current_hard_iron's per-motor shape share, replay_compass.cc MotorShape) is fitted, not tested.
  const int tested = c != nullptr && c->magnitude_params > 0 ? std::min(c->magnitude_params, pc) : pc;
  e.wald_p = WaldP(e.full.beta, e.cov, Range(p0, p0 + tested), G_);
  return e;
}

std::vector<Vec3> Analyzer::After(const Evaluated& e) const {
  const int p0 = e.off;
  const int pc = e.cand ? e.cand->p() : 0;
  std::vector<Vec3> r(baseline_ ? y_raw_ : y_);
  Mat3X mean_x = Mat3X::Zero(3, pc);
  if (!baseline_ && ch_.bias_nuisance && e.cand) {
    for (const auto& x : e.cand->X) mean_x += x;
    mean_x /= static_cast<double>(n_);
  }
  for (size_t k = 0; k < n_; ++k) {
    if (p0 > 0) r[k] -= baseline_->X[k] * e.full.beta.head(p0);
    if (pc > 0) r[k] -= (e.cand->X[k] - mean_x) * e.full.beta.segment(p0, pc);
  }
  return r;
}

std::vector<Vec3> Analyzer::AfterBaseline() const { return y_; }

double ExplainedShare(double cv_base, double cv_after, double noise_sse) {
  const double excess = cv_base - std::max(0.0, noise_sse);
  if (!(excess > 0)) return 0.0;
  return std::clamp((cv_base - cv_after) / excess, -1.0, 1.0);
}

double Shrink(double after_sse, double before_sse) {
  if (!(before_sse > 0)) return 0.0;
  return 1.0 - std::sqrt(std::max(0.0, after_sse) / before_sse);
}

double MagnitudeOf(const Evaluated& e) {
  const Candidate& c = *e.cand;
  if (c.grid_name == "tau_s") return c.grid_value;
  const int pm = c.magnitude_params > 0 ? c.magnitude_params : c.p();
  Eigen::VectorXd v(pm);
  for (int j = 0; j < pm; ++j) v[j] = e.full.beta[e.off + j] * c.scale[j];
  return pm == 1 ? v[0] : v.norm();
}

namespace {

// The 95 % interval of a profiled parameter at `value`: the 2.5–97.5 % range of its bootstrap
// picks, widened to the grid cells it spans. A profiled parameter is resolved to its grid only: a
// value between two grid points goes to one of them, so the interval holds the cells of the grid
// points it spans (half-way to the neighbouring grid value; at the grid's ends half a step beyond).
// A bootstrap that always picks one grid point would otherwise give an interval of zero width.
// `cells` false: a member choice (current_aligned), not a continuous parameter.
Interval GridInterval(double value, std::vector<double> picks, std::vector<double> grid, bool cells) {
  std::sort(picks.begin(), picks.end());
  Interval iv{value, value};
  if (!picks.empty()) {
    iv.lo = std::min(iv.lo, picks[static_cast<size_t>(0.025 * static_cast<double>(picks.size() - 1))]);
    iv.hi = std::max(iv.hi, picks[static_cast<size_t>(std::ceil(0.975 * static_cast<double>(picks.size() - 1)))]);
  }
  std::sort(grid.begin(), grid.end());
  grid.erase(std::unique(grid.begin(), grid.end()), grid.end());
  if (!cells || grid.size() < 2) return iv;
  const auto cell_lo = [&](double x) {
    const auto it = std::lower_bound(grid.begin(), grid.end(), x);
    if (it == grid.begin()) return x - 0.5 * (grid[1] - grid[0]);
    return 0.5 * (x + *(it - 1));
  };
  const auto cell_hi = [&](double x) {
    const auto it = std::upper_bound(grid.begin(), grid.end(), x);
    if (it == grid.end()) return x + 0.5 * (grid[grid.size() - 1] - grid[grid.size() - 2]);
    return 0.5 * (x + *it);
  };
  return {cell_lo(iv.lo), cell_hi(iv.hi)};
}

}  // namespace

// The reported intervals are 95 %: a norm's low end is 0 where its vector's 95 % region holds zero.
constexpr double kNormZeroLevel = 0.05;

void Describe(const Evaluated& e, const GridPicks& picks, CandidateResult* r) {
  DescribeAt(*e.cand, e.full.beta, JackknifeCov(e), e.off, static_cast<int>(e.blocks.size()), picks, r);
}

void DescribeAt(const Candidate& c, const Eigen::VectorXd& beta, const Eigen::MatrixXd& V, int o, int G,
                const GridPicks& picks, CandidateResult* r) {
  const double t975 = StudentT975(static_cast<double>(G - 1));
  const int p = c.p();
  for (int j = 0; j < p; ++j) {
    const double v = beta[o + j] * c.scale[j];
    const double sd = std::sqrt(std::max(0.0, V(o + j, o + j))) * std::fabs(c.scale[j]);
    r->params[c.names[j]] = v;
    r->ci95[c.names[j]] = {v - t975 * sd, v + t975 * sd};
  }
  if (!c.grid2_name.empty()) {
    r->params[c.grid2_name] = c.grid2_value;
    r->ci95[c.grid2_name] = GridInterval(c.grid2_value, picks.boot2, picks.grid2, true);
  }
  if (!c.grid_name.empty()) {
    r->params[c.grid_name] = c.grid_value;
    Interval iv = GridInterval(c.grid_value, picks.boot, picks.grid, c.grid_name != "current_aligned");
    if (c.grid_name == "tau_s") iv.lo = std::max(0.0, iv.lo);  // a lag is never negative
    r->ci95[c.grid_name] = iv;
    if (c.grid_name == "tau_s") {  // the lag is the magnitude of current_lag
      r->magnitude = c.grid_value;
      r->magnitude_ci95[0] = iv.lo;
      r->magnitude_ci95[1] = iv.hi;
      r->magnitude_unit = "s";
      return;
    }
  }
  r->magnitude_unit = c.magnitude_unit;
  const int pm = c.magnitude_params > 0 ? c.magnitude_params : p;
  Eigen::VectorXd v(pm);
  for (int j = 0; j < pm; ++j) v[j] = beta[o + j] * c.scale[j];
  Eigen::MatrixXd S = Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(c.scale.data(), pm)).asDiagonal();
  const Eigen::MatrixXd cov = S * V.block(o, o, pm, pm) * S;
  if (pm == 1) {
    r->magnitude = v[0];
    const double sd = std::sqrt(std::max(0.0, cov(0, 0)));
    r->magnitude_ci95[0] = v[0] - t975 * sd;
    r->magnitude_ci95[1] = v[0] + t975 * sd;
    return;
  }
  const double mag = v.norm();
  const Eigen::VectorXd grad = mag > 0 ? Eigen::VectorXd(v / mag) : Eigen::VectorXd::Zero(pm);
  const double sd = std::sqrt(std::max(0.0, grad.dot(cov * grad)));
  r->magnitude = mag;
  r->magnitude_ci95[0] = std::max(0.0, mag - t975 * sd);
  r->magnitude_ci95[1] = mag + t975 * sd;
  // The norm's interval holds 0 whenever the vector's 95 % confidence region does (its Wald test on
  // the same covariance does not reject zero at 5 %). The delta method's |v| − t·sd holds only the
  // radial spread, and a vector of pure noise has a norm well above that (on simulated 2 Hz logs of
  // an external compass without a current field, 15 of 16 current_hard_iron intervals excluded 0).
  if (WaldP(v, cov, Range(0, pm), G) >= kNormZeroLevel) r->magnitude_ci95[0] = 0.0;
}

double EffectiveTests(const std::vector<const Candidate*>& members) {
  const size_t k = members.size();
  if (k < 2) return static_cast<double>(k);
  const size_t n = members.front()->X.size();
  for (const Candidate* m : members) {
    if (m->X.size() != n) return static_cast<double>(k);
  }
  const auto K = static_cast<Eigen::Index>(k);
  const auto N = static_cast<Eigen::Index>(n);
  // Each member's signature v (its regressors' summed columns; 3 axes per sample), read once, its
  // mean μ over all 3n entries, and whether it is axis-uniform (one value on the three axes at every
  // sample, as a regressor times the identity).
  Eigen::MatrixXd V(3 * N, K);
  std::vector<Eigen::Index> general;  // the members that are not axis-uniform
  for (Eigen::Index m = 0; m < K; ++m) {
    const std::vector<Mat3X>& X = members[static_cast<size_t>(m)]->X;
    bool uniform = true;
    for (Eigen::Index i = 0; i < N; ++i) {
      const Vec3 v = X[static_cast<size_t>(i)].rowwise().sum();
      V.block(3 * i, m, 3, 1) = v;
      uniform = uniform && v[0] == v[1] && v[0] == v[2];
    }
    if (!uniform) general.push_back(m);
  }
  const Eigen::RowVectorXd mean = V.colwise().mean();
  // The centred cross products split along the axes' common direction and its complement:
  // (v − μ·1)·(v' − μ'·1) = 3·(v̄ − μ)(v̄' − μ') + r·r', v̄ the mean over the axes and r = v − v̄·1
  // (zero for an axis-uniform member). Summed over chunks of samples (the lower triangle, by rank
  // updates), then scaled to the correlations.
  const auto ng = static_cast<Eigen::Index>(general.size());
  constexpr Eigen::Index kChunk = 64;
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(K, K), Cr = Eigen::MatrixXd::Zero(ng, ng);
  Eigen::MatrixXd common(kChunk, K), rest(3 * kChunk, ng);
  for (Eigen::Index i0 = 0; i0 < N; i0 += kChunk) {
    const Eigen::Index rows = std::min(kChunk, N - i0);
    for (Eigen::Index m = 0, g = 0; m < K; ++m) {
      const bool gen = g < ng && general[static_cast<size_t>(g)] == m;
      for (Eigen::Index i = 0; i < rows; ++i) {
        const Vec3 v = V.block<3, 1>(3 * (i0 + i), m);
        const double vbar = gen ? v.sum() / 3.0 : v[0];
        common(i, m) = vbar - mean[m];
        if (gen) rest.block(3 * i, g, 3, 1) = v.array() - vbar;
      }
      g += gen ? 1 : 0;
    }
    C.selfadjointView<Eigen::Lower>().rankUpdate(common.topRows(rows).transpose(), 3.0);
    if (ng > 0) Cr.selfadjointView<Eigen::Lower>().rankUpdate(rest.topRows(3 * rows).transpose());
  }
  for (Eigen::Index b = 0; b < ng; ++b) {
    for (Eigen::Index a = b; a < ng; ++a) C(general[static_cast<size_t>(a)], general[static_cast<size_t>(b)]) += Cr(a, b);
  }
  const Eigen::VectorXd d = C.diagonal();
  if (!(d.minCoeff() > 0)) return static_cast<double>(k);
  const Eigen::VectorXd inv = d.cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd R = inv.asDiagonal() * C * inv.asDiagonal();  // its lower triangle: the correlations
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(R, Eigen::EigenvaluesOnly);
  if (eig.info() != Eigen::Success) return static_cast<double>(k);
  double tests = 0;
  for (Eigen::Index i = 0; i < eig.eigenvalues().size(); ++i) {
    const double l = std::fabs(eig.eigenvalues()[i]);
    tests += (l >= 1.0 ? 1.0 : 0.0) + (l - std::floor(l));
  }
  return std::clamp(tests, 1.0, static_cast<double>(k));
}

namespace {

// Every candidate with a non-zero regressor, evaluated; then the members of each family.
void EvaluateCandidates(const ChannelData& ch, const Analyzer& an, Attribution* at) {
  at->all.reserve(ch.candidates.size());
  for (const Candidate& c : ch.candidates) {
    double energy = 0;
    for (const auto& x : c.X) energy += x.squaredNorm();
    if (!(energy > 1e-18)) continue;
    Evaluated e = an.Evaluate(c);
    if (e.full.ok) at->all.push_back(std::move(e));
  }
  for (size_t i = 0; i < at->all.size(); ++i) at->family[at->all[i].cand->effect].push_back(i);
}

// The family's reported member. The one-standard-error rule within the family: a profiled
// parameter stays at its default (an exponent at the linear 1, a lag at 0) unless a member away from
// it beats it on held-out blocks by more than one standard error. Among the members with fewer
// fitted quantities (Dof) that the in-sample best does not beat so, the simplest (then the lowest
// held-out SSE) is the family's.
size_t ReportedMember(const std::vector<Evaluated>& all, const std::vector<size_t>& members) {
  size_t best = members[0];
  for (size_t m : members) {
    if (all[m].full.sse < all[best].full.sse) best = m;
  }
  const size_t fit_best = best;
  for (size_t m : members) {
    const Evaluated& em = all[m];
    const int dof = Dof(*em.cand), dof_best = Dof(*all[best].cand);
    if (m == fit_best || dof >= Dof(*all[fit_best].cand)) continue;
    if (dof > dof_best || (dof == dof_best && em.cv_sse >= all[best].cv_sse)) continue;
    const std::vector<double>& a = all[fit_best].fold_sse;
    const std::vector<double>& b = em.fold_sse;
    double sum = 0, sq = 0;
    const size_t F = std::min(a.size(), b.size());
    for (size_t f = 0; f < F; ++f) {
      sum += a[f] - b[f];
      sq += (a[f] - b[f]) * (a[f] - b[f]);
    }
    const double var = F > 1 ? (sq - sum * sum / static_cast<double>(F)) / static_cast<double>(F - 1) : 0.0;
    if (sum > -std::sqrt(static_cast<double>(F) * std::max(0.0, var))) best = m;
  }
  return best;
}

// Block bootstrap: which family wins the information criterion on resampled blocks (the baseline
// alone competes as "nothing"); per family its win count, and the profiled parameters' picks.
void BootstrapWins(const Analyzer& an, const DiagnoseOptions& o, RngStream* rng, const Attribution& at,
                   std::vector<double>* wins, std::vector<GridPicks>* picks) {
  const size_t F = at.fam_names.size();
  const int G = an.G();
  wins->assign(F, 0.0);
  picks->assign(F, GridPicks{});
  const int p0 = an.nested() ? an.baseline().p() : 0;
  for (int b = 0; b < o.bootstrap_samples; ++b) {
    std::vector<double> w(G, 0.0);
    for (int k = 0; k < G; ++k) w[std::min(G - 1, static_cast<int>(rng->Uniform() * G))] += 1.0;
    double n_w = 0, base = 0;
    for (int k = 0; k < G; ++k) {
      n_w += w[k] * an.base_n()[k];
      base += w[k] * an.base_blocks()[k];
    }
    Block base_sums;
    BaseFactor factor;
    if (an.nested()) {
      base_sums = SumBlocks(an.baseline().blocks, w, p0);
      base = SolveSums(base_sums, p0).sse;
      factor = FactorBase(base_sums, p0);
    }
    double best_bic = n_w * std::log(std::max(base, 1e-300) / n_w);
    int winner = -1;
    for (size_t f = 0; f < F; ++f) {
      // The family's best member wins its family; the profiled parameters' picks come from the
      // members of the reported member's form (the same second grid parameter, or none).
      const Candidate& reported = *at.all[at.fam_best[f]].cand;
      double fam_bic = 1e300, form_bic = 1e300;
      const Candidate* pick = nullptr;
      for (size_t m : at.family.at(at.fam_names[f])) {
        const Candidate& c = *at.all[m].cand;
        const int pc = c.p();
        double sse = 0;
        if (!(an.nested() && NestedSse(at.all[m].blocks, w, p0, pc, factor, &sse))) {
          const Fit fit = an.nested() ? SolveNested(at.all[m].blocks, w, p0 + pc, base_sums) : Solve(at.all[m].blocks, w, p0 + pc);
          if (!fit.ok) continue;
          sse = fit.sse;
        }
        const double bic = n_w * std::log(std::max(sse, 1e-300) / n_w) + pc * std::log(n_w);
        fam_bic = std::min(fam_bic, bic);
        if (c.grid2_name == reported.grid2_name && bic < form_bic) {
          form_bic = bic;
          pick = &c;
        }
      }
      if (pick != nullptr && !reported.grid_name.empty()) (*picks)[f].boot.push_back(pick->grid_value);
      if (pick != nullptr && !reported.grid2_name.empty()) (*picks)[f].boot2.push_back(pick->grid2_value);
      if (fam_bic < best_bic) {
        best_bic = fam_bic;
        winner = static_cast<int>(f);
      }
    }
    if (winner >= 0) (*wins)[winner] += 1;
  }
}

// Per family its reported member's result (shares against the baseline's held-out SSE cv0), then
// the families in order of held-out shrink.
void DescribeFamilies(const DiagnoseOptions& o, double cv0, double noise_sse, const std::vector<double>& wins,
                      std::vector<GridPicks> picks, Attribution* at) {
  const size_t F = at->fam_names.size();
  for (size_t f = 0; f < F; ++f) {
    const Evaluated& e = at->all[at->fam_best[f]];
    CandidateResult r;
    r.effect = at->fam_names[f];
    r.id = e.cand->id;
    r.probability = o.bootstrap_samples > 0 ? wins[f] / o.bootstrap_samples : 0.0;
    r.heldout_shrink = Shrink(e.cv_sse, cv0);
    r.explained_share = ExplainedShare(cv0, e.cv_sse, noise_sse);
    r.p_value = std::min(1.0, e.p_value);
    r.bic = e.bic;
    r.parameters = e.cand->p();
    for (size_t m : at->family[at->fam_names[f]]) {
      const Candidate& c = *at->all[m].cand;
      if (c.grid2_name != e.cand->grid2_name) continue;  // the grids of the reported member's form
      picks[f].grid.push_back(c.grid_value);
      if (!c.grid2_name.empty()) picks[f].grid2.push_back(c.grid2_value);
    }
    Describe(e, picks[f], &r);
    at->results.push_back(std::move(r));
  }
  at->order.resize(F);
  std::iota(at->order.begin(), at->order.end(), 0);
  std::sort(at->order.begin(), at->order.end(),
            [&](size_t a, size_t b) { return at->results[a].heldout_shrink > at->results[b].heldout_shrink; });
}

// Whether each of the member's form columns (Candidate::form_ranges) lies inside its physical range.
bool FormInRange(const Evaluated& e) {
  for (const Candidate::FormRange& r : e.cand->form_ranges) {
    const double v = e.full.beta(e.off + r.param) * e.cand->scale[static_cast<size_t>(r.param)];
    if (!(v >= r.lo && v <= r.hi)) return false;
  }
  return true;
}

}  // namespace

Attribution Attribute(const ChannelData& ch, const Analyzer& an, const DiagnoseOptions& o, RngStream* rng,
                      double noise_sse) {
  Attribution at;
  EvaluateCandidates(ch, an, &at);
  for (auto& [name, members] : at.family) {
    // A member whose form lies outside its range is no description of the family's field; the
    // family keeps its others (where every member is outside, all of them, and its size is judged).
    std::vector<size_t> in_range;
    for (size_t m : members) {
      if (FormInRange(at.all[m])) in_range.push_back(m);
    }
    if (!in_range.empty() && in_range.size() < members.size()) members = std::move(in_range);
    at.fam_names.push_back(name);
    at.fam_best.push_back(ReportedMember(at.all, members));
    std::vector<const Candidate*> cands;
    for (size_t m : members) cands.push_back(at.all[m].cand);
    at.fam_tests.push_back(EffectiveTests(cands));
  }
  std::vector<double> wins;
  std::vector<GridPicks> picks;
  BootstrapWins(an, o, rng, at, &wins, &picks);
  const double cv0 = an.nested() ? an.baseline().cv_sse : an.base_sse();
  DescribeFamilies(o, cv0, noise_sse, wins, std::move(picks), &at);
  return at;
}

}  // namespace hexsim::gap::internal
