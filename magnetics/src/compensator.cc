// Concrete compensators and their calib.yaml form.
#include "hexsim/magnetics/compensator.h"

#include <cmath>
#include <utility>

#include <Eigen/LU>
#include <fmt/format.h>

#include "hexsim/common/yaml_reader.h"
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

Eigen::Matrix3d CheckedInverse(const Eigen::Matrix3d& K) {
  Eigen::FullPivLU<Eigen::Matrix3d> lu(K);
  HEXSIM_CHECK(lu.isInvertible());
  return lu.inverse();
}

const char* IndexName(LineIndex i) { return i == LineIndex::kControl ? "control_u" : "current_A"; }

double IndexValue(LineIndex i, const CompensatorInput& in) {
  return i == LineIndex::kControl ? in.control_u : in.current_A;
}

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

// ---- EllipsoidCompensator ----

EllipsoidCompensator::EllipsoidCompensator(std::string method, const Eigen::Matrix3d& soft_iron,
                                           const Eigen::Vector3d& hard_iron_uT)
    : method_(std::move(method)), K_(soft_iron), K_inv_(CheckedInverse(soft_iron)), beta_uT_(hard_iron_uT) {}

Eigen::Vector3d EllipsoidCompensator::Correct(const Eigen::Vector3d& raw_B_uT, const CompensatorInput&) const {
  return K_inv_ * (raw_B_uT - beta_uT_);
}

YAML::Node EllipsoidCompensator::ToYaml() const {
  YAML::Node n = Header(method_);
  if (method_ == "none") return n;
  n["soft_iron"] = MatNode(K_);
  n["hard_iron_uT"] = VecNode(beta_uT_);
  return n;
}

// ---- LineCompensator ----

LineCompensator::LineCompensator(std::string method, const Eigen::Matrix3d& soft_iron, HardIronLine line, LineIndex index)
    : method_(std::move(method)), K_(soft_iron), K_inv_(CheckedInverse(soft_iron)), line_(std::move(line)), index_(index) {}

Eigen::Vector3d LineCompensator::Correct(const Eigen::Vector3d& raw_B_uT, const CompensatorInput& in) const {
  return K_inv_ * (raw_B_uT - line_.At(IndexValue(index_, in)));
}

YAML::Node LineCompensator::ToYaml() const {
  YAML::Node n = Header(method_);
  n["soft_iron"] = MatNode(K_);
  YAML::Node l;
  l["index"] = IndexName(index_);
  l["point_uT"] = VecNode(line_.line.point_uT);
  l["direction"] = VecNode(line_.line.direction);
  YAML::Node a;
  const AlongModel& m = line_.along;
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

// ---- CurrentSlopeCompensator ----

CurrentSlopeCompensator::CurrentSlopeCompensator(std::string method, const Eigen::Matrix3d& soft_iron,
                                                 const Eigen::Vector3d& hard_iron_uT, const Eigen::Vector3d& c_uT_per_A,
                                                 double current_ref_A, CurrentFrame frame)
    : method_(std::move(method)),
      K_(soft_iron),
      K_inv_(CheckedInverse(soft_iron)),
      beta_uT_(hard_iron_uT),
      c_uT_per_A_(c_uT_per_A),
      current_ref_A_(current_ref_A),
      frame_(frame) {}

Eigen::Vector3d CurrentSlopeCompensator::Correct(const Eigen::Vector3d& raw_B_uT, const CompensatorInput& in) const {
  const Eigen::Vector3d motor_uT = c_uT_per_A_ * (in.current_A - current_ref_A_);
  if (frame_ == CurrentFrame::kCorrected) return K_inv_ * (raw_B_uT - beta_uT_) - motor_uT;
  return K_inv_ * (raw_B_uT - beta_uT_ - motor_uT);
}

YAML::Node CurrentSlopeCompensator::ToYaml() const {
  YAML::Node n = Header(method_);
  n["soft_iron"] = MatNode(K_);
  n["hard_iron_uT"] = VecNode(beta_uT_);
  n["c_uT_per_A"] = VecNode(c_uT_per_A_);
  n["current_ref_A"] = current_ref_A_;
  return n;
}

// ---- factory ----

std::vector<std::string> CompensatorNames() {
  return {"none", "traditional", "adaptive", "adaptive-current", "compassmot", "px4-ls"};
}

std::unique_ptr<Compensator> MakeNoneCompensator() {
  return std::make_unique<EllipsoidCompensator>("none", Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
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
  } else if (method == "traditional" || method == "sphere" || method == "sphere-planar" || method == "ellipsoid" ||
             method == "robust-sphere" || method == "robust-sphere-planar" || method == "robust-ellipsoid") {
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
  } else if (method == "compassmot" || method == "px4-ls") {
    ReadSoftIron(r, &K);
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    double ref_A = 0.0;
    r.Req("hard_iron_uT", &beta);
    r.Req("c_uT_per_A", &c);
    r.Req("current_ref_A", &ref_A);
    if (r.ok()) {
      out = std::make_unique<CurrentSlopeCompensator>(method, K, beta, c, ref_A,
                                                      method == "compassmot" ? CurrentFrame::kCorrected : CurrentFrame::kRaw);
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
