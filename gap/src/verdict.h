// Verdicts (private to gap/), a decomposition (CONTRACTS.md "The verdict is a decomposition"):
// every channel's shares are ExplainedShare (attribution.h) over its baseline and noise floor; the
// material effects, grown from the one-standard-error choice, are listed by share; the headline is
// the largest, partial below DiagnoseOptions::headline_share; an as-simple rival within one
// standard error that neither nests nor is nested is fitted beside the first and the variation they
// do not share decides (ResolveTie), ambiguous where it does not; what is left is described, never a veto;
// unexplained only when structure stands above the floor and no effect is material. Compasses
// first compare what the baseline absorbed with the vehicle file (the latency: LatencyTerm).
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "attribution.h"
#include "channels.h"
#include "hexsim/common/rng.h"

namespace hexsim::gap::internal {

// Which manoeuvre separates two collinear candidates.
std::string SeparatingManoeuvre(Effect a, Effect b);

// The rule of the gyro, accel and dynamics channels (verdict_inertial.cc).
ChannelResult AnalyzeInertial(const ChannelData& ch, const logs::FlightLog& log, const std::vector<std::string>& phases,
                               const DiagnoseOptions& o, RngStream* rng);

// ---- the decomposition shared by every channel (verdict_model.cc) ----
// Σ_f (a_f − b_f) and its standard error √(F·var(a_f − b_f)) over the CV folds.
struct FoldDiff {
  double sum = 0.0, se = 0.0;
};
FoldDiff Diff(const std::vector<double>& a, const std::vector<double>& b);
// Does a's column space (over the samples) hold b's?
bool Nests(const Candidate& a, const Candidate& b);
// current_lag's configured-wiring member (replay_compass.cc AddCurrentLag): the field the vehicle
// file models, arriving through a lag τ instead of the modelled one, times its fitted amplitude a.
// a is the share of the modelled field that arrives late: 1 where all of it lags, less where a
// plate's eddy currents delay a part. A lag never reverses the field it delays: a ≤ 0 is a field
// that LEADS the modelled current (the logged current's timing, which the timing scan and the
// current families' member shifts describe; on clean real-profile logs it fits a = −6…−135 at
// τ = 20–50 ms, significant at p 1e-9…2e-3). Upper end 2: τ is resolved to its grid (kLagGrid_s)
// and to first order only the product a·τ is fitted, so at the grid point below a true τ a reads
// up to the grid's largest step ratio (2, 10 → 20 ms) above the share that lags (an exact log's
// whole-field lag of 0.3 s fits τ = 0.28 s, a = 1.06 [1.01, 1.11]); a lagged field more than twice
// the modelled one is no lag of it (the free member describes an unmodelled lagged field). On a
// real log τ reads high and a low (a = 0.35–0.8 at τ fitted 0.2–0.56 s for true 0.15–0.3 s).
// Judged by the point for the sign, by the interval's low end for the upper end.
inline constexpr const char* kModelledFieldShare = "amplitude";
inline constexpr double kModelledFieldShareLo = 0.0, kModelledFieldShareHi = 2.0;
bool DelaysModelledField(const Candidate& c);
// The member's a inside its range (above): a > 0 and its interval's low end at most 2.
bool ModelledFieldShareInRange(const CandidateResult& r);
// Families that may enter a model: plausible and significant (family-corrected p ≤ alpha); a
// profiled lag resolved from zero, and the configured-wiring member's a inside its range.
std::vector<bool> Eligible(const Attribution& at, const DiagnoseOptions& o);
// The same rules without the physical range of the family's size alone: families that may join a
// model beside its first effect, their size then judged in the joint fit (GrowModel's judge). Alone
// a family absorbs the part of the model's effects its regressors share (a current soft iron fitted
// without the current hard iron beside it took the hard iron's field: 0.011 /A, outside its range,
// for a planted 0.0058; scripts/withheld_sim).
std::vector<bool> Joinable(const Attribution& at, const DiagnoseOptions& o);
// The first effect: the one-standard-error rule over the CV folds among the eligible families (F: none).
size_t ChooseFirst(const Attribution& at, const std::vector<bool>& eligible);
// Material: removes at least o.materiality of the noise floor's power on held-out blocks.
bool IsMaterial(const Analyzer& an, const Evaluated& e, double cv_before, double noise_var, const DiagnoseOptions& o);
// What a compass effect's fitted field does to the heading: the RMS of the angle by which its field
// turns the horizontal Earth field (the prior plus the baseline's correction), in degrees, and the
// low end of its 95 % interval (delta method on the block jackknife; 0 where the coefficients' Wald
// test holds zero). A current or throttle field is measured from the motors-off state the compass
// was calibrated in (its whole field); any other effect by its variation about its flight mean. A
// field fixed in the body per ampere or per unit throttle (EffectInfo::compensable) over a full turn
// of heading at the flight's current and tilt (CONTRACTS' heading error); any other over the flight's
// own headings. Zero where the channel is no compass. Physical range: 0..180 deg.
struct HeadingTurn {
  double deg = 0.0, lo_deg = 0.0;
  bool full_turn = false;  // over a full turn of heading (else over the headings flown)
};
// How the turn was taken, for the text: "over a full turn of heading from motors off" etc.
std::string TurnBasis(const HeadingTurn& h, bool from_motors_off);
HeadingTurn HeadingTurnOf(const ChannelData& ch, const Analyzer& an, const Evaluated& e);
// Material by its heading turn (DiagnoseOptions::material_heading_deg): the interval's low end at
// or above it.
bool TurnsHeading(const HeadingTurn& h, const DiagnoseOptions& o);
// The reported model: the first family, then (forward) each further family that beats the model
// by more than one standard error over the folds, is significant over it and material.
struct SelectedModel {
  std::vector<size_t> fams;          // families, in the order they entered
  std::unique_ptr<Candidate> joint;  // their regressors side by side
  Evaluated eval;                    // its fit (eval.cand == joint)
  std::vector<double> entry_cv_sse;  // the model's held-out SSE after each family entered (fams order)
};
// Whether family f, refused on its own, may join a model of these families: not where f and a
// member are both body-fixed powertrain fields (EffectInfo::compensable: per ampere, per motor, lagged,
// per unit throttle). Those are separated only by how their drives differ (the current against the
// throttle, its split over the motors, its lag), which is the member's shape error: the wiring
// field growing as I^1.4 read current_hard_iron beside a 25 µT per-motor field that took the
// curvature (ideal selftest, out of library: 60 % not confident against 96 % before such joins),
// where the leftover's shape finding says it. Beside a cause of another kind (a misalignment, a
// scale, a current soft iron that turns with the attitude) a hidden effect may join.
bool BesideAnotherCause(const Attribution& at, const std::vector<size_t>& model, size_t f);
// Family c's part of a fit that holds its parameters at offset off of beta (covariance V): its
// linear parameters, magnitude and intervals from that fit, its profiled grid parameters (a current
// shift, an exponent) and a profiled lag (current_lag's magnitude) kept from its own fit, where they
// were chosen.
void DescribePart(const Evaluated& fit, const Eigen::MatrixXd& V, const Candidate& c, int off, CandidateResult* r);
// joinable (empty: none beyond `eligible`): families that may join although refused on their own,
// for being immaterial alone (a small effect beside a large one: held out, alone, it explains
// nothing of a residual the large one dominates) or sized outside their range alone (Joinable); what
// decides is the joint test above. judge (null: none) judges a family's result against its physical
// range and sets `plausible`: a family joins only with its size in the joint fit (DescribePart)
// inside it.
SelectedModel GrowModel(const Analyzer& an, const Attribution& at, size_t first, const std::vector<bool>& eligible,
                        double noise_var, const DiagnoseOptions& o, const std::vector<bool>& joinable = {},
                        const std::function<void(CandidateResult*)>& judge = nullptr);
// The selected families' sizes and intervals from the model's one joint fit (every selected family
// together over the baseline; the block jackknife of that fit), in place of each family's fit alone:
// alone a family absorbs the part of the others its regressors share (the mean-current part S·Ī·h
// of a current soft iron turns the field as a static rotation does: a misalignment of 1.4° beside
// one read 3.4° [3.1, 3.8] alone). Profiled grid parameters and lags stay as their own fits chose
// them. A family after the first reports as its explained share what it adds to the model it joined
// over the baseline's structure above the floor (noise_sse), where that exceeds its share alone.
// One family: unchanged (its own fit is the model's).
void DescribeJointly(const SelectedModel& m, const Attribution& at, double cv0, double noise_sse,
                     std::vector<CandidateResult>* all);
// An eligible family outside the model, as simple as its first, within one standard error of it and
// neither nesting the other (F: none): the verdict is then "ambiguous".
size_t AmbiguousRival(const Attribution& at, const SelectedModel& m, const std::vector<bool>& eligible);
// A tie (AmbiguousRival) decided by the variation the two families do not share: the model with the
// rival beside it, fitted once, and each one's part beyond the other (and beyond the model's further
// families) by the partial Wald test on that fit's block jackknife covariance, Bonferroni over the
// two tests (each p times 2, against o.alpha). The part that stays significant beside the other while
// the other's does not is the effect (a static misalignment against a current field: the heading's
// and tilt's variation the current does not follow, and the current's the attitude does not); both
// significant, with the rival's size in the joint fit inside its physical range: both are effects
// (`both`, the model with the rival joined; `refused` says why GrowModel did not join it); otherwise
// ambiguous. Symmetric in the two families: no effect is preferred by its kind.
enum class TieOutcome { kFirst, kRival, kBoth, kNeither };
// The most effects a model holds (GrowModel; a flight log separates a few effects at most); a tie
// whose parts both stay significant beside a model already this large keeps the model (ResolveTie).
inline constexpr size_t kMaxModelEffects = 3;
struct Tie {
  TieOutcome outcome = TieOutcome::kNeither;
  size_t first = 0, rival = 0;  // families (Attribution order); first is m.fams.front()
  // Each part's p-value beside the other, Bonferroni-corrected over the two tests: 0..1.
  double p_first = 1.0, p_rival = 1.0;
  bool rival_plausible = true;  // the rival's size in the joint fit inside its physical range (judge)
  bool model_full = false;      // both significant, but the model holds kMaxModelEffects already
  bool one_field = false;       // both significant, two forms of one field (OneFieldTwoForms): the first kept
  SelectedModel both;           // kBoth: m's families, then the rival, fitted together
  std::string refused;          // kBoth: GrowModel's tests the joint step failed
};
// Two forms of one field, the motors': a current field (hard iron, per motor, lagged) and a
// throttle field. Both significant beside each other say the field is in proportion to neither (a
// power law, a saturation, a lag), not that two fields are there: the first is kept, its form not
// established. A current soft iron (a field that turns with the heading) is an effect of its own.
bool OneFieldTwoForms(Effect a, Effect b);
Tie ResolveTie(const Analyzer& an, const Attribution& at, const SelectedModel& m, size_t rival, double noise_var,
               const DiagnoseOptions& o, const std::function<void(CandidateResult*)>& judge = nullptr);
// The tie's outcome in words: which part stayed significant beside the other, with both p-values.
std::string TieFinding(const Tie& t, const Attribution& at);
// The reported model, its tie decided (ResolveTie), for every channel: grown from `first`
// (GrowModel); a rival as simple and within one standard error alone (AmbiguousRival) is fitted
// beside it, and the part that stays significant beside the other is the effect (the model regrown
// from the rival where that is the rival), both parts significant give both, neither leaves the
// verdict ambiguous (`ambiguous`, TieUndecided says it). `tie`: TieFinding, empty without a tie.
struct ModelChoice {
  SelectedModel m;
  bool ambiguous = false;
  size_t rival = 0;
  std::string tie;
};
ModelChoice ChooseModel(const Analyzer& an, const Attribution& at, size_t first, const std::vector<bool>& eligible,
                        double noise_var, const DiagnoseOptions& o, const std::vector<bool>& joinable = {},
                        const std::function<void(CandidateResult*)>& judge = nullptr);
// The explanation of an ambiguous verdict: the two families, their shares alone, and the manoeuvre
// that would separate them.
std::string TieUndecided(const Attribution& at, size_t first, size_t rival);
// The effects-list entry of a selected candidate (its autopilot unit where one exists).
EffectShare ToEffect(const CandidateResult& k, double share, const std::string& source);
void SortEffects(std::vector<EffectShare>* effects);
// The effects' sizes again from their selected candidates (after the plug-in propagation widened
// their intervals and the current equivalents were added), and a selected current_lag's lag under
// the channel's timing (FieldLag).
void RefreshEffects(ChannelResult* res);
// A selected current_lag's lag as the channel's timing reports it (Timing::current_field_lag; the
// timing scan's lag, ScanCurrentFieldLag, where current_lag is not selected).
LagReport FieldLag(const CandidateResult& k, double share);
// Selected candidates in the effects' order first, then library candidates by explained share,
// then the timing and nuisance terms.
std::vector<CandidateResult> OrderCandidates(const std::vector<EffectShare>& effects, std::vector<CandidateResult> all);
// The finding printed for an implausible fit that is why its family was refused.
std::string RefusedFinding(const CandidateResult& k, bool beside_a_model);
// " at exponent X" for a candidate with a profiled exponent (current_lag's, throttle_hard_iron's), else
// empty: the exponent has a range of its own and may be what lies outside it.
std::string AtExponent(const CandidateResult& k);

// What the timing scan found for one compass (nuisance.cc).
struct CompassTiming {
  Timing report;  // reported under `timing`
  bool latency_ok = false;
  double latency_s = 0.0, latency_ci95_s[2] = {0.0, 0.0};
  double latency_share = 0.0;        // held-out share of the unaligned baseline residual the alignment removes
  double latency_noise_share = 0.0;  // what the alignment removes held out, over the noise floor's power
  double staleness_s = 0.0;
};

// The nuisance baseline's estimates as findings (nuisance.cc).
struct NuisanceReport {
  Nuisance nuisance;  // reported under `nuisance`
  std::vector<CandidateResult> terms;  // hard_iron_offset, local_anomaly, scale_error as candidates
  std::string out_of_range;            // the term named as the verdict when nothing else is found
  // Every term beyond its normal range (exact ranges: significant), by the same rules: what the
  // baseline absorbed that differs from the vehicle file. Beside fitted effects each is an effect too.
  std::vector<std::string> beyond_normal;
  std::vector<std::string> findings;   // plain language
  // The offset outside hard_iron_offset's physical range (nuisance.h ReadOffset): the baseline is a
  // model mismatch, so the verdict is unexplained, never "no gap" on top of it.
  bool offset_implausible = false;
  // The index in `findings` of the offset's "beyond the normal range: recalibrate" line (-1: none),
  // which RejudgeOffsetAtZeroCurrent rewrites.
  int offset_finding = -1;
};
NuisanceReport DescribeNuisance(const ChannelData& ch, const Evaluated& baseline, const DiagnoseOptions& o);
// Where the reported model fits a field the motor current drives, the baseline's offset holds the
// flight's mean field d·Ī on top of the calibration's own: the offset at zero current is the joint
// fit's. An offset beyond its normal range only through that mean field is no recalibration: the
// term leaves beyond_normal and its finding (findings[nr->offset_finding], a copy of nr's own findings
// first) says so instead (normal ranges only).
void RejudgeOffsetAtZeroCurrent(const ChannelData& ch, const Evaluated& joint, const DiagnoseOptions& o,
                                NuisanceReport* nr, std::vector<std::string>* findings);
// The interval a nuisance term is judged by: value ± t975 times the wider of its two spreads, the
// cluster sandwich and the block jackknife its printed interval uses (on a real log's slow structure
// the jackknife can be several times wider: a point beyond a range is then not resolved beyond it).
Interval JudgedInterval(double value, double sd_sandwich, double sd_jackknife, double t975);
// A compass misaligned by φ whose readings carry a field-norm error s (a sensor scale, or a field of
// another size) reads (1 + s)·R(φ)·h: the linear residual φ × h of the prediction h holds (1 + s)·φ.
// The angle is the coefficient over the baseline's fitted field scale |B_fit|/|B_WMM| (nuisance.cc):
// the misalignment's magnitude, interval and parameters divided by it.
void DescaleMisalignment(double field_scale, CandidateResult* r);

// Does `extra` hold a part the reported model leaves? Significant over the model by its
// cluster-robust Wald test at alpha, and material: it removes at least the materiality share of the
// noise floor's power (in sample). gain: that share of the noise floor's power.
bool LeavesPart(const Analyzer& an, const Evaluated& model, const Candidate& extra, double noise_var, const DiagnoseOptions& o,
                double* gain);
// What a compass model leaves, described (leftover.cc; empty: nothing). A cross-axis coupling of
// the sensor: symmetric off-diagonal gains, which no library family spans.
std::string CouplingFinding(const ChannelData& ch, const Analyzer& an, const Evaluated& model, double noise_var,
                            const DiagnoseOptions& o);

// A form the library refuses that the reported model leaves (leftover.cc; empty: none). The form
// check against driven forms outside the physical range: a family driven by the current or the
// throttle whose best fit was refused as implausible (its exponent outside the physical range: a
// throttle^0.5 fits a field that saturates), significant on its own at alpha and not in the model,
// that alone beats the reported model on held-out blocks by more than one standard error over the
// folds (the rule that selects and that calls two families ambiguous), or still holds a part over it
// (LeavesPart: significant over it and material). The refused form is never an effect; that the data
// prefer it says the field is not in proportion to what drives it, so the reported form is not
// established.
std::string RefusedFormFinding(const Analyzer& an, const Attribution& at, const SelectedModel& m, double noise_var,
                               const DiagnoseOptions& o);

// The rule of compass channels (verdict.cc). Appends the static per-axis scale family (scale_error,
// built from the library-free set's field matrix) to ch's candidates, then analyses them all.
ChannelResult AnalyzeCompass(ChannelData* ch, const logs::FlightLog& log, const std::vector<std::string>& phases,
                             const DiagnoseOptions& o, const CompassTiming& timing, RngStream* rng);

}  // namespace hexsim::gap::internal
