// A description of what a reported compass model leaves (verdict.h, LeftStructure): a cross-axis
// coupling of the sensor, and a driven field's form outside the physical range.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "verdict.h"

namespace hexsim::gap::internal {
namespace {

// The symmetric off-diagonal gains of the sensor, r = S·h with S = Sᵀ, diag S = 0 (h the predicted
// field in the sensor frame, read from the library-free set's field matrix: its row i holds h in
// columns 3i..3i+2). No library family spans them: a misalignment is antisymmetric, a per-axis scale
// diagonal, a current soft iron varies with the current.
Candidate CrossCoupling(const ChannelData& ch) {
  Candidate c = MakeCandidate("cross_coupling", {"s_xy", "s_xz", "s_yz"}, {1.0, 1.0, 1.0}, "1");
  if (ch.flexible.p() < kFlexFieldParams || ch.flexible.X.size() != ch.t.size()) return c;
  for (const auto& x : ch.flexible.X) {
    const Vec3 h(x(0, 0), x(0, 1), x(0, 2));
    Mat3X s = Mat3X::Zero(3, 3);
    s(0, 0) = h.y(), s(1, 0) = h.x();
    s(0, 1) = h.z(), s(2, 1) = h.x();
    s(1, 2) = h.z(), s(2, 2) = h.y();
    c.X.push_back(s);
  }
  return c;
}

}  // namespace

std::string CouplingFinding(const ChannelData& ch, const Analyzer& an, const Evaluated& model, double noise_var,
                            const DiagnoseOptions& o) {
  const Candidate s = CrossCoupling(ch);
  double gain = 0;
  if (s.X.empty() || !LeavesPart(an, model, s, noise_var, o, &gain)) return "";
  return fmt::format("a cross-axis coupling of the sensor (symmetric off-diagonal gains, {:.0f} % of the noise floor's "
                     "power) that neither a misalignment nor a per-axis scale describes",
                     100 * gain);
}

std::string RefusedFormFinding(const Analyzer& an, const Attribution& at, const SelectedModel& m, double noise_var,
                               const DiagnoseOptions& o) {
  for (size_t f = 0; f < at.results.size(); ++f) {
    const CandidateResult& r = at.results[f];
    if (r.plausible || !DrivenByCurrent(r.id) || r.p_value > o.alpha) continue;
    if (std::find(m.fams.begin(), m.fams.end(), f) != m.fams.end()) continue;
    const std::string form = fmt::format("{}{}, a form outside its physical range {},", r.effect, AtExponent(r), r.physical_range);
    const char* const why = "the field is not in proportion to what drives it (a saturation or a power law)";
    // Alone, it beats the reported model on held-out blocks by more than one standard error over the
    // folds (the selection's own rule).
    const FoldDiff d = Diff(m.eval.fold_sse, at.all[at.fam_best[f]].fold_sse);
    if (d.sum > d.se) {
      return fmt::format("{} describes the field better on held-out blocks than the reported model: {}", form, why);
    }
    // The selection's parsimony rule (ReportedMember, AmbiguousRival): a model with more fitted
    // quantities must beat a simpler one by more than one standard error. A reported model that
    // does not beat the simpler refused form so describes the field no better than a form the
    // library refuses.
    const int dof_refused = Dof(*at.all[at.fam_best[f]].cand), dof_model = Dof(*m.eval.cand);
    if (dof_refused < dof_model && d.sum > -d.se) {
      return fmt::format("{} describes the field on held-out blocks as well as the reported model, with fewer fitted "
                         "quantities ({} against {}): {}",
                         form, dof_refused, dof_model, why);
    }
    double gain = 0;
    if (LeavesPart(an, m.eval, *at.all[at.fam_best[f]].cand, noise_var, o, &gain)) {
      return fmt::format("{} describes a part the reported model leaves ({:.0f} % of the noise floor's power): {}", form,
                         100 * gain, why);
    }
  }
  return "";
}

}  // namespace hexsim::gap::internal
