// gap.json (hexsim.gap/1, with the second wave's keys) and the stdout summary.
#include "hexsim/gap/diagnose.h"

#include <fmt/format.h>

#include "compass_terms_fit.h"

namespace hexsim::gap {

nlohmann::json ToJson(const GapReport& r) {
  nlohmann::json j;
  j["schema"] = "hexsim.gap/1";
  j["log"] = r.log_name;
  j["attitude_source"] = r.attitude_source;
  j["field_model"] = r.field_model;
  j["earth_field_N_uT"] = {r.earth_field_N_uT.x(), r.earth_field_N_uT.y(), r.earth_field_N_uT.z()};
  j["channels"] = nlohmann::json::array();
  for (const auto& c : r.channels) {
    nlohmann::json cj;
    cj["channel"] = c.channel;
    cj["unit"] = c.unit;
    cj["samples"] = c.samples;
    cj["rms_before"] = c.rms_before;
    cj["noise_rms"] = c.noise_rms;
    cj["noise_floor_ratio"] = c.noise_floor_ratio;
    cj["gap_detected"] = c.gap_detected;
    cj["p_value"] = c.p_value;
    cj["ljung_box_p"] = c.ljung_box_p;
    cj["reference_contaminated"] = c.reference_contaminated;
    cj["where"] = c.where;
    cj["verdict"] = c.verdict;
    cj["explanation"] = c.explanation;
    cj["candidates"] = nlohmann::json::array();
    for (const auto& k : c.candidates) {
      cj["candidates"].push_back({{"effect", k.effect},
                                  {"probability", k.probability},
                                  {"params", k.params},
                                  {"ci95", k.ci95},
                                  {"heldout_shrink", k.heldout_shrink},
                                  {"p_value", k.p_value},
                                  {"magnitude", k.magnitude},
                                  {"magnitude_ci95", {k.magnitude_ci95[0], k.magnitude_ci95[1]}},
                                  {"magnitude_unit", k.magnitude_unit},
                                  {"selected", k.selected},
                                  {"explained_share", k.explained_share},
                                  {"plausible", k.plausible},
                                  {"physical_range", k.physical_range},
                                  {"parameters", k.parameters}});
    }
    cj["heldout_shrink"] = c.heldout_shrink;
    cj["not_available"] = c.not_available;
    cj["explained_share"] = c.explained_share;
    cj["nuisance"] = c.nuisance;
    cj["timing"] = c.timing;
    cj["residual_left"] = c.residual_left;
    cj["ground_vs_flight"] = c.ground_vs_flight;
    cj["findings"] = c.findings;
    cj["headline"] = c.headline;
    if (c.absolute_terms) cj["absolute_terms"] = internal::CompassTermsJson(*c.absolute_terms);
    j["channels"].push_back(cj);
  }
  j["not_diagnosed"] = nlohmann::json::array();
  for (const auto& [ch, why] : r.not_diagnosed) j["not_diagnosed"].push_back({{"channel", ch}, {"why", why}});
  j["phases"] = nlohmann::json::array();
  for (const auto& p : r.phases) j["phases"].push_back({{"phase", p.phase}, {"t0_s", p.t0_s}, {"t1_s", p.t1_s}});
  j["effects_not_built"] = r.effects_not_built;
  j["windows"] = nlohmann::json::array();
  for (const auto& w : r.windows) {
    j["windows"].push_back({{"start_s", w.start_s}, {"end_s", w.end_s}, {"kind", w.kind}, {"why", w.why}});
  }
  j["windows_source"] = r.windows_source;
  return j;
}

std::string Headline(const ChannelResult& c) {
  const bool mag = c.unit == "uT";
  if (!c.gap_detected) {
    if (c.verdict != "none") return fmt::format("{}: {} (a nuisance term outside its normal range): {}", c.channel, c.verdict, c.explanation);
    return fmt::format("{}: no gap: residual at the noise floor (power ratio {:.2f})", c.channel, c.noise_floor_ratio);
  }
  const CandidateResult* top = nullptr;
  for (const auto& k : c.candidates) {
    if (k.selected) {
      top = &k;
      break;
    }
  }
  if (c.verdict == "unexplained" || c.verdict == "ambiguous" || top == nullptr) {
    std::string s = fmt::format("{}: {}: {}", c.channel, c.verdict, c.explanation);
    if (c.residual_left.contains("share")) {
      s += fmt::format("; left: {:.0f} % of the baseline residual, dominant {:.2g} Hz, in {}",
                       100 * c.residual_left.value("share", 1.0), c.residual_left.value("dominant_freq_Hz", 0.0),
                       c.residual_left.value("concentrated", std::string("?")));
    }
    return s;
  }
  std::string m = fmt::format("{:.3g} [{:.3g}, {:.3g}] {}", top->magnitude, top->magnitude_ci95[0], top->magnitude_ci95[1],
                              top->magnitude_unit);
  if (mag && top->magnitude_unit == "uT/A") {
    m = fmt::format("{:.1f} [{:.1f}, {:.1f}] mG/A", 10 * top->magnitude, 10 * top->magnitude_ci95[0], 10 * top->magnitude_ci95[1]);
  }
  if (top->params.contains("current_equivalent_uT_per_A")) {
    const auto& ci = top->ci95["current_equivalent_uT_per_A"];
    m += fmt::format(" (= {:.1f} [{:.1f}, {:.1f}] mG/A in battery-current terms)",
                     10 * top->params["current_equivalent_uT_per_A"].get<double>(), 10 * ci[0].get<double>(),
                     10 * ci[1].get<double>());
  }
  if (top->magnitude_unit == "s") m = fmt::format("{:.0f} [{:.0f}, {:.0f}] ms", 1000 * top->magnitude, 1000 * top->magnitude_ci95[0], 1000 * top->magnitude_ci95[1]);
  std::string s = fmt::format("{}: {} {}, explains {:.0f} % of the held-out residual above the baseline", c.channel, c.verdict, m,
                              100 * c.explained_share);
  if (!c.explanation.empty()) s += " (" + c.explanation + ")";
  if (c.residual_left.contains("share")) s += fmt::format("; {:.0f} % left", 100 * c.residual_left.value("share", 0.0));
  return s;
}

std::string Summary(const GapReport& r) {
  std::string s;
  if (!r.windows.empty()) {
    s += "windows (" + r.windows_source + "):";
    for (const auto& w : r.windows) s += fmt::format(" {} {:.1f}-{:.1f} s;", w.kind, w.start_s, w.end_s);
    s += "\n";
  }
  for (const auto& c : r.channels) {
    const bool mag = c.unit == "uT";
    const double k = mag ? 10.0 : 1.0;  // µT → mG
    const std::string unit = mag ? "mG" : c.unit;
    s += fmt::format("{}: residual {:.3g} {} RMS (noise {:.2g})", c.channel, c.rms_before * k, unit, c.noise_rms * k);
    if (c.reference_contaminated) s += " [reference-contaminated]";
    s += "\n  verdict: " + c.headline + "\n";
    if (c.absolute_terms) s += internal::CompassTermsText(*c.absolute_terms) + "\n";
    if (c.timing.contains("latency_s")) {
      const auto& l = c.timing["latency_s"];
      s += fmt::format("  timing: compass latency {:.0f} ms [{:.0f}, {:.0f}]", 1000 * l.value("value", 0.0),
                       1000 * l["ci95"][0].get<double>(), 1000 * l["ci95"][1].get<double>());
      if (c.timing.contains("regressor_staleness_s") && c.timing["regressor_staleness_s"].contains("current_A")) {
        const auto& st = c.timing["regressor_staleness_s"]["current_A"];
        s += fmt::format("; current staleness {:.0f} ms [{:.0f}, {:.0f}]", 1000 * st.value("value", 0.0),
                         1000 * st["ci95"][0].get<double>(), 1000 * st["ci95"][1].get<double>());
      }
      s += "\n";
    }
    if (c.nuisance.contains("offset_uT")) {
      const auto& o = c.nuisance["offset_uT"];
      s += fmt::format("  nuisance: offset ({:.0f}, {:.0f}, {:.0f}) mG, field norm {:+.1f} % against WMM (horizontal {:+.1f} %)",
                       10 * o[0].get<double>(), 10 * o[1].get<double>(), 10 * o[2].get<double>(),
                       100 * (c.nuisance.value("field_scale", 1.0) - 1),
                       100 * (c.nuisance.value("field_scale_horizontal", 1.0) - 1));
      // Without per-motor currents: how the replay split the battery current over the motors.
      if (c.nuisance.contains("current_split_exponent")) {
        s += fmt::format("; motor currents split as output^{:.2f}", c.nuisance["current_split_exponent"].get<double>());
      }
      s += "\n";
    }
    if (c.ground_vs_flight.contains("mG_per_A")) {
      s += fmt::format("  ground vs flight: {:.1f} mG/A over {:.1f} A\n", c.ground_vs_flight["mG_per_A"].get<double>(),
                       c.ground_vs_flight["delta_I_A"].get<double>());
    }
    for (const auto& f : c.findings) s += "  finding: " + f + "\n";
  }
  for (const auto& [ch, why] : r.not_diagnosed) s += fmt::format("{}: not diagnosed: {}\n", ch, why);
  return s;
}

}  // namespace hexsim::gap
