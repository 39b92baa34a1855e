// identify.json (hexsim.identify/1) and the text summary (identify.html is reports::WriteIdentifyHtml).
#include <cmath>

#include <fmt/format.h>

#include "hexsim/common/atomic_file.h"
#include "hexsim/identify/identify.h"

namespace hexsim::identify {
namespace {

nlohmann::json Num(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

nlohmann::json ToJson(const IdentifyResult& r) {
  nlohmann::json j;
  j["schema"] = "hexsim.identify/1";
  j["frame"] = r.frame;
  j["frame_source"] = r.frame_source;
  j["motors"] = r.motors;
  j["base"] = r.base_name;
  j["spins"] = r.spins;
  j["rotor_xy_m"] = r.rotor_xy_m;
  j["layout_source"] = r.layout_source;
  j["layout_from_log"] = r.layout_from_log;
  j["data_source"] = r.data_source;
  j["v_ref_V"] = r.v_ref_V;
  j["thrust_expo"] = {{"value", Num(r.thrust_expo)}, {"source", r.thrust_expo_source}};
  nlohmann::json params = nlohmann::json::object();
  for (const auto& k : r.param_order) {
    const Param& p = r.params.at(k);
    params[k] = {{"value", Num(p.value)},
                 {"ci95", {Num(p.ci95[0]), Num(p.ci95[1])}},
                 {"unit", p.unit},
                 {"source", p.source},
                 {"physical_range", {Num(p.range[0]), Num(p.range[1])}},
                 {"physical_range_reason", p.range_reason},
                 {"plausible", p.plausible()},
                 {"applied", p.applied},
                 {"not_applied", p.not_applied},
                 {"note", p.note}};
  }
  j["params"] = params;
  nlohmann::json held = nlohmann::json::object();
  for (const auto& h : r.heldout) {
    held[h.output] = {{"unit", h.unit},
                      {"rms_measured", h.rms_measured},
                      {"rms_residual", h.rms_residual},
                      {"r2", h.r2},
                      {"samples", h.samples},
                      {"how", "fitted on the even time blocks, scored on the odd ones"}};
  }
  held["dynamics_specific_force"] = {
      {"unit", "m/s^2"},
      {"rms_base_vehicle", Num(r.dynamics_rms_base)},
      {"rms_identified_vehicle", Num(r.dynamics_rms_identified)},
      {"drop", r.dynamics_rms_base > 0 ? 1.0 - r.dynamics_rms_identified / r.dynamics_rms_base : 0.0},
      {"improves_on_base", r.improves_on_base},
      {"not_comparable", r.dynamics_not_comparable},
      {"how", "3-axis RMS about zero on the odd blocks; thrust from hexsim's steady powertrain at the logged outputs "
              "and voltage, drag from the vehicle; identified vehicle fitted on the even blocks"}};
  j["heldout_fit"] = held;
  nlohmann::json win = nlohmann::json::array();
  for (const auto& w : r.windows) win.push_back({{"start_s", w.start_s}, {"end_s", w.end_s}, {"kind", w.kind}, {"why", w.why}});
  j["windows"] = win;
  j["hover_check"] = {{"steady_hover_samples", r.hover_output.size()},
                      {"median_motor_output", Num(Median(r.hover_output))},
                      {"median_voltage_V", Num(Median(r.hover_voltage_V))}};
  j["improves_on_base"] = r.improves_on_base;
  j["notes"] = r.notes;
  return j;
}

std::string Summary(const IdentifyResult& r) {
  std::string s = fmt::format("frame {} ({}), base {}; {}\n", r.frame, r.frame_source, r.base_name, r.data_source);
  for (const auto& k : r.param_order) {
    const Param& p = r.params.at(k);
    s += fmt::format("  {:<32} {:>11.5g}  [{:.5g}, {:.5g}] {:<7} {}{}\n", k, p.value, p.ci95[0], p.ci95[1], p.unit, p.source,
                     p.source == "fitted" && !p.applied ? " (not applied: " + p.not_applied + ")" : std::string());
  }
  for (const auto& h : r.heldout) {
    s += fmt::format("  held-out {:<24} RMS {:.4g} -> residual {:.4g} {} (R² {:.2f}, {} samples)\n", h.output,
                     h.rms_measured, h.rms_residual, h.unit, h.r2, h.samples);
  }
  if (r.dynamics_not_comparable.empty()) {
    s += fmt::format("  held-out dynamics residual (3 axes, RMS): base vehicle {:.3g} m/s^2, identified {:.3g} m/s^2\n",
                     r.dynamics_rms_base, r.dynamics_rms_identified);
  }
  if (!r.hover_output.empty()) {
    s += fmt::format("  steady hover in the log: median motor output {:.3f} at {:.2f} V ({} samples)\n",
                     Median(r.hover_output), Median(r.hover_voltage_V), r.hover_output.size());
  }
  for (const auto& note : r.notes) s += "  note: " + note + "\n";
  s += "  " + ImprovementLine(r) + "\n";
  return s;
}

std::string ImprovementLine(const IdentifyResult& r) {
  if (!r.dynamics_not_comparable.empty()) {
    return fmt::format("not compared with its base {}: {}; the identified vehicle is not used", r.base_name,
                       r.dynamics_not_comparable);
  }
  if (r.improves_on_base) {
    return fmt::format("improves on its base: held-out dynamics residual {:.3g} m/s^2 against the base's {:.3g} m/s^2",
                       r.dynamics_rms_identified, r.dynamics_rms_base);
  }
  return fmt::format("improves nothing on its base {}: held-out dynamics residual {:.3g} m/s^2, the base's {:.3g} m/s^2; "
                     "the identified vehicle is not used",
                     r.base_name, r.dynamics_rms_identified, r.dynamics_rms_base);
}

}  // namespace hexsim::identify
