// The compass latency L against the attitude: a lag scan of the baseline (+ the aligned current
// term) fit over the flight samples (private to gap/; declared in nuisance.h).
//
// At each trial latency the configured compass model is evaluated at every flight sample
// (CompassSampler, the replay's own model) and the baseline fitted by least squares on the samples
// usable at every trial latency; the per-block SSE profile gives the estimate and its block-bootstrap
// interval (realdata::ProfileLag). Nothing but the fit's regressors is built per trial latency.
#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <string>

#include <Eigen/Cholesky>

#include "attribution.h"
#include "compass_sampler.h"
#include "detection.h"
#include "hexsim/common/plausibility.h"
#include "nuisance.h"

namespace hexsim::gap::internal {
namespace {

// The scan's fit: the baseline's 6 columns (offset, Earth-field correction), then, where the log has
// a current, the current field's: the battery current's 3 columns, or 3 per motor where the log gives
// each motor's current (logged, or the battery current split by the outputs). The residual holds the
// wiring field the vehicle file does not model (all of it without --sim), and a manoeuvre that moves
// the motors' split (the torque of a yaw, roll or pitch) moves that field while the battery current
// barely changes: the battery term alone leaves it to the latency, which the same manoeuvres move (a
// quad's 130 ms read 137 ms without --sim). The per-motor field costs 3 columns a motor, though, and
// its split comes from the outputs (the controller's torque commands, which move with the attitude's
// rates too): where the residual holds no per-motor field it only blurs a weakly resolved latency,
// and on a short real log (54 s, log_0041) it predicted held-out blocks better yet read a planted
// 59 ms as 80 ms more. So the form is a plug-in the data do not always settle: the point is the form
// that predicts held-out blocks better (ChooseScanForm), the interval the hull of both forms'
// intervals, resolved only where both are.
constexpr int kMaxScanMotors = 8;
constexpr int kMaxScanParams = 6 + 3 + 3 * kMaxScanMotors;
using ScanA = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxScanParams, kMaxScanParams>;
using ScanV = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxScanParams, 1>;

// How many motors' currents the scan's per-motor form has (0: no such form).
size_t ScanMotors(const CompassSampler& sampler, const vehicle::VehicleParams& v, const LogInputs& in) {
  if (!sampler.has_current()) return 0;
  const size_t n = v.rotors.size();
  const bool per_motor = !in.motor_A.empty() || SplitsBatteryCurrent(in, v);
  return per_motor && n >= 2 && n <= static_cast<size_t>(kMaxScanMotors) ? n : 0;
}

// One block's normal equations over every column: the SSE of a fit β on columns c is
// yy − 2β·r_c + βᵀA_cc β.
struct BlockNormal {
  ScanA A;
  ScanV r;
  double yy = 0;
};

// A block's sums before they are spread over the columns. Every column group but the field
// correction's is a scalar f_i times the identity (f = 1 for the offset, the battery current, each
// motor's current), so xᵀx needs only Σ f_i f_j, Σ f_i·H and HᵀH (H = M·R_NBᵀ), not the 3p² products
// of the full 3 × p regressor: a sample costs about (k + 6)² multiply-adds for k scalars, against
// 3p² (p = 3 + 3k) for the full regressor.
constexpr int kMaxScalars = 2 + kMaxScanMotors;
struct BlockSums {
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxScalars, kMaxScalars> ff;
  Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, 3 * kMaxScalars> fH;  // [Σ f_0·H, Σ f_1·H, …]
  Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, kMaxScalars> fy;      // [Σ f_0·y, Σ f_1·y, …]
  Eigen::Matrix3d HH = Eigen::Matrix3d::Zero();
  Vec3 Hy = Vec3::Zero();
  double yy = 0;

  explicit BlockSums(int k) : ff(decltype(ff)::Zero(k, k)), fH(3, 3 * k), fy(3, k) {
    fH.setZero();
    fy.setZero();
  }
  template <typename F>
  void Add(const F& f, const Eigen::Matrix3d& H, const Vec3& y) {
    ff.noalias() += f * f.transpose();
    for (Eigen::Index i = 0; i < f.size(); ++i) {
      fH.middleCols<3>(3 * i) += f[i] * H;
      fy.col(i) += f[i] * y;
    }
    HH.noalias() += H.transpose() * H;
    Hy.noalias() += H.transpose() * y;
    yy += y.squaredNorm();
  }
  // Column start of scalar i's identity group: the offset at 0, the field correction at 3, the
  // battery current at 6, motor j at 9 + 3j.
  static Eigen::Index Start(Eigen::Index i) { return i == 0 ? 0 : 3 + 3 * i; }
  BlockNormal Spread(int p) const {
    BlockNormal b{ScanA::Zero(p, p), ScanV::Zero(p), yy};
    const Eigen::Index k = ff.rows();
    const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
    for (Eigen::Index i = 0; i < k; ++i) {
      const Eigen::Index ci = Start(i);
      for (Eigen::Index j = 0; j < k; ++j) b.A.block<3, 3>(ci, Start(j)) = ff(i, j) * I;
      b.A.block<3, 3>(ci, 3) = fH.middleCols<3>(3 * i);
      b.A.block<3, 3>(3, ci) = fH.middleCols<3>(3 * i).transpose();
      b.r.segment<3>(ci) = fy.col(i);
    }
    b.A.block<3, 3>(3, 3) = HH;
    b.r.segment<3>(3) = Hy;
    return b;
  }
};

// A form of the scan's fit: its columns, per trial latency its per-block SSE and its held-out SSE.
struct ScanForm {
  std::vector<int> cols;
  std::vector<std::vector<double>> sse;
  std::vector<double> cv;
};

ScanV SolveNormal(const ScanA& A, const ScanV& r) {
  const Eigen::Index p = A.rows();
  return (A + ScanA::Identity(p, p) * 1e-12 * A.trace()).ldlt().solve(r);
}

double BlockSse(const BlockNormal& b, const std::vector<int>& c, const ScanV& beta) {
  return std::max(0.0, b.yy - 2.0 * beta.dot(b.r(c)) + beta.dot(b.A(c, c) * beta));
}

// Form f's fit at one trial latency: its per-block SSE appended, and its held-out SSE (each block
// predicted by the fit on the others).
void FitForm(const std::vector<BlockNormal>& blocks, ScanForm* f) {
  const std::vector<int>& c = f->cols;
  const Eigen::Index p = static_cast<Eigen::Index>(c.size());
  ScanA A = ScanA::Zero(p, p);
  ScanV r = ScanV::Zero(p);
  for (const BlockNormal& b : blocks) {
    A += b.A(c, c);
    r += b.r(c);
  }
  const ScanV beta = SolveNormal(A, r);
  std::vector<double> row;
  double cv = 0;
  for (const BlockNormal& b : blocks) {
    row.push_back(BlockSse(b, c, beta));
    cv += BlockSse(b, c, SolveNormal(A - b.A(c, c), r - b.r(c)));
  }
  f->sse.push_back(std::move(row));
  f->cv.push_back(cv);
}

// The form whose best trial latency predicts held-out blocks best (the fewer columns on a tie).
size_t ChooseScanForm(const std::vector<ScanForm>& forms) {
  size_t best = 0;
  for (size_t i = 1; i < forms.size(); ++i) {
    if (*std::min_element(forms[i].cv.begin(), forms[i].cv.end()) <
        *std::min_element(forms[best].cv.begin(), forms[best].cv.end())) {
      best = i;
    }
  }
  return best;
}

// The scan's forms over the columns [baseline 6][battery 3][motor 3·motors].
std::vector<ScanForm> ScanForms(bool has_current, size_t motors) {
  std::vector<ScanForm> forms(1);
  for (int j = 0; j < (has_current ? 9 : 6); ++j) forms[0].cols.push_back(j);
  if (motors > 0) {
    forms.emplace_back();
    for (int j = 0; j < 6; ++j) forms[1].cols.push_back(j);
    for (int j = 0; j < 3 * static_cast<int>(motors); ++j) forms[1].cols.push_back(9 + j);
  }
  return forms;
}

// The scan's forms, each with its per-block SSE and held-out SSE at each trial latency, on the
// samples usable at every one; empty when fewer than 100 are.
std::vector<ScanForm> LatencyProfile(CompassSampler* sampler, const CompassReplayOptions& base, double shift_s,
                                                const std::vector<double>& grid, int G, size_t motors) {
  const std::vector<CompassSample>& samples = sampler->samples();
  const size_t ns = samples.size();
  auto wanted = [&](const CompassSample& s) {
    return !base.row_kind || (*base.row_kind)[static_cast<size_t>(s.row)] == base.want;
  };
  LocatedSample ls;
  Eigen::Matrix3d R_NB;
  // The samples usable at every trial latency.
  std::vector<int> usable(ns, 0);
  for (double L : grid) {
    sampler->Begin(L, shift_s, base.LongestMemberShift_s());
    for (size_t k = 0; k < ns; ++k) {
      if (wanted(samples[k]) && sampler->Locate(samples[k], &ls)) ++usable[k];
    }
  }
  size_t common = 0;
  for (int u : usable) common += u == static_cast<int>(grid.size());
  if (common < 100) return {};
  const int p = 9 + 3 * static_cast<int>(motors);
  std::vector<ScanForm> forms = ScanForms(sampler->has_current(), motors);
  const int k = 2 + static_cast<int>(motors);  // scalars: 1, battery, each motor
  std::vector<BlockSums> sums(static_cast<size_t>(G), BlockSums(k));
  std::vector<BlockNormal> blocks(static_cast<size_t>(G));
  Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxScalars, 1> scalars(k);
  for (size_t g = 0; g < grid.size(); ++g) {
    std::fill(sums.begin(), sums.end(), BlockSums(k));
    // Every sample usable at this latency advances the configured current lag, as in the replay.
    sampler->Begin(grid[g], shift_s, base.LongestMemberShift_s());
    size_t m = 0;
    for (size_t s = 0; s < ns; ++s) {
      if (!wanted(samples[s]) || !sampler->Locate(samples[s], &ls)) continue;
      R_NB = ls.q.toRotationMatrix();
      const CompassSampler::Prediction pr = sampler->Predict(samples[s], ls, R_NB);
      if (usable[s] != static_cast<int>(grid.size())) continue;
      scalars[0] = 1.0;
      scalars[1] = ls.currents.battery_A;
      for (size_t j = 0; j < motors; ++j) scalars[2 + static_cast<Eigen::Index>(j)] = ls.currents.motor_A[j];
      sums[m * static_cast<size_t>(G) / common].Add(scalars, pr.M * R_NB.transpose(), samples[s].m - pr.pred);
      ++m;
    }
    for (size_t b = 0; b < blocks.size(); ++b) blocks[b] = sums[b].Spread(p);
    for (ScanForm& f : forms) FitForm(blocks, &f);
  }
  return forms;
}

// The latency from the forms' profiles: the chosen form's estimate, its interval the hull of every
// form's (each profiled with the same resamples and seed), resolved only where every form's is.
realdata::LagEstimate ScanEstimate(const std::vector<double>& grid, const std::vector<ScanForm>& forms, const DiagnoseOptions& o) {
  const size_t chosen = ChooseScanForm(forms);
  realdata::LagEstimate lat = realdata::ProfileLag(grid, forms[chosen].sse, o.bootstrap_samples, o.seed);
  if (!lat.ok()) return lat;
  for (size_t i = 0; i < forms.size(); ++i) {
    if (i == chosen) continue;
    const realdata::LagEstimate other = realdata::ProfileLag(grid, forms[i].sse, o.bootstrap_samples, o.seed);
    if (!other.ok()) continue;
    lat.ci95_s[0] = std::min(lat.ci95_s[0], other.ci95_s[0]);
    lat.ci95_s[1] = std::max(lat.ci95_s[1], other.ci95_s[1]);
    lat.at_grid_edge = lat.at_grid_edge || other.at_grid_edge;
    lat.unbounded = lat.unbounded || other.unbounded;
  }
  return lat;
}

// The latency scan of ScanCompassTiming into *tm (unchanged where the profile cannot be had).
void ScanLatency(const logs::FlightLog& log, const vehicle::VehicleParams& v, size_t c, const LogInputs& in,
                 const Vec3& B_N_uT, const CompassReplayOptions& base, double shift_s, const DiagnoseOptions& o,
                 CompassTiming* tm_out) {
  CompassTiming& tm = *tm_out;
  // Latency grid: −0.1…0.3 s in 10 ms steps; every lag on the same compass samples.
  const std::vector<double> grid = realdata::LagGrid(-0.1, 0.3, 0.01);
  CompassSampler sampler(log, v, c, in, B_N_uT, base.calibrated_log, base.share_exponent);
  const std::vector<ScanForm> forms =
      LatencyProfile(&sampler, base, shift_s, grid, std::max(4, o.blocks), ScanMotors(sampler, v, in));
  if (forms.empty()) return;
  const realdata::LagEstimate lat = ScanEstimate(grid, forms, o);
  if (!lat.ok()) return;
  tm.latency_ok = lat.resolved();
  tm.latency_s = lat.value_s;
  tm.latency_ci95_s[0] = lat.ci95_s[0];
  tm.latency_ci95_s[1] = lat.ci95_s[1];
  tm.report.latency = {true,           lat.value_s,         {lat.ci95_s[0], lat.ci95_s[1]},
                       "attitude (q_*)", lat.resolved(), plausibility::IntervalPlausible("latency", lat.ci95_s[0], lat.ci95_s[1]),
                       std::nan(""),   std::nan("")};
  // Held-out share of the unaligned baseline residual that the alignment removes, and whether the
  // unaligned residual has structure at all.
  CompassReplayOptions r0 = base, r1 = base;
  r0.baseline_only = r1.baseline_only = true;
  r0.current_shift_s = r1.current_shift_s = shift_s;
  r1.latency_s = lat.value_s;
  const ChannelData c0 = ReplayCompass(log, v, c, in, B_N_uT, r0);
  const ChannelData c1 = ReplayCompass(log, v, c, in, B_N_uT, r1);
  if (c0.t.size() < 100 || c1.t.size() < 100) return;
  const Analyzer a0(c0, o), a1(c1, o);
  const double cv0 = a0.baseline().cv_sse / static_cast<double>(c0.t.size());
  const double cv1 = a1.baseline().cv_sse / static_cast<double>(c1.t.size());
  const double noise = 3.0 * NoiseVariance(c1.t, a1.y());
  tm.latency_share = std::max(0.0, ExplainedShare(cv0, cv1, noise));
  tm.latency_noise_share = noise > 0 ? std::max(0.0, (cv0 - cv1) / noise) : 0.0;
  tm.report.latency.explained_share = tm.latency_share;
}

}  // namespace

CompassTiming ScanCompassTiming(const logs::FlightLog& log, const vehicle::VehicleParams& v, size_t c, const LogInputs& in,
                                const Vec3& B_N_uT, const CompassReplayOptions& base, const realdata::LagEstimate& stale,
                                double shift_s, const DiagnoseOptions& o) {
  CompassTiming tm;
  // No usable current (in.current null): the staleness of a current the fit does not use is no finding.
  tm.staleness_s = stale.ok() && in.current != nullptr ? stale.value_s : 0.0;
  if (stale.ok() && in.current != nullptr) {
    tm.report.current_staleness = {true,      stale.value_s,      {stale.ci95_s[0], stale.ci95_s[1]},
                                   "control_u", stale.resolved(),
                                   plausibility::IntervalPlausible("current_staleness", stale.ci95_s[0], stale.ci95_s[1]),
                                   std::nan(""), shift_s};
  }
  ScanLatency(log, v, c, in, B_N_uT, base, shift_s, o, &tm);
  // The current-driven field's lag behind the logged current, on the replay the diagnosis makes: the
  // latency aligned where resolved clear of zero (DiagnoseCompass), the prediction's current shift.
  if (in.current != nullptr) {
    const bool align = tm.latency_ok && (tm.latency_ci95_s[0] > 0 || tm.latency_ci95_s[1] < 0);
    CompassReplayOptions r = base;
    r.baseline_only = true;
    r.latency_s = align ? tm.latency_s : 0.0;
    r.current_shift_s = shift_s;
    tm.report.current_field_lag = ScanCurrentFieldLag(ReplayCompass(log, v, c, in, B_N_uT, r), in, r.latency_s, o);
  }
  return tm;
}

namespace {

// The plug-ins' replay options, each at the ends of its own 95 % interval (a logged current is
// never early: its shift at least zero).
std::vector<std::pair<CompassReplayOptions, CompassReplayOptions>> PlugInEnds(const vehicle::VehicleParams& v,
                                                                             const LogInputs& in,
                                                                             const CompassReplayOptions& used,
                                                                             const CompassTiming& timing,
                                                                             const realdata::LagEstimate& stale) {
  std::vector<std::pair<CompassReplayOptions, CompassReplayOptions>> pairs;
  if (timing.latency_ok) {
    CompassReplayOptions lo = used, hi = used;
    lo.latency_s = timing.latency_ci95_s[0];
    hi.latency_s = timing.latency_ci95_s[1];
    pairs.emplace_back(lo, hi);
  }
  // The current-driven families choose their own member shift (their interval holds that choice);
  // the prediction's current shift is a plug-in.
  if (stale.ok() && used.current_shift_s > 0) {
    CompassReplayOptions lo = used, hi = used;
    lo.current_shift_s = std::max(0.0, stale.ci95_s[0]);
    hi.current_shift_s = std::max(0.0, stale.ci95_s[1]);
    pairs.emplace_back(lo, hi);
  }
  // The split matters only where the replay splits a battery current over configured motor wiring.
  if (SplitsBatteryCurrent(in, v) && HasWiring(v)) {
    CompassReplayOptions lo = used, hi = used;
    lo.share_exponent = kShareExponentLo;
    hi.share_exponent = kShareExponentHi;
    pairs.emplace_back(lo, hi);
  }
  return pairs;
}

// What the refits build: the reported families only, of current_lag the reported form's lag
// profile, and of the current iron families the reported members' shifts.
struct RefitSet {
  std::vector<Effect> families;
  LagMembers lag_members;
  std::vector<double> member_shifts;
};

RefitSet ReportedRefitSet(const ChannelResult& res) {
  RefitSet set;
  for (const CandidateResult& k : res.candidates) {
    if (k.nuisance_term || k.id == Effect::kLatency || k.id == Effect::kNone) continue;
    set.families.push_back(k.id);
    const auto aligned = k.params.find("current_aligned");
    if (aligned != k.params.end()) set.member_shifts.push_back(aligned->second);
    if (k.id != Effect::kCurrentLag) continue;
    const auto ex = k.params.find("exponent");
    set.lag_members.form = ex == k.params.end() ? LagMembers::Form::kWiring : LagMembers::Form::kFree;
    if (ex != k.params.end()) set.lag_members.exponent = ex->second;
  }
  return set;
}

// The replayed channel's member of reported family k: its reported member, or, for a profiled lag
// τ, the best-fitting member of its form (then *profiled_magnitude holds that member's magnitude).
const Candidate* RefitMember(const ChannelData& ch, const Analyzer& an, const CandidateResult& k,
                             std::optional<double>* profiled_magnitude) {
  const Candidate* member = nullptr;
  double best_sse = 0;
  for (const Candidate& cand : ch.candidates) {
    if (cand.effect != k.effect) continue;
    const bool profiled = cand.grid_name == "tau_s";
    // A lag is profiled again within the reported member's form (current_lag's free member at
    // its exponent, or the configured-wiring member).
    if (profiled && !(cand.grid2_name.empty() ? k.params.count("exponent") == 0
                                              : k.params.count(cand.grid2_name) > 0 &&
                                                    k.params.at(cand.grid2_name) == cand.grid2_value)) {
      continue;
    }
    if (!profiled && !cand.grid_name.empty() &&
        !(k.params.count(cand.grid_name) > 0 && k.params.at(cand.grid_name) == cand.grid_value)) {
      continue;
    }
    // Members of one shift that differ in their columns (current_hard_iron's with the file's
    // per-motor shape, MotorShape): the one with every reported parameter, the most columns.
    if (!profiled) {
      const bool reported = std::all_of(cand.names.begin(), cand.names.end(),
                                        [&k](const std::string& n) { return k.params.count(n) > 0; });
      if (reported && (member == nullptr || cand.names.size() > member->names.size())) member = &cand;
      continue;
    }
    const Evaluated e = an.FitOnly(cand);
    if (e.full.ok && (member == nullptr || e.full.sse < best_sse)) {
      member = &cand;
      best_sse = e.full.sse;
      *profiled_magnitude = MagnitudeOf(e);
    }
  }
  return member;
}

// Each reported effect's magnitude on a replay at the given timing: the reported member of its
// family (a profiled lag τ, the magnitude itself, profiled again); the nuisance terms from the
// baseline.
std::map<std::string, double> RefitMagnitudes(const logs::FlightLog& log, const vehicle::VehicleParams& v, size_t c,
                                              const LogInputs& in, const Vec3& B_N_uT, CompassReplayOptions ro,
                                              const RefitSet& set, const DiagnoseOptions& o, const ChannelResult& res) {
  std::map<std::string, double> m;
  ro.library_free = false;  // not a reported effect
  ro.only_families = set.families;
  ro.lag_members = set.lag_members;
  ro.only_member_shifts_s = set.member_shifts;
  const ChannelData ch = ReplayCompass(log, v, c, in, B_N_uT, ro);
  if (static_cast<int>(ch.t.size()) < CompassMinSamples(ch).samples) return m;
  const Analyzer an(ch, o);
  const NuisanceReport nr = DescribeNuisance(ch, an.baseline(), o);
  for (const CandidateResult& t : nr.terms) m[t.effect] = t.magnitude;
  for (const CandidateResult& k : res.candidates) {
    if (k.nuisance_term || k.id == Effect::kLatency) continue;
    std::optional<double> profiled_magnitude;
    const Candidate* member = RefitMember(ch, an, k, &profiled_magnitude);
    if (member == nullptr) continue;
    if (profiled_magnitude) {  // fitted in the profile
      m[k.effect] = *profiled_magnitude;
      continue;
    }
    const Evaluated e = an.FitOnly(*member);
    if (!e.full.ok) continue;
    CandidateResult refit;
    refit.effect = k.effect;
    refit.id = k.id;
    refit.magnitude = MagnitudeOf(e);
    DescaleMisalignment(nr.nuisance.field_scale, &refit);
    m[k.effect] = refit.magnitude;
  }
  return m;
}

}  // namespace

void PropagatePlugIns(const logs::FlightLog& log, const vehicle::VehicleParams& v, size_t c, const LogInputs& in,
                     const Vec3& B_N_uT, const CompassReplayOptions& used, const CompassTiming& timing,
                     const realdata::LagEstimate& stale, const DiagnoseOptions& o, ChannelResult* res) {
  const auto pairs = PlugInEnds(v, in, used, timing, stale);
  if (pairs.empty()) return;
  const RefitSet set = ReportedRefitSet(*res);
  std::map<std::string, double> var;  // Σ over the plug-ins of (half the refit spread)²
  for (const auto& [lo, hi] : pairs) {
    const std::map<std::string, double> a = RefitMagnitudes(log, v, c, in, B_N_uT, lo, set, o, *res);
    const std::map<std::string, double> b = RefitMagnitudes(log, v, c, in, B_N_uT, hi, set, o, *res);
    for (const auto& [effect, ma] : a) {
      const auto it = b.find(effect);
      if (it == b.end() || !std::isfinite(ma) || !std::isfinite(it->second)) continue;
      const double half = 0.5 * (it->second - ma);
      var[effect] += half * half;
    }
  }
  for (CandidateResult& k : res->candidates) {
    const auto it = var.find(k.effect);
    if (it == var.end() || k.id == Effect::kLatency) continue;
    const double lo = k.magnitude - k.magnitude_ci95[0], hi = k.magnitude_ci95[1] - k.magnitude;
    const bool norm = !Info(k.id).signed_magnitude;
    k.magnitude_ci95[0] = k.magnitude - std::sqrt(lo * lo + it->second);
    k.magnitude_ci95[1] = k.magnitude + std::sqrt(hi * hi + it->second);
    if (norm) k.magnitude_ci95[0] = std::max(0.0, k.magnitude_ci95[0]);
  }
}

}  // namespace hexsim::gap::internal
