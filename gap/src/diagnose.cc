// The diagnosis in order: windows (realdata), replay, per compass the timing scan and the nested
// fits over the nuisance baseline (nuisance.cc, attribution.cc, detection.cc, verdict.cc), the
// inertial rule for the gyro, accel and dynamics channels (verdict_inertial.cc).
#include "hexsim/gap/diagnose.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <functional>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>

#include <fmt/format.h>

#include "channels.h"
#include "compass_map.h"
#include "compass_terms_fit.h"
#include "hexsim/common/rng.h"
#include "hexsim/common/plausibility.h"
#include "hexsim/magnetics/flight_fit.h"
#include "hexsim/realdata/compass_flight.h"
#include "hexsim/realdata/windows.h"
#include "nuisance.h"
#include "replay_util.h"
#include "verdict.h"

namespace hexsim::gap {

using internal::ChannelData;

namespace {

realdata::FlightWindows Windows(const logs::FlightLog& log, const DiagnoseOptions& o) {
  if (o.from_s < o.to_s) return realdata::WindowsFromRange(log, o.from_s, o.to_s);
  return realdata::FindFlightWindows(log);
}

// The throttle-driven field in current terms: |d| / (dI/d(u^r)), the log's current-vs-throttle slope.
void AddCurrentEquivalent(const ChannelData& ch, CandidateResult* r) {
  const auto it = r->params.find("exponent");
  const double ex = it != r->params.end() ? it->second : 1.0;
  double mu = 0, mi = 0;
  size_t n = 0;
  for (size_t k = 0; k < ch.t.size(); ++k) {
    if (!std::isfinite(ch.throttle[k])) continue;
    mu += std::pow(std::max(0.0, ch.throttle[k]), ex);
    mi += ch.current_A[k];
    ++n;
  }
  if (n < 10) return;
  mu /= static_cast<double>(n);
  mi /= static_cast<double>(n);
  double sxy = 0, sxx = 0;
  for (size_t k = 0; k < ch.t.size(); ++k) {
    if (!std::isfinite(ch.throttle[k])) continue;
    const double x = std::pow(std::max(0.0, ch.throttle[k]), ex) - mu;
    sxy += x * (ch.current_A[k] - mi);
    sxx += x * x;
  }
  if (!(sxx > 0) || !(std::fabs(sxy) > 0)) return;
  const double slope_A = sxy / sxx;  // A per unit throttle^r
  r->params["current_per_throttle_A"] = slope_A;
  r->params["current_equivalent_uT_per_A"] = r->magnitude / std::fabs(slope_A);
  r->ci95["current_equivalent_uT_per_A"] = {r->magnitude_ci95[0] / std::fabs(slope_A), r->magnitude_ci95[1] / std::fabs(slope_A)};
}

// A throttle effect's current equivalent is kept only where the in-flight model says the current
// carries it (internal::CurrentEquivalentRefusal); otherwise it is removed (the effect stays in its
// throttle unit) and, for a selected effect, a finding says why.
void GateCurrentEquivalent(const Result<CompassTerms>& terms, CandidateResult* k, std::vector<std::string>* findings) {
  const auto eq = k->params.find("current_equivalent_uT_per_A");
  if (eq == k->params.end()) return;
  const std::string why = internal::CurrentEquivalentRefusal(terms, eq->second);
  if (why.empty()) return;
  k->params.erase("current_equivalent_uT_per_A");
  k->ci95.erase("current_equivalent_uT_per_A");
  if (k->selected) findings->push_back(k->effect + ": no current equivalent: " + why);
}

// A per-motor field in current terms: the slope of its fitted field on the battery current,
// d = Σ (B_k − B̄)(I_k − Ī) / Σ (I_k − Ī)², B_k = Σ_i c_i·u_i,k^0.65 (the candidate's regressors).
void AddPerMotorEquivalent(const ChannelData& ch, CandidateResult* r) {
  const internal::Candidate* cand = nullptr;
  for (const auto& c : ch.candidates) {
    if (c.effect == r->effect) cand = &c;
  }
  if (!cand || cand->X.size() != ch.t.size() || ch.t.size() < 10) return;
  Eigen::VectorXd beta(cand->p());
  for (int j = 0; j < cand->p(); ++j) {
    const auto it = r->params.find(cand->names[j]);
    beta[j] = it != r->params.end() ? it->second : 0.0;
  }
  const size_t n = ch.t.size();
  std::vector<internal::Vec3> B(n);
  internal::Vec3 Bm = internal::Vec3::Zero();
  double Im = 0;
  for (size_t k = 0; k < n; ++k) {
    B[k] = cand->X[k] * beta;
    Bm += B[k];
    Im += ch.current_A[k];
  }
  Bm /= static_cast<double>(n);
  Im /= static_cast<double>(n);
  internal::Vec3 sxy = internal::Vec3::Zero();
  double sxx = 0;
  for (size_t k = 0; k < n; ++k) {
    sxy += (B[k] - Bm) * (ch.current_A[k] - Im);
    sxx += (ch.current_A[k] - Im) * (ch.current_A[k] - Im);
  }
  if (!(sxx > 0) || !(r->magnitude > 0)) return;
  const double k_uT_per_A = (sxy / sxx).norm();
  r->params["current_equivalent_uT_per_A"] = k_uT_per_A;
  // The interval scales with the fitted magnitude (the regressors are fixed).
  const double f = k_uT_per_A / r->magnitude;
  r->ci95["current_equivalent_uT_per_A"] = {f * r->magnitude_ci95[0], f * r->magnitude_ci95[1]};
}

// The in-flight model's absolute terms on the channel, or why there are none (a finding); where the
// diagnosed log holds blocks out (identify_heldout), says on which blocks they were fitted.
void AttachAbsoluteTerms(Result<CompassTerms> terms, const logs::FlightLog& log, bool whole_log, ChannelResult* r) {
  if (!terms.ok()) {
    r->findings.push_back("in-flight model (absolute terms) not fitted: " + terms.status().message());
    return;
  }
  if (log.meta.contains("identify_heldout")) {
    terms->held_out = whole_log ? "absolute terms fitted on every flight block (as hexsim calibrate); the vehicle was "
                                  "identified on the even blocks, and the candidates are diagnosed on the odd (held-out) "
                                  "blocks only"
                                : "absolute terms fitted on the held-out blocks only (the vehicle was identified on the "
                                  "others); hexsim calibrate fits every flight block";
  }
  r->absolute_terms = std::move(*terms);
}

// Runs the tasks on `threads` threads (each takes the next task in turn; 1 or fewer: in order on
// this thread). The first exception a task throws is rethrown here once every thread has stopped.
void RunTasks(const std::vector<std::function<void()>>& tasks, int threads) {
  const size_t n_threads = std::min(tasks.size(), static_cast<size_t>(std::max(1, threads)));
  if (n_threads <= 1) {
    for (const auto& t : tasks) t();
    return;
  }
  std::atomic<size_t> next{0};
  std::vector<std::exception_ptr> errors(tasks.size());
  auto work = [&] {
    for (size_t i = next++; i < tasks.size(); i = next++) {
      try {
        tasks[i]();
      } catch (...) {
        errors[i] = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  for (size_t k = 1; k < n_threads; ++k) pool.emplace_back(work);
  work();
  for (auto& th : pool) th.join();
  for (const auto& e : errors) {
    if (e) std::rethrow_exception(e);
  }
}

// Where a compass's decomposition holds the reference's heading error (reference_yaw), the finding
// a user acts on: the estimator fuses a compass the current disturbs (`fused`, the log's primary).
void ReferenceYawFinding(const std::string& fused, ChannelResult* r) {
  for (const EffectShare& e : r->effects) {
    if (e.id != Effect::kReferenceYaw) continue;
    r->findings.push_back(fmt::format(
        "reference_yaw: the attitude reference's heading moves with the current by {:.2f} [{:.2f}, {:.2f}] deg/A: the "
        "estimator fuses a compass the current disturbs ({}, its primary): compensate that compass (COMPASS_MOT, "
        "CAL_MAGn_COMP) or fuse one away from the wiring; the field this plants on {} is the reference's, not {}'s own",
        e.magnitude, e.ci95.lo, e.ci95.hi, fused.empty() ? std::string("not named in the log") : fused, r->channel,
        r->channel));
  }
}

// What every compass channel of one diagnosis shares.
struct CompassRun {
  const logs::FlightLog& log;
  const vehicle::VehicleParams& vehicle;
  const DiagnoseOptions& options;
  const internal::ReplayResult& rr;
  const realdata::FlightWindows& fw;
  const std::vector<std::string>& phases;
  const logs::FlightLog& model_log;  // the in-flight model's log (the whole log when gap holds blocks out)
  const realdata::FlightWindows& model_windows;
  const realdata::LagEstimate& stale;
  double shift_s, share_exponent, fitted_share_exponent, flight_s;
  bool sim_truth;
};

struct CompassChannel {
  ChannelResult result;
  ChannelData data;
};

// The least-squares Earth field of the nuisance baseline alone (offset and NED field, no prior) over
// the compass's flight samples; NaN when they are too few for the in-flight model's own minimum.
internal::Vec3 BaselineEarthField(const CompassRun& run, size_t c) {
  internal::CompassReplayOptions ro;
  ro.row_kind = &run.fw.row_kind;
  ro.calibrated_log = !run.sim_truth;
  ro.share_exponent = run.share_exponent;
  ro.current_shift_s = run.shift_s;
  ro.baseline_only = true;
  const ChannelData ch = internal::ReplayCompass(run.log, run.vehicle, c, run.rr.inputs, internal::Vec3::Zero(), ro);
  internal::Vec3 none = internal::Vec3::Constant(std::nan(""));
  if (static_cast<int>(ch.t.size()) < magnetics::MinFlightFitSamples()) return none;
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
  for (size_t k = 0; k < ch.t.size(); ++k) {
    A += ch.baseline.X[k].transpose() * ch.baseline.X[k];
    g += ch.baseline.X[k].transpose() * ch.y[k];
  }
  const Eigen::FullPivLU<Eigen::Matrix<double, 6, 6>> lu(A);
  if (lu.rank() < 6) return none;
  return lu.solve(g).tail<3>();
}

// The Earth field compass c is replayed against, and where it comes from: the field model's at the
// log's place and date; without one (no GPS fix) the in-flight model's free fit (the field hexsim
// calibrate --method flight prints), else the baseline's own least-squares field. A free field
// outside the Earth's range (plausibility row earth_field_norm) is a model mismatch: nullopt, the
// reason in *why.
std::optional<internal::Vec3> CompassEarthField(const CompassRun& run, size_t c, const Result<CompassTerms>& terms,
                                                std::string* source, std::string* why) {
  if (!run.rr.field_free) {
    *source = run.rr.field_model + " at the log's place and date";
    return run.rr.earth_field_N_uT;
  }
  const bool from_model = terms.ok() && terms->field_N_uT.norm() > 0;
  const internal::Vec3 B = from_model ? terms->field_N_uT : BaselineEarthField(run, c);
  const char* by = from_model ? "the in-flight model, as hexsim calibrate --method flight" : "the nuisance baseline alone";
  if (!B.allFinite()) {
    *why = "no place and date for the field model, and too few flight samples to fit the Earth field freely (" +
           run.rr.field_free_why + ")";
    return std::nullopt;
  }
  const double k = kMilliGaussPerMicroTesla;
  *source = fmt::format("fitted freely (no place and date: no GPS fix) by {}: ({:.0f}, {:.0f}, {:.0f}) mG N/E/D, |B| {:.0f} mG",
                        by, k * B.x(), k * B.y(), k * B.z(), k * B.norm());
  if (!plausibility::IsPlausible("earth_field_norm", B.norm())) {
    *why = fmt::format("Earth field {}, outside {}: model mismatch", *source, plausibility::RangeText("earth_field_norm"));
    return std::nullopt;
  }
  return B;
}

// One compass channel (c: its index): the in-flight model's absolute terms, the timing scan, the
// replay and its analysis; nullopt, with the reason in *not_diagnosed, when it cannot be diagnosed.
std::optional<CompassChannel> DiagnoseCompass(const CompassRun& run, size_t c,
                                              std::vector<std::pair<std::string, std::string>>* not_diagnosed) {
  const logs::FlightLog& log = run.log;
  const vehicle::VehicleParams& vehicle = run.vehicle;
  const DiagnoseOptions& options = run.options;
  const internal::ReplayResult& rr = run.rr;
  const realdata::LagEstimate& stale = run.stale;
  const std::string name = internal::MagPrefix(c);
  // The in-flight model's absolute terms, the same fit as `hexsim calibrate --method flight`. A
  // compass is diagnosed whenever this model can fit it (its own minimum: min_samples samples in
  // min_blocks jackknife blocks, flight_fit.h), else by the channel minimums below.
  // The diagnosis's own staleness scan is the model's where both read the same log with the same
  // resamples and seed (the same computation, done once).
  const bool same_scan = &run.model_log == &run.log && options.bootstrap_samples == realdata::CompassFlightOptions{}.resamples;
  Result<CompassTerms> terms = internal::FitCompassTerms(run.model_log, vehicle, c, name, run.model_windows, options.seed,
                                                         same_scan ? &stale : nullptr);
  // One current shift per compass for the prediction and the in-flight model (PredictionCurrentShift).
  const std::vector<double> shift_grid =
      realdata::CurrentShiftGrid(stale, realdata::UpdatePeriod_s(rr.inputs.current_samples_t));
  const internal::CurrentShift shift = internal::PredictionCurrentShift(terms, stale, run.shift_s, shift_grid);
  const double shift_s = shift.value_s;
  if (!terms.ok() && !(run.flight_s >= options.min_duration_s)) {
    not_diagnosed->emplace_back(name, fmt::format("flight windows too short: {:.1f} s, needs {:.0f} s", run.flight_s,
                                                  options.min_duration_s));
    return std::nullopt;
  }
  std::string field_source, field_why;
  const std::optional<internal::Vec3> field = CompassEarthField(run, c, terms, &field_source, &field_why);
  if (!field) {
    not_diagnosed->emplace_back(name, field_why);
    return std::nullopt;
  }
  const internal::Vec3& B_N = *field;
  internal::CompassReplayOptions ro;
  ro.row_kind = &run.fw.row_kind;
  ro.calibrated_log = !run.sim_truth;
  ro.share_exponent = run.share_exponent;
  internal::CompassTiming timing;
  if (options.timing_scan) {
    timing = internal::ScanCompassTiming(log, vehicle, c, rr.inputs, B_N, ro, stale, shift_s, options);
  }
  // Align only a resolved latency (its interval clear of zero): a zero-width shift changes nothing.
  const bool align = timing.latency_ok && (timing.latency_ci95_s[0] > 0 || timing.latency_ci95_s[1] < 0);
  ro.latency_s = align ? timing.latency_s : 0.0;
  ro.current_shift_s = shift_s;
  ro.reference_yaw = !rr.contaminated.empty();
  ro.fused_by_reference = name == rr.contaminated;
  // The current-driven families' members: the in-flight model's shift grid (one definition).
  ro.member_shifts_s = shift_grid;
  ChannelData ch = internal::ReplayCompass(log, vehicle, c, rr.inputs, B_N, ro);
  const internal::CompassMinimum least = internal::CompassMinSamples(ch);
  // A short flight is diagnosed where the in-flight model fits it on flight samples; a model that
  // needed ground samples too (a log with no flight) leaves the channel nothing to diagnose.
  if (static_cast<int>(ch.t.size()) < least.samples && (!terms.ok() || !terms->flight_only)) {
    not_diagnosed->emplace_back(name, fmt::format("too few flight samples: {}, needs {} ({}); in-flight model: {}",
                                                  ch.t.size(), least.samples, least.why,
                                                  terms.ok() ? terms->windows_note : terms.status().message()));
    return std::nullopt;
  }
  RngStream rng(options.seed, "gap_bootstrap/" + name);
  ChannelResult r = internal::AnalyzeCompass(&ch, log, run.phases, options, timing, &rng);
  if (options.timing_scan) {
    internal::PropagatePlugIns(log, vehicle, c, rr.inputs, B_N, ro, timing, shift.plug_in, options, &r);
  }
  r.nuisance.current_split_exponent = run.fitted_share_exponent;
  r.nuisance.field_source = field_source;
  if (rr.field_free) {
    r.findings.push_back("Earth field " + field_source + ": a uniform scale of the compass is not measured against it");
  }
  for (CandidateResult& k : r.candidates) {
    if (k.id == Effect::kThrottleHardIron) {
      AddCurrentEquivalent(ch, &k);
      GateCurrentEquivalent(terms, &k, &r.findings);
    }
    if (k.id == Effect::kPerMotorCurrentHardIron) AddPerMotorEquivalent(ch, &k);
  }
  ro.want = realdata::RowKind::kGround;
  ro.baseline_only = true;  // the ground-vs-flight check reads the residual, baseline and current only
  const ChannelData ground = internal::ReplayCompass(log, vehicle, c, rr.inputs, B_N, ro);
  r.ground_vs_flight = internal::CompareGroundFlight(ch, ground, r.nuisance);
  if (ro.calibrated_log) {
    const bool wiring = internal::HasWiring(vehicle);
    r.findings.emplace_back(std::string("logged values are the autopilot's calibrated ones: the vehicle file's hard and soft "
                                        "iron are not applied to them") +
                            (wiring ? "; its wiring (current) field still is applied" : ""));
  }
  AttachAbsoluteTerms(std::move(terms), log, &run.model_log != &log, &r);
  return CompassChannel{std::move(r), std::move(ch)};
}

}  // namespace

std::vector<std::string> ClassifyPhases(const logs::FlightLog& log) {
  return realdata::PhaseLabels(log, realdata::FindFlightWindows(log));
}

Result<GapReport> Diagnose(const logs::FlightLog& log, const vehicle::VehicleParams& vehicle_file,
                           const DiagnoseOptions& options) {
  if (log.rows() == 0) return Status::BadInput("log: no rows");
  if (!log.Has("t_s")) return Status::BadInput("log: t_s: column missing");
  if (options.nuisance_ranges != "normal" && options.nuisance_ranges != "exact") {
    return Status::BadInput("nuisance_ranges: '" + options.nuisance_ranges + "': expected normal or exact");
  }
  GapReport rep;
  rep.log_name = log.meta.value("source", std::string("log"));
  // Compass c of `vehicle` is the one log compass c is compared with (compass_map.h).
  rep.compass_mapping = internal::MapCompasses(log, vehicle_file);
  const vehicle::VehicleParams vehicle = internal::WithCompassesInLogOrder(vehicle_file, rep.compass_mapping);
  const auto& t = log.Column("t_s");
  const double duration = t.back() - t.front();
  const realdata::FlightWindows fw = Windows(log, options);
  rep.windows_source = fw.armed_source;
  for (const auto& w : fw.windows) rep.windows.push_back({w.start_s, w.end_s, w.kind, w.why, w.on_ground});
  const std::vector<std::string> phases = realdata::PhaseLabels(log, fw);
  for (size_t i = 0; i < phases.size();) {
    size_t j = i;
    while (j < phases.size() && phases[j] == phases[i]) ++j;
    rep.phases.push_back({t[i], t[j - 1], phases[i]});
    i = j;
  }
  // The inertial and dynamics replays take airborne rows only: a run on the ground is no flight there.
  internal::ReplayResult rr = internal::Replay(log, vehicle, options, realdata::AirborneRowKind(log, fw));
  rep.attitude_source = rr.attitude_source;
  rep.field_model = rr.field_model;
  rep.earth_field_N_uT = rr.earth_field_N_uT;
  rep.headline_share = options.headline_share;
  rep.not_diagnosed = rr.not_diagnosed;
  const bool sim_truth = log.meta.value("source", std::string()) == "hexsim";
  const realdata::LagEstimate stale = internal::CurrentStaleness(log, fw.row_kind, options);
  // The logged current trails the throttle by its logging staleness (plus the motors' own response,
  // tens of ms, which the scan cannot separate). The prediction's current is aligned by the scan's
  // point estimate, the least-squares alignment (a logged channel is never early: at least zero),
  // whenever the scan resolved it inside its plausible range: leaving a stale current unaligned
  // because its interval still touches zero is an estimate too (zero), and a worse one on average:
  // a wiring-field lag of the compass would then be read against a current already late by the
  // staleness, and the two would cancel. A compass whose in-flight model fits the current takes
  // that model's own shift instead (DiagnoseCompass): one shift per compass.
  const double shift_s = realdata::AppliedCurrentShift_s(stale);
  // The motors' current law's exponent, where the replay splits a battery current over them.
  const double fitted_share_exponent = internal::FitShareExponent(log, rr.inputs, vehicle, fw.row_kind, shift_s);
  const double share_exponent = std::isfinite(fitted_share_exponent) ? fitted_share_exponent : internal::kShareExponent;
  double flight_s = 0;
  for (const auto& w : fw.windows) flight_s += w.kind == "flight" ? w.end_s - w.start_s : 0.0;

  auto finish = [&](ChannelResult r, const ChannelData& ch) {
    r.reference_contaminated = ch.name == rr.contaminated;
    if (!ch.note.empty()) r.explanation += (r.explanation.empty() ? "" : "; ") + ch.note;
    if (r.reference_contaminated) {
      r.explanation += (r.explanation.empty() ? "" : "; ") +
                       std::string("the attitude reference fused this compass, so part of its error is absorbed into the "
                                   "reference: diagnose the other compasses against it");
    }
    rep.channels.push_back(std::move(r));
  };
  const logs::FlightLog& model_log = options.compass_model_log != nullptr ? *options.compass_model_log : log;
  const realdata::FlightWindows model_windows = &model_log == &log ? fw : Windows(model_log, options);
  const CompassRun run{log,   vehicle, options, rr,      fw,        phases, model_log, model_windows, stale, shift_s,
                       share_exponent, fitted_share_exponent, flight_s, sim_truth};
  // Every channel into its own slot (on options.threads threads), then the report in channel order.
  using NotDiagnosed = std::vector<std::pair<std::string, std::string>>;
  std::vector<std::optional<CompassChannel>> compass_out(rr.compasses.size());
  std::vector<NotDiagnosed> compass_nd(rr.compasses.size());
  std::vector<std::optional<ChannelResult>> inertial_out(rr.channels.size());
  std::vector<std::function<void()>> tasks;
  for (size_t k = 0; k < rr.compasses.size(); ++k) {
    tasks.emplace_back([&, k] { compass_out[k] = DiagnoseCompass(run, rr.compasses[k], &compass_nd[k]); });
  }
  for (size_t k = 0; k < rr.channels.size(); ++k) {
    const ChannelData& ch = rr.channels[k];
    if (!(duration >= options.min_duration_s) || static_cast<int>(ch.t.size()) < options.min_samples) continue;
    tasks.emplace_back([&, k] {
      RngStream rng(options.seed, "gap_bootstrap/" + rr.channels[k].name);
      inertial_out[k] = internal::AnalyzeInertial(rr.channels[k], log, phases, options, &rng);
    });
  }
  RunTasks(tasks, options.threads);
  for (size_t k = 0; k < rr.compasses.size(); ++k) {
    rep.not_diagnosed.insert(rep.not_diagnosed.end(), compass_nd[k].begin(), compass_nd[k].end());
    std::optional<CompassChannel>& cc = compass_out[k];
    if (!cc) continue;
    for (const CompassPair& p : rep.compass_mapping.pairs) {
      if (p.channel == cc->result.channel) cc->result.vehicle_compass = p.vehicle_compass;
    }
    finish(std::move(cc->result), cc->data);
  }
  for (size_t k = 0; k < rr.channels.size(); ++k) {
    const ChannelData& ch = rr.channels[k];
    if (!(duration >= options.min_duration_s)) {
      rep.not_diagnosed.emplace_back(ch.name, fmt::format("log too short: {:.1f} s, needs {:.0f} s", duration, options.min_duration_s));
    } else if (static_cast<int>(ch.t.size()) < options.min_samples) {
      rep.not_diagnosed.emplace_back(ch.name, fmt::format("too few samples: {}, needs {}", ch.t.size(), options.min_samples));
    } else if (inertial_out[k]) {
      finish(std::move(*inertial_out[k]), ch);
    }
  }
  for (ChannelResult& r : rep.channels) {
    internal::RefreshEffects(&r);
    ReferenceYawFinding(rr.contaminated, &r);
    r.headline = Headline(r);
  }
  return rep;
}

}  // namespace hexsim::gap
