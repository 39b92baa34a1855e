// gap.json (hexsim.gap/1 with the real-data keys of CONTRACTS.md) and the stdout summary.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "compass_terms_fit.h"
#include "hexsim/common/plausibility.h"
#include "hexsim/gap/diagnose.h"
#include "hexsim/gap/json.h"

namespace hexsim::gap {

namespace {

using nlohmann::json;

json Vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
json Pair(const Interval& i) { return {i.lo, i.hi}; }

json ParamsJson(const CandidateResult& k) {
  json p = json::object();
  for (const auto& [name, v] : k.params) p[name] = v;
  if (k.nuisance_term) p["nuisance"] = true;
  return p;
}

json IntervalsJson(const ParamIntervals& ci) {
  json j = json::object();
  for (const auto& [name, i] : ci) j[name] = Pair(i);
  return j;
}

json WhereJson(const Where& w) {
  if (!w.present) return json::object();
  json regime = json::object();
  for (const auto& [name, split] : w.regime) {
    json bins = json::array();
    for (const RegimeBin& b : split.bins) bins.push_back({{"bin", b.bin}, {"rms", b.rms}, {"samples", b.samples}});
    regime[name] = {{"edges", {split.edges[0], split.edges[1], split.edges[2]}}, {"bins", bins}};
  }
  regime["concentrated"] = w.regime_concentrated;
  json rms_phase = json::object();
  for (const auto& [ph, rms] : w.rms_by_phase) rms_phase[ph] = rms;
  return {{"phase", {{"rms_by_phase", rms_phase}, {"concentrated", w.phase_concentrated}}},
          {"regime", regime},
          {"band",
           {{"below_0.2Hz", w.band_below_0p2Hz},
            {"0.2_to_2Hz", w.band_0p2_to_2Hz},
            {"above_2Hz", w.band_above_2Hz},
            {"concentrated", w.band_concentrated}}},
          {"rms", w.rms}};
}

json NuisanceJson(const Nuisance& n) {
  if (!n.present) {
    return std::isfinite(n.current_split_exponent) ? json{{"current_split_exponent", n.current_split_exponent}}
                                                   : json::object();
  }
  json j = {{"offset_uT", Vec(n.offset_uT)},
            {"offset_ci95_uT", Pair(n.offset_ci95_uT)},
            {"field_scale", n.field_scale},
            {"field_scale_horizontal", n.field_scale_horizontal},
            {"field_vector_N_uT", Vec(n.field_vector_N_uT)},
            {"field_prior_N_uT", Vec(n.field_prior_N_uT)},
            {"field_correction_N_uT", Vec(n.field_correction_N_uT)},
            {"field_direction_error_uT", n.field_direction_error_uT},
            {"field_source", n.field_source},
            {"undone_compensation", n.undone_compensation},
            {"ranges", n.ranges}};
  if (std::isfinite(n.current_split_exponent)) j["current_split_exponent"] = n.current_split_exponent;
  return j;
}

json LagJson(const LagReport& l) {
  json j = {{"value", l.value_s}, {"ci95", Pair(l.ci95_s)}, {"against", l.against}, {"resolved", l.resolved},
            {"plausible", l.plausible}};
  if (std::isfinite(l.explained_share)) j["explained_share"] = l.explained_share;
  if (std::isfinite(l.applied_shift_s)) j["applied_shift_s"] = l.applied_shift_s;
  return j;
}

json TimingJson(const Timing& t) {
  json j = json::object();
  if (t.current_field_lag.present) j["current_field_lag_s"] = LagJson(t.current_field_lag);
  if (!t.latency.present && !t.current_staleness.present) return j;
  json st = json::object();
  if (t.current_staleness.present) st["current_A"] = LagJson(t.current_staleness);
  j["regressor_staleness_s"] = st;
  if (t.latency.present) j["latency_s"] = LagJson(t.latency);
  return j;
}

json ResidualLeftJson(const ResidualLeft& r) {
  if (!r.present) return json::object();
  return {{"share", r.share}, {"dominant_freq_Hz", r.dominant_freq_Hz}, {"trend", r.trend}, {"spikes", r.spikes},
          {"concentrated", r.concentrated}};
}

json GroundVsFlightJson(const GroundVsFlight& g) {
  if (!g.present) return json::object();
  json j = {{"ground_samples", g.ground_samples}, {"delta_B_uT", Vec(g.delta_B_uT)}, {"delta_I_A", g.delta_I_A}};
  if (std::isfinite(g.mG_per_A)) j["mG_per_A"] = g.mG_per_A;
  return j;
}

json EffectsJson(const std::vector<EffectShare>& effects) {
  json a = json::array();
  for (const EffectShare& e : effects) {
    json j = {{"effect", e.effect},       {"magnitude", e.magnitude}, {"ci95", Pair(e.ci95)},
              {"unit", e.unit},           {"explained_share", e.explained_share}, {"source", e.source}};
    if (!e.autopilot_unit.empty()) {
      j["autopilot_unit"] = e.autopilot_unit;
      j["autopilot_magnitude"] = e.autopilot_factor * e.magnitude;
      j["autopilot_ci95"] = {e.autopilot_factor * e.ci95.lo, e.autopilot_factor * e.ci95.hi};
    }
    a.push_back(j);
  }
  return a;
}

json CompassMappingJson(const CompassMapping& m) {
  json pairs = json::array();
  for (const CompassPair& p : m.pairs) {
    pairs.push_back({{"channel", p.channel}, {"vehicle_compass", p.vehicle_compass}, {"external", p.external}});
  }
  return {{"method", m.method}, {"why", m.why}, {"pairs", pairs}};
}

json CandidateJson(const CandidateResult& k) {
  return {{"effect", k.effect},
          {"probability", k.probability},
          {"params", ParamsJson(k)},
          {"ci95", IntervalsJson(k.ci95)},
          {"heldout_shrink", k.heldout_shrink},
          {"p_value", k.p_value},
          {"magnitude", k.magnitude},
          {"magnitude_ci95", {k.magnitude_ci95[0], k.magnitude_ci95[1]}},
          {"magnitude_unit", k.magnitude_unit},
          {"selected", k.selected},
          {"explained_share", k.explained_share},
          {"plausible", k.plausible},
          {"physical_range", k.physical_range},
          {"parameters", k.parameters}};
}

}  // namespace

std::string ParamsText(const Params& params) {
  std::string s;
  for (const auto& [name, v] : params) s += fmt::format("{}{}={:.4g}", s.empty() ? "" : ", ", name, v);
  return s;
}

nlohmann::json ToJson(const GapReport& r) {
  json j;
  j["schema"] = "hexsim.gap/1";
  j["log"] = r.log_name;
  j["attitude_source"] = r.attitude_source;
  j["field_model"] = r.field_model;
  j["earth_field_N_uT"] = Vec(r.earth_field_N_uT);
  j["headline_share"] = r.headline_share;
  j["compass_mapping"] = CompassMappingJson(r.compass_mapping);
  j["channels"] = json::array();
  for (const auto& c : r.channels) {
    json cj;
    cj["channel"] = c.channel;
    if (c.vehicle_compass > 0) cj["vehicle_compass"] = c.vehicle_compass;
    cj["unit"] = c.unit;
    cj["samples"] = c.samples;
    cj["rms_before"] = c.rms_before;
    cj["noise_rms"] = c.noise_rms;
    if (c.measured_floor_rms > 0) cj["measured_floor_rms"] = c.measured_floor_rms;
    cj["noise_floor_ratio"] = c.noise_floor_ratio;
    cj["gap_detected"] = c.gap_detected;
    cj["p_value"] = c.p_value;
    cj["ljung_box_p"] = c.ljung_box_p;
    cj["reference_contaminated"] = c.reference_contaminated;
    cj["where"] = WhereJson(c.where);
    cj["verdict"] = c.verdict;
    cj["partial"] = c.partial;
    cj["explanation"] = c.explanation;
    cj["effects"] = EffectsJson(c.effects);
    cj["candidates"] = json::array();
    for (const auto& k : c.candidates) cj["candidates"].push_back(CandidateJson(k));
    cj["heldout_shrink"] = c.heldout_shrink;
    cj["not_available"] = c.not_available;
    cj["explained_share"] = c.explained_share;
    cj["nuisance"] = NuisanceJson(c.nuisance);
    cj["timing"] = TimingJson(c.timing);
    cj["residual_left"] = ResidualLeftJson(c.residual_left);
    cj["ground_vs_flight"] = GroundVsFlightJson(c.ground_vs_flight);
    cj["findings"] = c.findings;
    cj["headline"] = c.headline;
    if (c.absolute_terms) cj["absolute_terms"] = internal::CompassTermsJson(*c.absolute_terms);
    j["channels"].push_back(cj);
  }
  j["not_diagnosed"] = json::array();
  for (const auto& [ch, why] : r.not_diagnosed) j["not_diagnosed"].push_back({{"channel", ch}, {"why", why}});
  j["phases"] = json::array();
  for (const auto& p : r.phases) j["phases"].push_back({{"phase", p.phase}, {"t0_s", p.t0_s}, {"t1_s", p.t1_s}});
  j["effects_not_built"] = r.effects_not_built;
  j["windows"] = json::array();
  for (const auto& w : r.windows) {
    j["windows"].push_back({{"start_s", w.start_s}, {"end_s", w.end_s}, {"kind", w.kind}, {"why", w.why},
                            {"on_ground", w.on_ground}});
  }
  j["windows_source"] = r.windows_source;
  return j;
}

namespace {

// An effect's size in its physical unit and, where one exists, the autopilot's (mG/A for a current
// term, also for a throttle or per-motor form through its battery-current equivalent).
std::string EffectSize(const EffectShare& e) {
  // The per-motor form's coefficients are fields at full output (its regressors are the outputs,
  // u_i^0.65, not a current): its size is their norm over motors and axes at output 1.
  const char* at = e.id == Effect::kPerMotorCurrentHardIron ? " at full output (all motors)" : "";
  if (e.unit == "s") return fmt::format("{:.0f} [{:.0f}, {:.0f}] ms", 1000 * e.magnitude, 1000 * e.ci95.lo, 1000 * e.ci95.hi);
  if (e.unit == "uT/A") return fmt::format("{:.1f} [{:.1f}, {:.1f}] mG/A", kMilliGaussPerMicroTesla * e.magnitude, kMilliGaussPerMicroTesla * e.ci95.lo,
                                                    kMilliGaussPerMicroTesla * e.ci95.hi);
  if (e.unit == "uT" && e.autopilot_unit == "mG") return fmt::format("{:.1f} [{:.1f}, {:.1f}] mG{}", kMilliGaussPerMicroTesla * e.magnitude,
                                                                    kMilliGaussPerMicroTesla * e.ci95.lo, kMilliGaussPerMicroTesla * e.ci95.hi, at);
  std::string m = fmt::format("{:.3g} [{:.3g}, {:.3g}] {}{}", e.magnitude, e.ci95.lo, e.ci95.hi, e.unit, at);
  if (e.autopilot_unit == "mG/A") {
    m += fmt::format(" (= {:.1f} [{:.1f}, {:.1f}] mG/A in battery-current terms)", e.autopilot_factor * e.magnitude,
                     e.autopilot_factor * e.ci95.lo, e.autopilot_factor * e.ci95.hi);
  }
  return m;
}

// The in-flight model's absolute term beside a current-driven effect (the number hexsim calibrate
// prints and writes as COMPASS_MOT / COMPASS_MOTCT 1), so that both commands visibly give one
// answer; empty for any other effect or where the model fitted no plausible term.
std::string AbsoluteBeside(const ChannelResult& c, const EffectShare& e) {
  if (!Info(e.id).compensable || !c.absolute_terms) return "";
  const CompassTerms& t = *c.absolute_terms;
  if (!t.term_fitted || !t.term_plausible) return "";
  const bool throttle = t.form == "throttle";
  // A fit that saw no flight (CompassTerms::ground_run_note) writes no compensation: said beside it.
  const std::string use = t.ground_run_note.empty() ? std::string(throttle ? "COMPASS_MOTCT 1" : "COMPASS_MOT")
                                                    : "not written: the fit saw no flight";
  return fmt::format(", absolute {} term {:.1f} [{:.1f}, {:.1f}] {} ({}, as hexsim calibrate)", throttle ? "throttle" : "current",
                     kMilliGaussPerMicroTesla * t.term_norm_uT, kMilliGaussPerMicroTesla * t.term_norm_ci95_uT[0], kMilliGaussPerMicroTesla * t.term_norm_ci95_uT[1],
                     throttle ? "mG per unit throttle" : "mG/A", use);
}

std::string LeftText(const ResidualLeft& l) {
  if (!l.present) return "";
  return fmt::format("; left: {:.0f} %, dominant {:.2g} Hz, trend {:.0f} %, in {}", 100 * l.share, l.dominant_freq_Hz,
                     100 * l.trend, l.concentrated.empty() ? "no phase or regime" : l.concentrated);
}

// A held-out residual of at least this many times the noise floor's power is not the floor (a white
// residual's ratio is 1 within a few per cent on any channel diagnosed: ≥ 400 samples); below it the
// verdict says "at the noise floor".
constexpr double kAboveFloorRatio = 2.0;

// The verdict without the field's source.
std::string HeadlineBody(const ChannelResult& c) {
  if (!c.gap_detected && c.noise_floor_ratio >= kAboveFloorRatio) {  // slow structure no test resolves
    return fmt::format("{}: no gap resolved: the residual holds {:.1f} times the noise floor's power, but neither the "
                       "library-free fit, a spectral line nor spikes separate structure from it on this log "
                       "(a short or quiet flight): nothing to attribute",
                       c.channel, c.noise_floor_ratio);
  }
  if (!c.gap_detected) {
    return fmt::format("{}: no gap: residual at the noise floor (power ratio {:.2f})", c.channel, c.noise_floor_ratio);
  }
  if (c.effects.empty() || c.verdict == "unexplained" || c.verdict == "ambiguous") {
    return fmt::format("{}: {}: {}{}", c.channel, c.verdict, c.explanation, LeftText(c.residual_left));
  }
  const EffectShare& top = c.effects.front();
  if (top.source == "nuisance") {
    return fmt::format("{}: {} {} (a nuisance term outside its normal range): {}", c.channel, c.verdict, EffectSize(top),
                       c.explanation);
  }
  // The absolute term once, beside the first current-driven effect.
  std::string absolute = AbsoluteBeside(c, top);
  // A negative held-out share (an effect material by the heading it turns, which held out predicts
  // worse than the baseline) is said as such, not as a negative part explained.
  const std::string explains =
      top.explained_share >= 0
          ? fmt::format("explains {:.0f} % of the held-out structure above the noise floor", 100 * top.explained_share)
          : fmt::format("explains none of the held-out structure above the noise floor (held out it predicts {:.0f} % "
                        "worse than the baseline; see the findings)",
                        -100 * top.explained_share);
  std::string s = fmt::format("{}: {} {}{}, {}{}", c.channel, c.verdict, EffectSize(top), absolute, explains,
                              c.partial ? " (partial)" : "");
  for (size_t i = 1; i < c.effects.size(); ++i) {
    const std::string beside = absolute.empty() ? AbsoluteBeside(c, c.effects[i]) : std::string();
    absolute += beside;
    // A nuisance term beside the fitted effects is a gap the baseline absorbed (its offset or field
    // beyond the normal range): it removes nothing over that baseline, so it has no share to print.
    const std::string share = c.effects[i].source == "nuisance" ? "beyond its normal range, absorbed by the baseline"
                                                                : fmt::format("{:.0f} %", 100 * std::max(0.0, c.effects[i].explained_share));
    s += fmt::format("; also {} {}{} ({})", c.effects[i].effect, EffectSize(c.effects[i]), beside, share);
  }
  return s + LeftText(c.residual_left);
}

std::string CompassMappingText(const CompassMapping& m) {
  if (m.pairs.empty()) return "";
  std::string s = "compasses compared with the vehicle file's";
  for (const CompassPair& p : m.pairs) {
    s += fmt::format("{} {} → compass {} ({})", &p == m.pairs.data() ? ":" : ",", p.channel, p.vehicle_compass,
                     p.external ? "external" : "internal");
  }
  return s + fmt::format("; by {} ({})\n", m.method == "external_flag" ? "the external flag" : "index", m.why);
}

}  // namespace

std::string Headline(const ChannelResult& c) {
  // A compass diagnosed without the field model (no GPS fix) says so in its verdict.
  const bool free_field = c.nuisance.field_source.rfind("fitted", 0) == 0;
  return HeadlineBody(c) + (free_field ? "; Earth field fitted freely (no place and date)" : "");
}

std::string FieldScaleText(const Nuisance& n) {
  const std::string against = n.field_source.rfind("fitted", 0) == 0 ? "the freely fitted field" : "WMM";
  // A horizontal part along the model's at zero or against it has no size a compass could read (a
  // 14S public log printed "field -105.9 %"): said as a direction, a model mismatch.
  if (!(n.field_scale_horizontal > 0)) {
    return fmt::format("fitted horizontal field points against {}'s: model mismatch (the heading of the attitude, the "
                       "compass's orientation or its units)",
                       against);
  }
  std::string s = fmt::format("field {:+.1f} % against {} (horizontal part", 100 * (n.field_scale_horizontal - 1), against);
  if (plausibility::IsPlausible("field_scale", n.field_scale)) {
    return s + fmt::format("; norm {:+.1f} %)", 100 * (n.field_scale - 1));
  }
  return s + "; the norm is not resolved: in a nearly level flight the vertical field trades with the z offset)";
}

std::string Summary(const GapReport& r) {
  std::string s = CompassMappingText(r.compass_mapping);
  if (!r.windows.empty()) {
    s += "windows (" + r.windows_source + "):";
    for (const auto& w : r.windows) {
      s += fmt::format(" {}{} {:.1f}-{:.1f} s;", w.kind, w.on_ground ? " on the ground" : "", w.start_s, w.end_s);
    }
    s += "\n";
  }
  for (const auto& c : r.channels) {
    const bool mag = c.unit == "uT";
    const double k = mag ? kMilliGaussPerMicroTesla : 1.0;
    const std::string unit = mag ? "mG" : c.unit;
    s += fmt::format("{}: residual {:.3g} {} RMS (noise {:.2g})", c.channel, c.rms_before * k, unit, c.noise_rms * k);
    if (c.reference_contaminated) s += " [reference-contaminated]";
    s += "\n  verdict: " + c.headline + "\n";
    if (c.absolute_terms) s += internal::CompassTermsText(*c.absolute_terms) + "\n";
    if (c.timing.latency.present || c.timing.current_field_lag.present) {
      std::string line;
      const auto add = [&line](const char* what, const LagReport& l) {
        if (!l.present) return;
        line += fmt::format("{}{} {:.0f} ms [{:.0f}, {:.0f}]", line.empty() ? "" : "; ", what, 1000 * l.value_s,
                            1000 * l.ci95_s.lo, 1000 * l.ci95_s.hi);
      };
      if (c.timing.latency.present && !c.timing.latency.resolved) {  // a flat profile: no number to act on
        line += fmt::format("compass latency not resolved by the attitude scan (its interval reaches the scan's edge: "
                            "[{:.0f}, {:.0f}] ms)",
                            1000 * c.timing.latency.ci95_s.lo, 1000 * c.timing.latency.ci95_s.hi);
      } else {
        add("compass latency", c.timing.latency);
      }
      const LagReport& st = c.timing.current_staleness;
      if (c.timing.latency.present && st.present) {
        if (st.resolved && st.plausible && plausibility::IsPlausible("current_staleness", st.value_s)) {
          add("current staleness", st);
        } else {  // its point outside 0..1 s or on the scan's edge: no number to act on
          line += fmt::format("; current staleness not resolved by the throttle scan ({})",
                              st.resolved ? "its point lies outside the physical range 0..1 s" : "its point or its interval reaches the scan's edge");
        }
      }
      const LagReport& fl = c.timing.current_field_lag;
      if (fl.present && !fl.resolved) {  // measured as the latency is: a flat profile is no number to act on
        line += fmt::format("{}current field lag behind the current not resolved ([{:.0f}, {:.0f}] ms)",
                            line.empty() ? "" : "; ", 1000 * fl.ci95_s.lo, 1000 * fl.ci95_s.hi);
      } else {
        add("current field lag behind the current", fl);
      }
      s += "  timing: " + line + "\n";
    }
    if (c.nuisance.present) {
      const Eigen::Vector3d& o = c.nuisance.offset_uT;
      s += fmt::format("  nuisance: offset ({:.0f}, {:.0f}, {:.0f}) mG, {}", kMilliGaussPerMicroTesla * o.x(),
                       kMilliGaussPerMicroTesla * o.y(), kMilliGaussPerMicroTesla * o.z(), FieldScaleText(c.nuisance));
      // Without per-motor currents: how the replay split the battery current over the motors.
      if (std::isfinite(c.nuisance.current_split_exponent)) {
        s += fmt::format("; motor currents split as output^{:.2f}", c.nuisance.current_split_exponent);
      }
      s += "\n";
    }
    if (c.ground_vs_flight.present && std::isfinite(c.ground_vs_flight.mG_per_A)) {
      s += fmt::format("  ground vs flight: {:.1f} mG/A over {:.1f} A\n", c.ground_vs_flight.mG_per_A,
                       c.ground_vs_flight.delta_I_A);
    }
    for (const auto& f : c.findings) s += "  finding: " + f + "\n";
  }
  for (const auto& [ch, why] : r.not_diagnosed) s += fmt::format("{}: not diagnosed: {}\n", ch, why);
  return s;
}

}  // namespace hexsim::gap
