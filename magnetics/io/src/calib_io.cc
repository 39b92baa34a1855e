#include "hexsim/magnetics/calib_io.h"

#include <cstdlib>
#include <cmath>
#include <map>
#include <sstream>

#include <fmt/format.h>

namespace hexsim::magnetics {
namespace {

std::vector<std::string> SplitCsvLine(const std::string& line) {
  std::vector<std::string> out;
  std::string cur;
  for (char ch : line) {
    if (ch == ',') {
      out.push_back(cur);
      cur.clear();
    } else if (ch != '\r') {
      cur.push_back(ch);
    }
  }
  out.push_back(cur);
  for (auto& f : out) {
    const auto b = f.find_first_not_of(" \t");
    const auto e = f.find_last_not_of(" \t");
    f = b == std::string::npos ? std::string() : f.substr(b, e - b + 1);
  }
  return out;
}

bool ParseDouble(const std::string& s, double* out) {
  if (s.empty()) return false;
  char* end = nullptr;
  *out = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && std::isfinite(*out);
}

nlohmann::json Bound(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

nlohmann::json Vec(const Eigen::Vector3d& v) { return {v(0), v(1), v(2)}; }

}  // namespace

Result<std::vector<MagSample>> ParseSamplesCsv(const std::string& text, const std::string& file, const std::string& mag_prefix) {
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  std::vector<std::string> header;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    header = SplitCsvLine(line);
    break;
  }
  if (header.empty()) return Status::BadInput(file + ": empty file (no header row)");
  std::map<std::string, size_t> col;
  for (size_t i = 0; i < header.size(); ++i) col[header[i]] = i;
  const std::string mx = mag_prefix + "_x_uT", my = mag_prefix + "_y_uT", mz = mag_prefix + "_z_uT";
  const std::vector<std::string> required = {"plane", "control_u", "current_A", "angle_deg", "q_w", "q_x", "q_y", "q_z", mx, my, mz};
  for (const auto& r : required) {
    if (!col.count(r)) return Status::BadInput(fmt::format("{}:{}: {}: missing column", file, line_no, r));
  }
  const bool has_earth = col.count("earth_x_uT") && col.count("earth_y_uT") && col.count("earth_z_uT");
  std::vector<MagSample> out;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const auto f = SplitCsvLine(line);
    if (f.size() != header.size()) {
      return Status::BadInput(fmt::format("{}:{}: row: has {} fields, header has {}", file, line_no, f.size(), header.size()));
    }
    auto num = [&](const std::string& name, double* v) -> Status {
      if (!ParseDouble(f[col.at(name)], v)) {
        return Status::BadInput(fmt::format("{}:{}: {}: not a finite number: '{}'", file, line_no, name, f[col.at(name)]));
      }
      return Status::Ok();
    };
    MagSample s;
    s.plane = f[col.at("plane")];
    if (!(s.plane.empty() || s.plane == "xy" || s.plane == "yz" || s.plane == "xz")) {
      return Status::BadInput(fmt::format("{}:{}: plane: must be xy, yz, xz or empty, got '{}'", file, line_no, s.plane));
    }
    double qw = 1, qx = 0, qy = 0, qz = 0;
    HEXSIM_RETURN_IF_ERROR(num("control_u", &s.control_u));
    HEXSIM_RETURN_IF_ERROR(num("current_A", &s.current_A));
    HEXSIM_RETURN_IF_ERROR(num("angle_deg", &s.angle_deg));
    HEXSIM_RETURN_IF_ERROR(num("q_w", &qw));
    HEXSIM_RETURN_IF_ERROR(num("q_x", &qx));
    HEXSIM_RETURN_IF_ERROR(num("q_y", &qy));
    HEXSIM_RETURN_IF_ERROR(num("q_z", &qz));
    HEXSIM_RETURN_IF_ERROR(num(mx, &s.mag_B_uT(0)));
    HEXSIM_RETURN_IF_ERROR(num(my, &s.mag_B_uT(1)));
    HEXSIM_RETURN_IF_ERROR(num(mz, &s.mag_B_uT(2)));
    s.q_NB = Eigen::Quaterniond(qw, qx, qy, qz);
    const double qn = s.q_NB.norm();
    if (std::abs(qn - 1.0) > 1e-3) {
      return Status::BadInput(fmt::format("{}:{}: q_w: attitude quaternion is not unit (norm {:.6g})", file, line_no, qn));
    }
    s.q_NB.normalize();
    if (has_earth) {
      HEXSIM_RETURN_IF_ERROR(num("earth_x_uT", &s.earth_B_uT(0)));
      HEXSIM_RETURN_IF_ERROR(num("earth_y_uT", &s.earth_B_uT(1)));
      HEXSIM_RETURN_IF_ERROR(num("earth_z_uT", &s.earth_B_uT(2)));
    }
    out.push_back(s);
  }
  if (out.empty()) return Status::BadInput(fmt::format("{}: no sample rows", file));
  return out;
}

std::string SamplesToCsv(const std::vector<MagSample>& samples) {
  std::string out =
      "plane,control_u,current_A,angle_deg,q_w,q_x,q_y,q_z,mag_x_uT,mag_y_uT,mag_z_uT,earth_x_uT,earth_y_uT,earth_z_uT\n";
  for (const auto& s : samples) {
    out += fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", s.plane, s.control_u, s.current_A, s.angle_deg,
                       s.q_NB.w(), s.q_NB.x(), s.q_NB.y(), s.q_NB.z(), s.mag_B_uT(0), s.mag_B_uT(1), s.mag_B_uT(2),
                       s.earth_B_uT(0), s.earth_B_uT(1), s.earth_B_uT(2));
  }
  return out;
}

std::string CompensatorToYamlText(const Compensator& compensator) {
  YAML::Emitter e;
  e.SetDoublePrecision(17);
  e << CompensatorToYaml(compensator);
  return std::string("# hexsim compass calibration (") + compensator.name() + ")\n" + e.c_str() + "\n";
}

nlohmann::json GateToJson(const FitGate& gate) {
  nlohmann::json crit = nlohmann::json::array();
  for (const auto& c : gate.criteria) {
    crit.push_back({{"name", c.name}, {"value", Bound(c.value)}, {"min", Bound(c.min)}, {"max", Bound(c.max)},
                    {"pass", c.pass}, {"failed_bound", c.failed_bound}, {"note", c.note}});
  }
  return {{"accepted", gate.accepted}, {"criteria", crit}, {"failures", gate.Failures()}};
}

nlohmann::json EllipsoidFitToJson(const EllipsoidFit& f) {
  nlohmann::json j;
  j["ok"] = f.status.ok();
  j["status"] = f.status.ok() ? "ok" : f.status.message();
  j["num_samples"] = f.num_samples;
  if (!f.status.ok()) return j;
  j["hard_iron_uT"] = Vec(f.hard_iron_uT);
  j["soft_iron"] = {Vec(f.soft_iron.row(0).transpose()), Vec(f.soft_iron.row(1).transpose()), Vec(f.soft_iron.row(2).transpose())};
  j["radius_uT"] = f.radius_uT;
  j["rms_residual_uT"] = f.rms_residual_uT;
  j["max_residual_uT"] = f.max_residual_uT;
  j["iterations"] = f.iterations;
  j["converged"] = f.converged;
  j["condition_number"] = Bound(f.condition_number);
  j["coverage_fraction"] = f.coverage_fraction;
  j["gate"] = GateToJson(f.gate);
  return j;
}

nlohmann::json YamlToJson(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Map: {
      nlohmann::json j = nlohmann::json::object();
      for (const auto& kv : node) j[kv.first.as<std::string>()] = YamlToJson(kv.second);
      return j;
    }
    case YAML::NodeType::Sequence: {
      nlohmann::json j = nlohmann::json::array();
      for (const auto& item : node) j.push_back(YamlToJson(item));
      return j;
    }
    case YAML::NodeType::Scalar: {
      const std::string& s = node.Scalar();
      double v = 0.0;
      if (ParseDouble(s, &v)) return v;
      return s;
    }
    default:
      return nullptr;
  }
}

}  // namespace hexsim::magnetics
