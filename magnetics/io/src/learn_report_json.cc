// hexsim.calib/1 for a learnt compensator: what LearnCompensator fitted (LearnReport), as JSON.
#include <string>

#include <fmt/format.h>

#include "hexsim/magnetics/calib_io.h"

namespace hexsim::magnetics {
namespace {

nlohmann::json GroupJson(const LearnedFit& g) {
  nlohmann::json j = EllipsoidFitToJson(g.fit);
  j["control_u"] = g.control_u;
  j["mean_current_A"] = g.mean_current_A;
  j["planes"] = g.planes;
  return j;
}

nlohmann::json DiagnosticsJson(const LearnDiagnostics& d) {
  nlohmann::json j = nlohmann::json::object();
  if (d.line_svd_rms_residual_uT) j["line_svd_rms_residual_uT"] = *d.line_svd_rms_residual_uT;
  if (d.line_paper) {
    const PaperLineSummary& p = *d.line_paper;
    j["line_paper"] = {{"a", p.a},
                       {"b_uT", p.b_uT},
                       {"c", p.c},
                       {"d_uT", p.d_uT},
                       {"iterations", p.iterations},
                       {"rms_residual_uT", p.rms_residual_uT},
                       {"angle_to_svd_deg", p.angle_to_svd_deg}};
  }
  if (d.along_rms_residual_uT) j["along_rms_residual_uT"] = *d.along_rms_residual_uT;
  if (!d.along_index.empty()) j["along_index"] = d.along_index;
  if (!d.along_model.empty()) j["along_model"] = d.along_model;
  if (d.pair_rms_residual_uT) j["pair_rms_residual_uT"] = *d.pair_rms_residual_uT;
  if (d.pose_rms_residual_uT) j["pose_rms_residual_uT"] = *d.pose_rms_residual_uT;
  if (d.samples_used_for_c) j["samples_used_for_c"] = *d.samples_used_for_c;
  return j;
}

}  // namespace

nlohmann::json LearnReportToJson(const LearnReport& report, const Compensator& compensator) {
  nlohmann::json r = nlohmann::json::object();
  r["schema"] = "hexsim.calib/1";
  r["method"] = report.method;
  const bool accepted = report.accepted();
  nlohmann::json fits = nlohmann::json::array();
  for (const auto& g : report.fits) fits.push_back(GroupJson(g));
  r["accepted"] = accepted;
  if (report.fits.empty()) {
    r["gate"] = {{"accepted", true}, {"criteria", nlohmann::json::array()}, {"failures", ""}};
    r["rms_residual_uT"] = nullptr;
    r["coverage"] = nullptr;
  } else {
    // The ground fit's gate; every fit's own gate is under "fits". Rejected fits are named.
    const LearnedFit& ground = report.fits.front();
    nlohmann::json gate = GateToJson(ground.fit.gate);
    std::string failures;
    for (const auto& g : report.fits) {
      if (g.fit.gate.accepted) continue;
      failures += fmt::format("{}control_u {}: {}", failures.empty() ? "" : " | ", g.control_u, g.fit.gate.Failures());
    }
    gate["accepted"] = accepted;
    gate["failures"] = failures;
    r["gate"] = gate;
    r["rms_residual_uT"] = ground.fit.rms_residual_uT;
    r["coverage"] = {{"fraction", ground.fit.coverage_fraction}, {"planes", ground.planes}};
  }
  r["fits"] = fits;
  r["params"] = YamlToJson(CompensatorToYaml(compensator));
  r["diagnostics"] = DiagnosticsJson(report.diagnostics);
  r["num_samples"] = report.num_samples;
  return r;
}

}  // namespace hexsim::magnetics
