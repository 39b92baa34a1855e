// Which and how much (private to gap/): every candidate fitted as a linear model of the residual over
// the channel's nuisance baseline (nested models), with per-block normal equations so that blocked
// cross-validation, the block bootstrap and cluster-robust intervals are cheap.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "channels.h"
#include "hexsim/common/rng.h"

namespace hexsim::gap::internal {

// Per-block normal equations of one model: A = Σ XᵀX, g = Σ Xᵀy, s = Σ yᵀy, n = 3·samples.
struct Block {
  Eigen::MatrixXd A;
  Eigen::VectorXd g;
  double s = 0, n = 0;
};

struct Fit {
  Eigen::VectorXd beta;
  double sse = 0, n = 0;
  bool ok = false;
};

// The number of contiguous blocks a channel's samples `t` (s) are cut into (equal sample counts):
// as many as DiagnoseOptions::blocks allows while each block covers min_block_s of flight and holds
// min_block_samples samples; never fewer than kMinAnalysisBlocks (channels.h: the CV needs two
// folds of two blocks).
int BlockCount(const std::vector<double>& t, const DiagnoseOptions& o);
Fit Solve(const std::vector<Block>& blocks, const std::vector<double>& w, int p);
// The weighted sums Σ_b w_b·(A_b, g_b, s_b, n_b) of p-parameter blocks, and the fit from them.
Block SumBlocks(const std::vector<Block>& blocks, const std::vector<double>& w, int p);
Fit SolveSums(const Block& sums, int p);
// Solve for blocks whose first rows and columns are the baseline's own normal equations (every
// candidate's, EvaluateX), given the baseline's sums over the same weights: only the candidate's
// rows and columns are summed (the same sums as Solve).
Fit SolveNested(const std::vector<Block>& blocks, const std::vector<double>& w, int p, const Block& base_sums);

struct Evaluated {
  const Candidate* cand = nullptr;  // null: the baseline alone
  int off = 0;                      // the candidate's parameters start here (after the baseline's)
  std::vector<Block> blocks;
  Fit full;
  double cv_sse = 0;
  std::vector<double> fold_sse;  // held-out SSE per CV fold
  double p_value = 1;
  double bic = 0;
  double wald_p = 1;    // cluster-robust Wald test of the effect's own parameters, those its magnitude holds
                        // (Candidate::magnitude_params; Hotelling T², F(q, G − q))
  Eigen::MatrixXd cov;  // cluster-robust covariance of beta
  int p() const { return static_cast<int>(full.beta.size()); }
};

// The jackknife (CR3) covariance of beta over the blocks: (G−1)/G · Σ_g (β₍₋g₎ − β)(β₍₋g₎ − β)ᵀ,
// β₍₋g₎ the fit without block g. Where a parameter's information sits in a few blocks (the vertical
// field of a nearly level flight: the few tilted ones) the sandwich `cov` is too small and the
// jackknife holds that leverage (MacKinnon, Nielsen & Webb 2023, "Cluster-robust inference: a guide
// to empirical practice"). Reported intervals use it; the tests that select a model keep `cov`.
// `cov` where a leave-one-out fit fails.
Eigen::MatrixXd JackknifeCov(const Evaluated& e);

// Cluster-robust Wald test that the parameters `idx` are zero: F(q, G − q) with the small-sample
// factor (G − q)/(q·(G − 1)); 1 (not testable) where q ≥ G, the covariance's rank being below q.
double WaldP(const Eigen::VectorXd& beta, const Eigen::MatrixXd& cov, const std::vector<int>& idx, int G);
std::vector<int> Range(int a, int b);
// Fitted quantities of a candidate for the parsimony rules: its linear parameters, plus one for each
// nonlinear parameter profiled over a grid away from its default (an exponent other than the linear
// 1, a lag τ other than 0): choosing the best of several grid values is a fit too.
int Dof(const Candidate& c);
// Stacks two candidates' regressors side by side (b's Candidate::X_joint where it has them).
Candidate Join(const Candidate& a, const Candidate& b);

class Analyzer {
 public:
  Analyzer(const ChannelData& ch, const DiagnoseOptions& o);
  int G() const { return G_; }
  double base_sse() const { return total_base_; }  // in-sample residual SSE after the baseline
  double total_n() const { return total_n_; }
  const std::vector<double>& base_blocks() const { return base_; }
  const std::vector<double>& base_n() const { return base_n_; }
  // The residual the candidates explain: y with the baseline's full-data fit removed.
  const std::vector<Vec3>& y() const { return y_; }
  const std::vector<int>& block() const { return block_; }
  bool nested() const { return baseline_ != nullptr; }
  const Evaluated& baseline() const { return base_eval_; }
  // c fitted over the baseline (nested: compass channels) or alone (inertial and dynamics channels).
  Evaluated Evaluate(const Candidate& c) const;
  // The full-data fit only (no cross-validation, no covariance): for refits that need the estimate.
  Evaluated FitOnly(const Candidate& c) const;
  // Residual after subtracting the full-data fit of e (baseline included).
  std::vector<Vec3> After(const Evaluated& e) const;
  // Residual after the baseline alone, per sample.
  std::vector<Vec3> AfterBaseline() const;

 private:
  Evaluated EvaluateX(const Candidate* c, bool full_only = false) const;
  const ChannelData& ch_;
  const Candidate* baseline_ = nullptr;
  size_t n_ = 0;
  int G_ = 0;
  std::vector<int> block_;
  std::vector<Vec3> y_raw_, y_;
  std::vector<double> base_, base_n_;
  double total_base_ = 0, total_n_ = 0;
  Evaluated base_eval_;
  // The baseline's sums over all blocks and over each CV fold's fitting blocks (EvaluateX).
  Block base_all_;
  std::vector<Block> base_folds_;
};

// Every candidate evaluated, grouped into families (one member per family: the smallest in-sample
// SSE), with block-bootstrap attribution probabilities and the reported figures per family.
struct Attribution {
  std::vector<Evaluated> all;
  std::vector<std::string> fam_names;
  std::vector<size_t> fam_best;  // index into all
  // Per family (fam_names order), the effective number of independent tests among its members
  // (EffectiveTests): the family-wise correction of the reported member's p-value.
  std::vector<double> fam_tests;
  std::map<std::string, std::vector<size_t>> family;
  std::vector<CandidateResult> results;  // per family, in fam_names order
  std::vector<size_t> order;             // families by held-out shrink, best first
};
// The effective number of independent tests among candidates that differ only by a profiled grid
// value (a current shift, an exponent, a lag): Li and Ji's (2005) count over the eigenvalues λ of
// the members' correlation matrix, Σ [λ ≥ 1] + (λ − ⌊λ⌋), in [1, members]. Each member's signature
// is its regressors' summed columns, stacked over samples and axes and centred. Members that are
// one regressor shifted by a fraction of its own correlation time test nearly the same hypothesis:
// a Bonferroni factor of their count would hide a field every member resolves.
double EffectiveTests(const std::vector<const Candidate*>& members);
// noise_sse: the noise floor's share of the baseline's held-out SSE (nested channels: explained
// shares are of the held-out residual above it).
Attribution Attribute(const ChannelData& ch, const Analyzer& an, const DiagnoseOptions& o, RngStream* rng,
                      double noise_sse = 0.0);

// The reported magnitude of a candidate fit (Describe's): a profiled lag τ, else the scaled
// parameter or the norm of the magnitude's parameters.
double MagnitudeOf(const Evaluated& e);
// The bootstrap picks of a family's profiled parameters (grid, grid2) and the grid values of its
// members (Describe's intervals).
struct GridPicks {
  std::vector<double> boot, boot2, grid, grid2;
};
// Fills the reported parameters, intervals and magnitude of a candidate fit.
void Describe(const Evaluated& e, const GridPicks& picks, CandidateResult* r);
// The same from any fit holding c's parameters at offset o of beta, with the covariance V of beta
// (the block jackknife's) over G blocks: a family's part of a joint fit of several families.
void DescribeAt(const Candidate& c, const Eigen::VectorXd& beta, const Eigen::MatrixXd& V, int o, int G,
                const GridPicks& picks, CandidateResult* r);

double Shrink(double after_sse, double before_sse);
// (MS_baseline − MS_after) / (MS_baseline − MS_noise) on held-out blocks: the share of the residual
// above the noise floor that a model removes (white noise alone cannot be explained).
double ExplainedShare(double cv_base, double cv_after, double noise_sse);

}  // namespace hexsim::gap::internal
