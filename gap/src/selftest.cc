// Blind selftest of the gap diagnosis on pseudo-real simulated logs.
#include "hexsim/gap/selftest.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <fmt/format.h>

#include "hexsim/common/rotation.h"
#include "hexsim/magnetics/current_field.h"
#include "hexsim/magnetics/wmm.h"
#include "hexsim/sim/run_config.h"
#include "selftest_plan.h"
#include "selftest_real.h"

namespace hexsim::gap {
namespace {

using internal::RandomUnit;

// A short battery-current segment next to point p whose field there is d_B (µT per ampere).
magnetics::WireSegment SegmentWithField(const Eigen::Vector3d& p, const Eigen::Vector3d& d_B, const std::string& name) {
  constexpr double kRho_m = 0.003, kHalf_m = 0.002;
  const Eigen::Vector3d dh = d_B.normalized();
  const Eigen::Vector3d u = dh.unitOrthogonal();
  const Eigen::Vector3d mid = p - dh.cross(u) * kRho_m;
  const double per_A = magnetics::kMu0Over4Pi_uTmpA / kRho_m * 2 * kHalf_m / std::hypot(kHalf_m, kRho_m);
  magnetics::WireSegment s;
  s.a_B_m = mid - u * kHalf_m;
  s.b_B_m = mid + u * kHalf_m;
  s.source = magnetics::CurrentSource::kBattery;
  s.share = d_B.norm() / per_A;
  s.name = name;
  return s;
}

Eigen::Matrix3d SensorGain(const magnetics::CompassErrorParams& e) { return e.R_SB * e.scale * e.soft_iron; }

bool IsLogLevel(const std::string& e) {
  return e == "throttle_hard_iron" || e == "temperature_drift" || e == "thermal_ramp" || e == "battery_sag";
}




double Interp(const std::vector<double>& t, const std::vector<double>& v, double tq) {
  auto it = std::lower_bound(t.begin(), t.end(), tq);
  if (it == t.begin()) return v.front();
  if (it == t.end()) return v.back();
  const size_t i = static_cast<size_t>(it - t.begin());
  const double w = (tq - t[i - 1]) / (t[i] - t[i - 1]);
  return (1 - w) * v[i - 1] + w * v[i];
}

struct LogEffect {
  std::string effect;
  Eigen::Vector3d d_s = Eigen::Vector3d::Zero();
};

}  // namespace

const std::vector<EffectRange>& InjectableDynamicsEffects() {
  static const std::vector<EffectRange> kEffects = {
      {"rotor_drag", 3e-5, 8e-5, false},          {"ground_effect", 0.2, 0.35, false},
      {"battery_sag", 0.03, 0.08, false},         {"motor_time_constant", 0.03, 0.08, false},
      {"wind", 2.0, 5.0, false},
  };
  return kEffects;
}

const std::vector<EffectRange>& InjectableEffects() {
  static const std::vector<EffectRange> kEffects = {
      {"current_hard_iron", 0.1, 0.6, false},  {"current_soft_iron", 0.002, 0.006, false},
      {"misalignment", 1.5, 5.0, false},       {"field_scale", 0.02, 0.06, true},
      {"local_anomaly", 1.0, 4.0, false},      {"current_lag", 0.1, 0.5, false},
      {"hard_iron_offset", 1.0, 5.0, false},   {"throttle_hard_iron", 15.0, 40.0, false},
      {"temperature_drift", 0.05, 0.2, false},
  };
  return kEffects;
}

const std::vector<EffectRange>& RealInjectableEffects() {
  // Sizes a real aircraft shows; the nuisance terms beyond their normal ranges (offset > 5 µT,
  // anomaly > 3 µT, scale > 5 %), since inside them they are not findings on a real log.
  static const std::vector<EffectRange> kEffects = {
      {"current_hard_iron", 0.2, 0.8, false},  {"current_soft_iron", 0.002, 0.006, false},
      {"misalignment", 3.0, 8.0, false},       {"field_scale", 0.08, 0.15, true},
      {"local_anomaly", 6.0, 12.0, false},     {"current_lag", 0.1, 0.5, false},
      {"hard_iron_offset", 10.0, 20.0, false}, {"throttle_hard_iron", 15.0, 40.0, false},
      {"temperature_drift", 0.05, 0.2, false},
      // Forms beyond the library's names: one axis' gain off by a few per cent (a static per-axis
      // scale: a calibration error, not a current effect), and a compass later than the vehicle
      // file models (by 40..80 ms; the modelled part is the log's latency less it, at least 0).
      {"axis_scale_error", 0.03, 0.08, true},  {"unmodelled_latency", 0.04, 0.08, false},
  };
  return kEffects;
}

Effect TruthLabel(const std::string& injected) {
  if (injected == "axis_scale_error") return Effect::kScaleError;
  if (injected == "unmodelled_latency") return Effect::kLatency;
  return EffectFromName(injected);
}

Result<Trial> MakeTrial(const SelftestOptions& o, uint64_t seed, const std::vector<Injection>& injections, RngStream* rng) {
  sim::RunRequest req;
  req.mission = o.mission.empty() ? "square" : o.mission;
  req.vehicle = o.vehicle;
  req.world = o.world;
  req.estimator = "truth";
  req.seed = seed;
  req.duration_s = o.duration_s;
  auto setup = sim::LoadRunSetup(req);
  if (!setup.ok()) return setup.status();
  Trial trial;
  trial.truth = std::move(*setup);
  trial.configured = trial.truth.vehicle;
  trial.injections = injections;
  auto& v = trial.truth.vehicle;
  if (v.compasses.size() <= kSelftestCompass) return Status::BadInput(o.vehicle + ": the selftest needs at least 2 compasses");
  auto& cp = v.compasses[kSelftestCompass];
  const Eigen::Matrix3d M = SensorGain(cp.error);
  for (const Injection& inj : injections) {
    double truth = inj.magnitude;
    if (inj.effect == "current_hard_iron") {
      const Eigen::Vector3d d_s = RandomUnit(rng) * inj.magnitude;
      v.wiring.segments.push_back(SegmentWithField(cp.position_B_m, M.inverse() * d_s, "withheld"));
      magnetics::CurrentFieldParams only;
      only.segments.push_back(v.wiring.segments.back());
      magnetics::Currents one;
      one.battery_A = 1.0;
      one.motor_A.assign(v.rotors.size(), 0.0);
      truth = (M * magnetics::CurrentDrivenField_uT(only, cp.position_B_m, one)).norm();
    } else if (inj.effect == "current_soft_iron") {
      Eigen::Matrix3d D;
      for (int i = 0; i < 9; ++i) D(i / 3, i % 3) = rng->Normal();
      D *= inj.magnitude / D.norm();
      cp.error.soft_iron_per_A += D;
      truth = (cp.error.R_SB * cp.error.scale * D * M.inverse()).norm();
    } else if (inj.effect == "misalignment") {
      const Eigen::Vector3d phi = RandomUnit(rng) * inj.magnitude * kDegToRad;
      cp.error.R_SB = QuatExp(phi).toRotationMatrix() * cp.error.R_SB;
    } else if (inj.effect == "field_scale") {
      cp.error.scale *= 1.0 + inj.magnitude;
    } else if (inj.effect == "axis_scale_error") {
      // One sensor axis' gain: K = diag(1 + s on that axis)·K. The reported spread of the gains is s.
      // A horizontal axis: a nearly level flight turns the horizontal field through the axes; a
      // vertical axis' gain reads mostly as an offset there, resolved only through the tilt (the
      // real profile's vertical_axis_scale form holds it).
      const int ax = rng->Uniform() < 0.5 ? 0 : 1;
      cp.error.soft_iron.row(ax) *= 1.0 + inj.magnitude;
    } else if (inj.effect == "unmodelled_latency") {
      // Applied to the log by the real profile (fly): the configured vehicle models less latency.
    } else if (inj.effect == "local_anomaly") {
      trial.truth.world.anomaly_N_uT = RandomUnit(rng) * inj.magnitude;
    } else if (inj.effect == "current_lag") {
      cp.current_lag_tau_s = inj.magnitude;
    } else if (inj.effect == "hard_iron_offset") {
      cp.error.hard_iron_uT += RandomUnit(rng) * inj.magnitude;
    } else if (inj.effect == "current_exponent") {
      // Out of library: the whole wiring field ∝ I^(1+m), plus a stronger lead near the compass.
      v.wiring.segments.push_back(SegmentWithField(cp.position_B_m, M.inverse() * RandomUnit(rng) * 0.3, "withheld"));
      v.wiring.exponent = 1.0 + inj.magnitude;
    } else if (inj.effect == "rotor_drag") {
      v.aero.rotor_drag_N_per_radps_mps = inj.magnitude;
    } else if (inj.effect == "ground_effect") {
      v.aero.ground_effect_radius_m = inj.magnitude;
    } else if (inj.effect == "motor_time_constant") {
      // τ ∝ J at a given speed: scale every rotor's inertia so hover gains the extra τ.
      const double factor = 1.0 + inj.magnitude / HoverRotorTimeConstant_s(v);
      v.motor.inertia_kgm2 *= factor;
      for (auto& r : v.rotors) r.inertia_kgm2 *= factor;
    } else if (inj.effect == "wind") {
      const double psi = 2.0 * kPi * rng->Uniform();
      const Eigen::Vector3d w(inj.magnitude * std::cos(psi), inj.magnitude * std::sin(psi), 0.0);
      trial.truth.world.wind.mean_N_mps = w;
      if (trial.truth.mission.wind) trial.truth.mission.wind->mean_N_mps = w;
    } else if (!IsLogLevel(inj.effect)) {
      return Status::BadInput("selftest: unknown effect '" + inj.effect + "'");
    }
    trial.true_magnitude.push_back(truth);
  }
  return trial;
}

Result<logs::FlightLog> FlyTrial(Trial* trial, RngStream* rng) {
  HEXSIM_RETURN_IF_ERROR(sim::ValidateRunSetup(trial->truth));
  sim::RunOutput out = sim::RunMission(trial->truth);
  if (!out.status.ok()) return out.status;
  logs::FlightLog log = std::move(out.log);
  // Log-level injections on the selftest compass, evaluated at each sample's time.
  const std::string pre = kSelftestCompass == 0 ? "mag" : fmt::format("mag{}", kSelftestCompass + 1);
  const auto& t = log.Column("t_s");
  const size_t n = log.rows();
  bool need_temp = false;
  std::vector<LogEffect> effects;
  for (const Injection& inj : trial->injections) {
    if (inj.effect == "battery_sag") {
      // The voltage sensor sits upstream of a resistance ΔR: it reads ΔR·I more than the ESCs get.
      const size_t cv = log.AddColumn("voltage_V");
      const auto& I = log.Column("current_A");
      for (size_t i = 0; i < n; ++i) log.MutableColumn(cv)[i] += inj.magnitude * I[i];
      continue;
    }
    if (!IsLogLevel(inj.effect)) continue;
    effects.push_back({inj.effect, RandomUnit(rng) * inj.magnitude});
    need_temp = need_temp || inj.effect == "temperature_drift";
  }
  if (effects.empty()) return log;
  // Board temperature: warms from 25 °C towards 45 °C with a 40 s time constant, 0.05 °C noise.
  std::vector<double> temp(n);
  for (size_t i = 0; i < n; ++i) temp[i] = 25.0 + 20.0 * (1 - std::exp(-t[i] / 40.0)) + rng->Normal(0, 0.05);
  if (need_temp) {
    const size_t c = log.AddColumn("imu_temp_C");
    for (size_t i = 0; i < n; ++i) log.MutableColumn(c)[i] = temp[i];
  }
  const size_t cx = static_cast<size_t>(log.ColumnIndex(pre + "_x_uT"));
  const auto& mt = log.Column(pre + "_t_s");
  const auto& u = log.Column("control_u");
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(mt[i])) continue;
    Eigen::Vector3d add = Eigen::Vector3d::Zero();
    for (const auto& e : effects) {
      if (e.effect == "throttle_hard_iron") add += e.d_s * Interp(t, u, mt[i]) / 1000.0;
      if (e.effect == "temperature_drift") add += e.d_s * (Interp(t, temp, mt[i]) - 25.0);
      if (e.effect == "thermal_ramp") add += e.d_s * (1 - std::exp(-mt[i] / 30.0));
    }
    for (int a = 0; a < 3; ++a) log.MutableColumn(cx + a)[i] += add[a];
  }
  return log;
}

namespace {

const ChannelResult* Find(const GapReport& r, const std::string& ch) {
  for (const auto& c : r.channels) {
    if (c.channel == ch) return &c;
  }
  return nullptr;
}

internal::SelftestPlan MakePlan(const SelftestOptions& options) {
  internal::SelftestPlan p;
  p.real = options.profile == "real";
  p.o = options;
  if (p.o.mission.empty()) p.o.mission = p.real ? "selftest_flight" : "square";
  // The ideal profile's configured vehicle is the calibrated truth: any significant nuisance term
  // is a finding; on real-profile logs the normal ranges apply.
  p.o.diagnose.nuisance_ranges = p.real ? "normal" : "exact";
  // The real profile reads the selftest compass only (the dynamics channel needs the simulator's row
  // rate; gyro and accel have no targets), except on clean logs, where every compass is diagnosed
  // for the any-compass false-alarm figure. The ideal profile diagnoses every channel.
  p.channel = fmt::format("mag{}", kSelftestCompass + 1);
  p.selftest_only = p.o.diagnose;
  p.every_compass = p.o.diagnose;
  if (p.real) {
    p.selftest_only.channels = {p.channel};
    p.every_compass.channels = {"mag"};
    for (size_t c = 1; c < 8; ++c) p.every_compass.channels.push_back(fmt::format("mag{}", c + 1));
  }
  p.effects = p.real ? &RealInjectableEffects() : &InjectableEffects();
  // The dynamics channel needs the simulator's row rate: the real profile does not run it. The forms
  // beyond the library's names are real-profile logs (their sensors fail as a real log's do).
  p.classes = {"clean", "one_effect", "two_effects", "out_of_library"};
  if (!p.real) p.classes.emplace_back("dynamics_one_effect");
  p.threshold_grid = {0.002, 0.005, 0.01, 0.02, 0.05, 0.1};
  for (const std::string& c : p.classes) p.segments.push_back({c, p.o.trials});
  p.segments.push_back({"threshold", static_cast<int>(p.threshold_grid.size()) * p.o.threshold_trials});
  if (p.real) {
    p.classes.emplace_back("beyond_library");
    p.segments.push_back({"beyond_library", p.o.trials});
  }
  return p;
}

// The truth of the nuisance-like effects corrected by the log's own nuisance terms. The logged
// compass is (1 + s)·(sensor reading) + b: every effect the sensor reads reaches the log through its
// field-norm error s too (no diagnosis can tell a sensor's scale from the size of a field it
// reads), so the truth of each effect is what the log holds.
Status CorrectTruth(const internal::RealLogTruth& lt, Trial* trial) {
  trial->compass_latency_s = lt.latency_s;
  const auto& ct = trial->truth.vehicle.compasses[kSelftestCompass].error;
  const auto& cc = trial->configured.compasses[kSelftestCompass].error;
  const auto& w = trial->truth.world;
  auto wmm = magnetics::EvaluateWmm({w.home_lat_deg, w.home_lon_deg, w.home_alt_m}, w.date_decimal_year, true);
  if (!wmm.ok()) return wmm.status();
  for (size_t i = 0; i < trial->injections.size(); ++i) {
    const std::string& e = trial->injections[i].effect;
    double& tm = trial->true_magnitude[i];
    if (e == "hard_iron_offset") {
      tm = ((1 + lt.scale) * (ct.hard_iron_uT - cc.hard_iron_uT) + lt.scale * cc.hard_iron_uT + lt.offset_uT).norm();
    } else if (e == "field_scale") {
      tm = (1 + trial->injections[i].magnitude) * (1 + lt.scale) - 1;
    } else if (e == "local_anomaly") {
      // The fitted field's difference from WMM: (1 + s)·(B + a) − B.
      tm = ((1 + lt.scale) * (wmm->B_N_uT + w.anomaly_N_uT) - wmm->B_N_uT).norm();
    } else if (e == "current_hard_iron" || e == "current_soft_iron" || e == "throttle_hard_iron" || e == "temperature_drift") {
      tm *= 1 + lt.scale;
    } else if (e == "unmodelled_latency") {
      // The log's latency is the measured one; the vehicle models it less the withheld part.
      trial->compass_latency_s = std::max(0.0, lt.latency_s - trial->injections[i].magnitude);
      tm = lt.latency_s;
    }
  }
  return Status::Ok();
}

// What a trial injects besides its effects: an out-of-library family or a form beyond the library.
struct LogInjection {
  std::string family, form;
  internal::FormTruth form_truth;
};

// Flies a trial; on the real profile adds the log-level form, degrades the log as a real autopilot
// logs it and corrects the truth of the nuisance-like effects.
Result<logs::FlightLog> FlyAsLogged(const internal::SelftestPlan& p, Trial* trial, LogInjection* li, RngStream* rng) {
  auto log = FlyTrial(trial, rng);
  if (!log.ok() || !p.real) return log;
  if (!li->family.empty()) HEXSIM_RETURN_IF_ERROR(internal::InjectOutOfLibrary(&*log, kSelftestCompass, li->family, rng));
  if (!li->form.empty()) {
    auto ft = internal::InjectBeyondLibrary(&*log, kSelftestCompass, li->form, rng);
    if (!ft.ok()) return ft.status();
    li->form_truth = *ft;
  }
  internal::RealLogTruth lt;
  auto deg = internal::DegradeToRealLog(*log, trial->configured, rng, &lt);
  if (!deg.ok()) return deg.status();
  HEXSIM_RETURN_IF_ERROR(CorrectTruth(lt, trial));
  return deg;
}

Result<TrialRecord> ThresholdTrial(const internal::SelftestPlan& p, size_t index, int k, RngStream* rng) {
  const double m = p.threshold_grid[static_cast<size_t>(k / p.o.threshold_trials)];
  auto trial = MakeTrial(p.o, p.o.seed * 100003 + index + 1, {{"current_hard_iron", m}}, rng);
  if (!trial.ok()) return trial.status();
  LogInjection none;
  auto log = FlyAsLogged(p, &*trial, &none, rng);
  if (!log.ok()) return log.status();
  DiagnoseOptions opt = p.selftest_only;
  opt.compass_latency_s = trial->compass_latency_s;
  auto rep = Diagnose(*log, trial->configured, opt);
  if (!rep.ok()) return rep.status();
  const ChannelResult* r = Find(*rep, p.channel);
  ThresholdTrialRecord rec;
  rec.magnitude_uT_per_A = trial->true_magnitude[0];
  rec.flagged = r && r->gap_detected;
  rec.verdict = r ? r->verdict : std::string("not diagnosed");
  return TrialRecord(std::move(rec));
}

// The withheld effects of trial k of class c, and its log-level form.
std::vector<Injection> DrawInjections(const internal::SelftestPlan& p, const std::string& c, int k, RngStream* rng,
                                      LogInjection* li) {
  const auto& effects = *p.effects;
  std::vector<Injection> inj;
  auto draw = [&](size_t e_index) {
    const EffectRange& e = effects[e_index];
    double m = e.lo + (e.hi - e.lo) * rng->Uniform();
    if (e.signed_magnitude && rng->Uniform() < 0.5) m = -m;
    return Injection{e.effect, m};
  };
  if (c == "one_effect") {
    inj.push_back(draw(static_cast<size_t>(k) % effects.size()));
  } else if (c == "dynamics_one_effect") {
    const auto& dyn = InjectableDynamicsEffects();
    const EffectRange& e = dyn[static_cast<size_t>(k) % dyn.size()];
    inj.push_back({e.effect, e.lo + (e.hi - e.lo) * rng->Uniform()});
  } else if (c == "two_effects") {
    const size_t a = static_cast<size_t>(rng->Uniform() * static_cast<double>(effects.size()));
    size_t b = static_cast<size_t>(rng->Uniform() * static_cast<double>(effects.size() - 1));
    if (b >= a) ++b;
    inj.push_back(draw(a));
    inj.push_back(draw(b));
  } else if (c == "out_of_library" && p.real) {
    const auto& fams = internal::OutOfLibraryFamilies();
    li->family = fams[static_cast<size_t>(rng->Uniform() * static_cast<double>(fams.size())) % fams.size()].name;
  } else if (c == "out_of_library") {
    if (k % 2 == 0) inj.push_back({"current_exponent", 0.3 + 0.5 * rng->Uniform()});
    else inj.push_back({"thermal_ramp", 2.0 + 4.0 * rng->Uniform()});
  } else if (c == "beyond_library") {
    const auto& forms = internal::BeyondLibraryForms();
    li->form = forms[static_cast<size_t>(k) % forms.size()].name;
  }
  return inj;
}

// The verdict names the registered effect e.
bool Names(const std::string& verdict, Effect e) { return e != Effect::kNone && verdict == Info(e).name; }

// The reported candidates of the injected effects, and whether the injected form's interval holds
// its truth (one effect).
void ReportTruth(const Trial& trial, const ChannelResult& r, bool one, ClassTrialRecord* out) {
  for (const auto& cand : r.candidates) {
    const bool injected = std::any_of(out->injected.begin(), out->injected.end(),
                                      [&](const InjectedEffect& x) { return x.label != Effect::kNone && x.label == cand.id; });
    if (!injected) continue;
    const ReportedEffect rep{cand.id, cand.magnitude, {cand.magnitude_ci95[0], cand.magnitude_ci95[1]}, cand.explained_share,
                             cand.selected};
    // One entry per effect: a later candidate of the same effect replaces an earlier one.
    auto same = std::find_if(out->reported.begin(), out->reported.end(), [&](const ReportedEffect& e) { return e.effect == cand.id; });
    if (same == out->reported.end()) out->reported.push_back(rep);
    else *same = rep;
  }
  if (!one) return;
  // The true effect's held-out explained share (of the baseline residual), 0 when not reported.
  const std::string& injected = out->injected[0].name;
  const Effect label = out->injected[0].label;
  double true_share = 0;
  for (const auto& cand : r.candidates) {
    if (label != Effect::kNone && cand.id == label && (cand.selected || true_share == 0)) true_share = cand.explained_share;
  }
  out->true_share = true_share;
  for (const auto& cand : r.candidates) {
    // The reported candidate of the injected form (the nuisance term for a uniform scale).
    if (label == Effect::kNone || cand.id != label || (injected == "axis_scale_error" && cand.nuisance_term) ||
        (injected == "field_scale" && !cand.nuisance_term)) {
      continue;
    }
    // The per-axis family reports the spread of the gains (≥ 0); every other form its signed size.
    const double tm = injected == "axis_scale_error" ? std::fabs(trial.true_magnitude[0]) : trial.true_magnitude[0];
    out->covered = tm >= cand.magnitude_ci95[0] && tm <= cand.magnitude_ci95[1];
    break;
  }
}

// A form's judgement: named right (the verdict is one of the effects it is a form of), and right
// (named right, or not confident); the lag candidate's fit beside a lagged form's truth.
void JudgeForm(const std::string& name, const LogInjection& li, const ChannelResult& r, ClassTrialRecord* out) {
  const internal::LogForm* form = internal::FindForm(name);
  bool named = false;
  if (form) {
    named = std::any_of(form->named_right.begin(), form->named_right.end(), [&](Effect e) { return Names(r.verdict, e); });
  }
  out->named_right = named;
  out->judged_right = named || out->not_confident;
  if (!std::isfinite(li.form_truth.lag_s)) return;
  out->true_lag_s = li.form_truth.lag_s;
  for (const auto& cand : r.candidates) {
    if (cand.id != Effect::kCurrentLag || name != "current_power_lag") continue;
    LagFit fit;
    fit.tau_s = cand.magnitude;
    fit.ci95_s = {cand.magnitude_ci95[0], cand.magnitude_ci95[1]};
    fit.selected = cand.selected;
    fit.plausible = cand.plausible;
    // Recovered: named current_lag, its lag's interval holding the truth.
    fit.named = Names(r.verdict, Effect::kCurrentLag);
    fit.covered = cand.magnitude_ci95[0] <= li.form_truth.lag_s && li.form_truth.lag_s <= cand.magnitude_ci95[1];
    out->lag_fit = fit;
  }
}

// What the metrics need of a class trial.
ClassTrialRecord Outcome(const std::string& c, const std::vector<Injection>& inj, const LogInjection& li, const Trial& trial,
                         const GapReport& rep, const ChannelResult& r) {
  ClassTrialRecord out;
  out.family = li.family.empty() ? li.form : li.family;
  out.verdict = r.verdict;
  out.gap_detected = r.gap_detected;
  out.heldout_shrink = r.heldout_shrink;
  for (const Injection& x : inj) out.injected.push_back({x.effect, TruthLabel(x.effect)});
  // Honest about an out-of-library form: not explained, ambiguous, partial, or the structure it
  // leaves reported beside the headline (CONTRACTS.md: the leftover is never a veto).
  bool left_reported = false;
  for (const std::string& f : r.findings) left_reported = left_reported || f.find("structure no candidate describes") != std::string::npos;
  out.left_reported = left_reported;
  out.not_confident = r.verdict == "unexplained" || r.verdict == "ambiguous" || r.partial || left_reported;
  if (!out.family.empty()) JudgeForm(out.family, li, r, &out);
  int in_effects = 0;
  for (const InjectedEffect& x : out.injected) {
    for (const EffectShare& e : r.effects) in_effects += x.label != Effect::kNone && e.id == x.label ? 1 : 0;
  }
  out.all_in_effects = in_effects >= static_cast<int>(inj.size()) && !inj.empty();
  // The trial as it came out (reported under "trials"): the truth beside what was reported of it.
  out.true_magnitude = trial.true_magnitude;
  out.explained_share = r.explained_share;
  for (const auto& cand : r.candidates) {
    if (cand.selected) out.selected += (out.selected.empty() ? "" : "+") + cand.effect;
  }
  if (c == "clean") {
    if (const ChannelResult* d = Find(rep, "dynamics")) out.dynamics_detected = d->gap_detected;
  }
  out.any_compass_alarm = std::any_of(rep.channels.begin(), rep.channels.end(),
                                      [](const ChannelResult& cr) { return cr.unit == "uT" && cr.gap_detected; });
  ReportTruth(trial, r, c == "one_effect" || c == "dynamics_one_effect", &out);
  return out;
}

Result<TrialRecord> ClassTrial(const internal::SelftestPlan& p, size_t index, const std::string& c, int k, RngStream* rng) {
  LogInjection li;
  const std::vector<Injection> inj = DrawInjections(p, c, k, rng, &li);
  auto trial = MakeTrial(p.o, p.o.seed * 100003 + index + 1, inj, rng);
  if (!trial.ok()) return trial.status();
  auto log = FlyAsLogged(p, &*trial, &li, rng);
  if (!log.ok()) return log.status();
  DiagnoseOptions opt = c == "clean" ? p.every_compass : p.selftest_only;
  opt.compass_latency_s = trial->compass_latency_s;
  auto rep = Diagnose(*log, trial->configured, opt);
  if (!rep.ok()) return rep.status();
  const std::string channel = c == "dynamics_one_effect" ? "dynamics" : p.channel;
  const ChannelResult* r = Find(*rep, channel);
  if (!r) return Status::Numerical("selftest: channel " + channel + " was not diagnosed");
  return TrialRecord(Outcome(c, inj, li, *trial, *rep, *r));
}

}  // namespace

namespace internal {

Slot Locate(const SelftestPlan& plan, size_t index) {
  int i = static_cast<int>(index);
  for (const Segment& s : plan.segments) {
    if (i < s.trials) return {&s, i};
    i -= s.trials;
  }
  return {};
}

}  // namespace internal

Result<SelftestResult> RunSelftest(const SelftestOptions& options, void (*progress)(int, int), const TrialRunner& runner) {
  if (options.trials < 1) return Status::BadInput("--trials: must be >= 1");
  if (options.profile != "real" && options.profile != "ideal") return Status::BadInput("--profile: expected real or ideal");
  const internal::SelftestPlan plan = MakePlan(options);
  const int total = plan.total();
  // Every trial is independent (its own simulator seed and random stream, SelftestPlan), so the
  // runner may run them in any order or in parallel; the metrics are summed in trial order.
  auto run_trial = [&plan](size_t index) -> Result<TrialRecord> {
    RngStream rng(plan.o.seed, fmt::format("gap_selftest/{}", index));
    const internal::Slot slot = internal::Locate(plan, index);
    if (!slot.segment) return Status::Numerical("selftest: no trial " + std::to_string(index));
    if (slot.segment->cls == "threshold") return ThresholdTrial(plan, index, slot.k, &rng);
    return ClassTrial(plan, index, slot.segment->cls, slot.k, &rng);
  };
  int done = 0;
  auto serial = [&](size_t n, const TrialFn& one) -> Result<std::vector<TrialRecord>> {
    std::vector<TrialRecord> outs;
    for (size_t i = 0; i < n; ++i) {
      auto r = one(i);
      if (!r.ok()) return r.status();
      outs.push_back(std::move(*r));
      if (progress) progress(++done, total);
    }
    return outs;
  };
  auto outcomes = runner ? runner(static_cast<size_t>(total), run_trial) : serial(static_cast<size_t>(total), run_trial);
  if (!outcomes.ok()) return outcomes.status();
  if (outcomes->size() != static_cast<size_t>(total)) return Status::Numerical("selftest: the runner lost trials");
  return internal::SummariseSelftest(plan, std::move(*outcomes));
}

}  // namespace hexsim::gap
