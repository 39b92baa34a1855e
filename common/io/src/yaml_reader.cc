#include "hexsim/common/yaml_reader.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

namespace hexsim {

bool Bound::Holds(double v) const {
  if (!std::isfinite(v)) return false;
  if (lo_open ? !(v > lo) : !(v >= lo)) return false;
  if (hi_open ? !(v < hi) : !(v <= hi)) return false;
  return true;
}

std::string Bound::Describe() const {
  const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
  if (has_lo && has_hi) return fmt::format("must be in {}{}, {}{}", lo_open ? "(" : "[", lo, hi, hi_open ? ")" : "]");
  if (has_lo) return fmt::format("must be {} {}", lo_open ? ">" : ">=", lo);
  if (has_hi) return fmt::format("must be {} {}", hi_open ? "<" : "<=", hi);
  return "must be a finite number";
}

Bound Positive() { return Bound{0.0, std::numeric_limits<double>::infinity(), true, false}; }
Bound NonNegative() { return Bound{0.0, std::numeric_limits<double>::infinity(), false, false}; }
Bound InRange(double lo, double hi) { return Bound{lo, hi, false, false}; }

Result<YAML::Node> YamlReader::LoadFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) return Status::BadInput(path + ": cannot open file");
  std::stringstream ss;
  ss << in.rdbuf();
  return LoadString(ss.str(), path);
}

Result<YAML::Node> YamlReader::LoadString(const std::string& text, const std::string& name) {
  try {
    YAML::Node node = YAML::Load(text);
    if (!node.IsMap()) return Status::BadInput(name + ":1: document: expected a map of keys");
    return node;
  } catch (const YAML::Exception& e) {
    return Status::BadInput(fmt::format("{}:{}: YAML syntax: {}", name, e.mark.line + 1, e.msg));
  }
}

YamlReader::YamlReader(YAML::Node node, std::string file, std::string prefix)
    : YamlReader(node, std::move(file), std::move(prefix), std::make_shared<Status>()) {}

YamlReader::YamlReader(YAML::Node node, std::string file, std::string prefix,
                       std::shared_ptr<Status> error)
    : node_(node), file_(std::move(file)), prefix_(std::move(prefix)), error_(std::move(error)) {}

std::string YamlReader::Where(const std::string& key) const {
  int line = node_.Mark().line;
  if (node_.IsMap() && !key.empty()) {
    const YAML::Node child = node_[key];
    if (child.IsDefined() && child.Mark().line >= 0) line = child.Mark().line;
  }
  const std::string field = prefix_.empty() ? key : (key.empty() ? prefix_ : prefix_ + "." + key);
  if (line >= 0) return fmt::format("{}:{}: {}", file_, line + 1, field);
  return fmt::format("{}: {}", file_, field);
}

void YamlReader::Fail(const std::string& key, const std::string& what) {
  if (error_->ok()) *error_ = Status::BadInput(Where(key) + ": " + what);
}

void YamlReader::FailHere(const std::string& what) { Fail("", what); }

bool YamlReader::Has(const std::string& key) const {
  return node_.IsMap() && node_[key].IsDefined() && !node_[key].IsNull();
}

std::vector<std::string> YamlReader::Keys() const {
  std::vector<std::string> keys;
  if (!node_.IsMap()) return keys;
  for (const auto& kv : node_) keys.push_back(kv.first.as<std::string>());
  return keys;
}

YAML::Node YamlReader::Fetch(const std::string& key, bool required) {
  used_.insert(key);
  if (!error_->ok()) return YAML::Node();
  if (!node_.IsMap()) {
    FailHere("expected a map");
    return YAML::Node();
  }
  YAML::Node child = node_[key];
  if (!child.IsDefined() || child.IsNull()) {
    if (required) Fail(key, "required field is missing");
    return YAML::Node();
  }
  return child;
}

template <class T>
bool YamlReader::Scalar(const std::string& key, bool required, T* out) {
  YAML::Node n = Fetch(key, required);
  if (!n.IsDefined() || n.IsNull()) return false;
  if (!n.IsScalar()) {
    Fail(key, "expected a single value");
    return false;
  }
  try {
    *out = n.as<T>();
    return true;
  } catch (const YAML::Exception&) {
    Fail(key, fmt::format("cannot read '{}' as {}", n.Scalar(),
                          std::is_same_v<T, bool> ? "true/false" : (std::is_arithmetic_v<T> ? "a number" : "text")));
    return false;
  }
}

void YamlReader::CheckBound(const std::string& key, double v, const Bound& b) {
  if (!b.Holds(v)) Fail(key, fmt::format("{} (got {})", b.Describe(), v));
}

void YamlReader::Req(const std::string& key, double* out, Bound b) {
  if (Scalar(key, true, out)) CheckBound(key, *out, b);
}
void YamlReader::Opt(const std::string& key, double* out, Bound b) {
  if (Scalar(key, false, out)) CheckBound(key, *out, b);
}
void YamlReader::Req(const std::string& key, int* out, Bound b) {
  if (Scalar(key, true, out)) CheckBound(key, *out, b);
}
void YamlReader::Opt(const std::string& key, int* out, Bound b) {
  if (Scalar(key, false, out)) CheckBound(key, *out, b);
}
void YamlReader::Req(const std::string& key, uint64_t* out) { Scalar(key, true, out); }
void YamlReader::Opt(const std::string& key, uint64_t* out) { Scalar(key, false, out); }
void YamlReader::Req(const std::string& key, bool* out) { Scalar(key, true, out); }
void YamlReader::Opt(const std::string& key, bool* out) { Scalar(key, false, out); }
void YamlReader::Req(const std::string& key, std::string* out) { Scalar(key, true, out); }
void YamlReader::Opt(const std::string& key, std::string* out) { Scalar(key, false, out); }

void YamlReader::Opt(const std::string& key, std::string* out, const std::vector<std::string>& allowed) {
  std::string v;
  if (!Scalar(key, false, &v)) return;
  for (const auto& a : allowed) {
    if (a == v) {
      *out = v;
      return;
    }
  }
  std::string list;
  for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
  Fail(key, fmt::format("'{}' is not one of: {}", v, list));
}

namespace {
bool ReadNumbers(const YAML::Node& n, std::vector<double>* out) {
  if (!n.IsSequence()) return false;
  out->clear();
  for (const auto& item : n) {
    if (!item.IsScalar()) return false;
    try {
      out->push_back(item.as<double>());
    } catch (const YAML::Exception&) {
      return false;
    }
  }
  return true;
}
}  // namespace

void YamlReader::Req(const std::string& key, Eigen::Vector3d* out) {
  YAML::Node n = Fetch(key, true);
  if (!n.IsDefined() || n.IsNull()) return;
  std::vector<double> v;
  if (!ReadNumbers(n, &v) || v.size() != 3) return Fail(key, "expected [x, y, z]");
  for (double x : v) {
    if (!std::isfinite(x)) return Fail(key, "must be finite");
  }
  *out = Eigen::Vector3d(v[0], v[1], v[2]);
}

void YamlReader::Opt(const std::string& key, Eigen::Vector3d* out) {
  if (Has(key)) Req(key, out);
  else used_.insert(key);
}

void YamlReader::Opt(const std::string& key, Eigen::Matrix3d* out) {
  YAML::Node n = Fetch(key, false);
  if (!n.IsDefined() || n.IsNull()) return;
  std::vector<double> v;
  if (ReadNumbers(n, &v) && v.size() == 3) {
    *out = Eigen::Vector3d(v[0], v[1], v[2]).asDiagonal();
    return;
  }
  if (!n.IsSequence() || n.size() != 3) return Fail(key, "expected [[a,b,c],[d,e,f],[g,h,i]] or a diagonal [a,b,c]");
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r) {
    if (!ReadNumbers(n[r], &v) || v.size() != 3) return Fail(key, "expected [[a,b,c],[d,e,f],[g,h,i]]");
    for (int c = 0; c < 3; ++c) m(r, c) = v[c];
  }
  if (!m.allFinite()) return Fail(key, "must be finite");
  *out = m;
}

void YamlReader::Opt(const std::string& key, std::vector<double>* out, Bound b) {
  YAML::Node n = Fetch(key, false);
  if (!n.IsDefined() || n.IsNull()) return;
  std::vector<double> v;
  if (!ReadNumbers(n, &v)) return Fail(key, "expected a list of numbers");
  for (double x : v) {
    if (!b.Holds(x)) return Fail(key, fmt::format("every entry {} (got {})", b.Describe(), x));
  }
  *out = v;
}

void YamlReader::Child(const std::string& key, const std::function<void(YamlReader&)>& fn, bool required) {
  YAML::Node n = Fetch(key, required);
  if (!n.IsDefined() || n.IsNull() || !error_->ok()) return;
  if (!n.IsMap()) return Fail(key, "expected a map of keys");
  YamlReader child(n, file_, prefix_.empty() ? key : prefix_ + "." + key, error_);
  fn(child);
  (void)child.Finish();
}

void YamlReader::ForEach(const std::string& key, const std::function<void(YamlReader&, size_t)>& fn,
                         bool required) {
  YAML::Node n = Fetch(key, required);
  if (!n.IsDefined() || n.IsNull() || !error_->ok()) return;
  if (!n.IsSequence()) return Fail(key, "expected a list");
  if (required && n.size() == 0) return Fail(key, "must not be empty");
  for (size_t i = 0; i < n.size() && error_->ok(); ++i) {
    const std::string p = fmt::format("{}[{}]", prefix_.empty() ? key : prefix_ + "." + key, i);
    YamlReader item(n[i], file_, p, error_);
    if (!n[i].IsMap()) {
      item.FailHere("expected a map of keys");
      return;
    }
    fn(item, i);
    (void)item.Finish();
  }
}

Status YamlReader::Finish() {
  if (error_->ok() && node_.IsMap()) {
    for (const auto& kv : node_) {
      const std::string k = kv.first.as<std::string>();
      if (used_.count(k) == 0) {
        Fail(k, "unknown key");
        break;
      }
    }
  }
  return *error_;
}

Status ApplyOverride(YAML::Node root, const std::string& assignment, const std::string& file,
                     bool create_missing) {
  const size_t eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) {
    return Status::BadInput(fmt::format("--set {}: expected KEY=VALUE", assignment));
  }
  const std::string path = assignment.substr(0, eq);
  const std::string value = assignment.substr(eq + 1);
  std::vector<std::string> parts;
  std::stringstream ss(path);
  for (std::string p; std::getline(ss, p, '.');) parts.push_back(p);
  YAML::Node node = root;
  for (size_t i = 0; i < parts.size(); ++i) {
    const std::string& p = parts[i];
    YAML::Node next;
    if (node.IsSequence()) {
      char* end = nullptr;
      const long idx = std::strtol(p.c_str(), &end, 10);
      if (*end != '\0' || idx < 0 || static_cast<size_t>(idx) >= node.size()) {
        return Status::BadInput(fmt::format("{}: {}: no such entry '{}'", file, path, p));
      }
      next = node[static_cast<size_t>(idx)];
    } else if (node.IsMap() && node[p].IsDefined()) {
      next = node[p];
    } else if (create_missing && (node.IsMap() || node.IsNull())) {
      if (i + 1 == parts.size()) {
        try {
          node[p] = YAML::Load(value);
        } catch (const YAML::Exception&) {
          return Status::BadInput(fmt::format("{}: {}: cannot parse value '{}'", file, path, value));
        }
        return Status::Ok();
      }
      node[p] = YAML::Node(YAML::NodeType::Map);
      next = node[p];
    } else {
      return Status::BadInput(fmt::format("{}: {}: unknown key '{}'", file, path, p));
    }
    if (i + 1 == parts.size()) {
      try {
        next = YAML::Load(value);
      } catch (const YAML::Exception&) {
        return Status::BadInput(fmt::format("{}: {}: cannot parse value '{}'", file, path, value));
      }
      return Status::Ok();
    }
    node.reset(next);
  }
  return Status::Ok();
}

}  // namespace hexsim
