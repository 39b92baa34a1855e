// calib.yaml: a compensator's schema, method and parameters, written and read back.
#include <cmath>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "hexsim/common/yaml_reader.h"
#include "hexsim/magnetics/calib_io.h"
#include "hexsim/magnetics/compensators.h"

namespace hexsim::magnetics {
namespace {

constexpr const char* kCalibSchema = "hexsim.calib/1";

YAML::Node VecNode(const Eigen::VectorXd& v) {
  YAML::Node n(YAML::NodeType::Sequence);
  for (Eigen::Index i = 0; i < v.size(); ++i) n.push_back(v(i));
  n.SetStyle(YAML::EmitterStyle::Flow);
  return n;
}

YAML::Node VecNode(const std::vector<double>& v) {
  return VecNode(Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size())));
}

YAML::Node MatNode(const Eigen::Matrix3d& m) {
  YAML::Node n(YAML::NodeType::Sequence);
  for (int i = 0; i < 3; ++i) n.push_back(VecNode(Eigen::Vector3d(m.row(i).transpose())));
  return n;
}

YAML::Node Header(const std::string& method) {
  YAML::Node n;
  n["schema"] = kCalibSchema;
  n["method"] = method;
  return n;
}

const char* IndexName(LineIndex i) { return i == LineIndex::kControl ? "control_u" : "current_A"; }

// Reads soft_iron (required, invertible and finite).
void ReadSoftIron(YamlReader& r, Eigen::Matrix3d* K) {
  if (!r.Has("soft_iron")) {
    r.Fail("soft_iron", "missing required field");
    return;
  }
  r.Opt("soft_iron", K);
  if (!r.ok()) return;
  if (!K->allFinite() || std::abs(K->determinant()) < 1e-9) r.Fail("soft_iron", "must be a finite, invertible 3x3 matrix");
}

void ReadAlong(YamlReader& a, AlongModel* m) {
  std::string model;
  a.Req("model", &model);
  if (!a.ok()) return;
  if (model == "linear") {
    m->kind = AlongKind::kLinear;
    a.Req("s0_uT", &m->s0_uT);
    a.Req("k_uT_per_x", &m->k_uT_per_x);
  } else if (model == "monotone") {
    m->kind = AlongKind::kMonotone;
    for (const char* key : {"knots_x", "knots_s_uT", "slopes"}) {
      if (!a.Has(key)) a.Fail(key, "missing required field");
    }
    a.Opt("knots_x", &m->knots_x);
    a.Opt("knots_s_uT", &m->knots_s_uT);
    a.Opt("slopes", &m->slopes);
    if (!a.ok()) return;
    const size_t n = m->knots_x.size();
    if (n < 2 || m->knots_s_uT.size() != n || m->slopes.size() != n) {
      a.Fail("knots_x", "knots_x, knots_s_uT and slopes need the same length, at least 2");
      return;
    }
    for (size_t i = 0; i + 1 < n; ++i) {
      if (!(m->knots_x[i + 1] > m->knots_x[i])) {
        a.Fail("knots_x", "must be strictly increasing");
        return;
      }
    }
  } else {
    a.Fail("model", "must be one of: linear, monotone");
  }
}

}  // namespace

YAML::Node CompensatorToYaml(const Compensator& compensator) {
  if (const auto* e = dynamic_cast<const EllipsoidCompensator*>(&compensator)) {
    YAML::Node n = Header(e->name());
    if (e->name() == "none") return n;
    n["soft_iron"] = MatNode(e->soft_iron());
    n["hard_iron_uT"] = VecNode(e->hard_iron_uT());
    return n;
  }
  if (const auto* lc = dynamic_cast<const LineCompensator*>(&compensator)) {
    YAML::Node n = Header(lc->name());
    n["soft_iron"] = MatNode(lc->soft_iron());
    YAML::Node l;
    l["index"] = IndexName(lc->index());
    l["point_uT"] = VecNode(lc->line().line.point_uT);
    l["direction"] = VecNode(lc->line().line.direction);
    YAML::Node a;
    const AlongModel& m = lc->line().along;
    if (m.kind == AlongKind::kLinear) {
      a["model"] = "linear";
      a["s0_uT"] = m.s0_uT;
      a["k_uT_per_x"] = m.k_uT_per_x;
    } else {
      a["model"] = "monotone";
      a["knots_x"] = VecNode(m.knots_x);
      a["knots_s_uT"] = VecNode(m.knots_s_uT);
      a["slopes"] = VecNode(m.slopes);
    }
    l["along"] = a;
    n["line"] = l;
    return n;
  }
  if (const auto* c = dynamic_cast<const CurrentSlopeCompensator*>(&compensator)) {
    YAML::Node n = Header(c->name());
    n["soft_iron"] = MatNode(c->soft_iron());
    n["hard_iron_uT"] = VecNode(c->hard_iron_uT());
    n["c_uT_per_A"] = VecNode(c->c_uT_per_A());
    n["current_ref_A"] = c->current_ref_A();
    return n;
  }
  // Only the compensators of compensators.h are learnt and written.
  const bool known_kind = false;
  HEXSIM_CHECK(known_kind);
  return YAML::Node();
}

Result<std::unique_ptr<Compensator>> CompensatorFromYaml(const YAML::Node& node, const std::string& file) {
  if (!node.IsMap()) return Status::BadInput(file + ": document: expected a map of keys");
  YamlReader r(node, file);
  std::string schema, method;
  r.Req("schema", &schema);
  r.Req("method", &method);
  HEXSIM_RETURN_IF_ERROR(r.ok() ? Status::Ok() : r.Finish());
  if (schema != kCalibSchema) {
    r.Fail("schema", fmt::format("must be {}, got {}", kCalibSchema, schema));
    return r.Finish();
  }
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  Eigen::Vector3d beta = Eigen::Vector3d::Zero();
  std::unique_ptr<Compensator> out;
  if (method == "none") {
    out = MakeNoneCompensator();
  } else if (method == "traditional" || method == "sphere" || method == "sphere-planar" || method == "circle" || method == "ellipsoid" ||
             method == "robust-sphere" || method == "robust-sphere-planar" || method == "robust-circle" || method == "robust-ellipsoid") {
    // K⁻¹(H − β); the free-hand fits of field_calibration.h write K = A⁻¹ (any scale).
    ReadSoftIron(r, &K);
    r.Req("hard_iron_uT", &beta);
    if (r.ok()) out = std::make_unique<EllipsoidCompensator>(method, K, beta);
  } else if (method == "adaptive" || method == "adaptive-current") {
    ReadSoftIron(r, &K);
    HardIronLine line;
    LineIndex index = LineIndex::kControl;
    r.Child(
        "line",
        [&](YamlReader& l) {
          std::string idx;
          l.Req("index", &idx);
          if (idx == "control_u") index = LineIndex::kControl;
          else if (idx == "current_A") index = LineIndex::kCurrent;
          else if (l.ok()) l.Fail("index", "must be one of: control_u, current_A");
          l.Req("point_uT", &line.line.point_uT);
          l.Req("direction", &line.line.direction);
          if (l.ok() && !(std::abs(line.line.direction.norm() - 1.0) < 1e-6)) l.Fail("direction", "must be a unit vector");
          l.Child("along", [&](YamlReader& a) { ReadAlong(a, &line.along); }, /*required=*/true);
        },
        /*required=*/true);
    if (r.ok()) out = std::make_unique<LineCompensator>(method, K, line, index);
  } else if (method == "compassmot" || method == "px4-ls" || method == "flight") {
    ReadSoftIron(r, &K);
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    double ref_A = 0.0;
    r.Req("hard_iron_uT", &beta);
    r.Req("c_uT_per_A", &c);
    r.Req("current_ref_A", &ref_A);
    if (r.ok()) {
      out = std::make_unique<CurrentSlopeCompensator>(method, K, beta, c, ref_A,
                                                      method == "px4-ls" ? CurrentFrame::kRaw : CurrentFrame::kCorrected);
    }
  } else {
    std::string all;
    for (const auto& n : CompensatorNames()) all += (all.empty() ? "" : ", ") + n;
    r.Fail("method", fmt::format("unknown method '{}' (one of: {})", method, all));
  }
  HEXSIM_RETURN_IF_ERROR(r.Finish());
  HEXSIM_CHECK(out != nullptr);
  return Result<std::unique_ptr<Compensator>>(std::move(out));
}

}  // namespace hexsim::magnetics
