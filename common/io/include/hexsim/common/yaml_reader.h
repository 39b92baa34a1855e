// Strict YAML reading into plain structs: every field named, unknown keys rejected, bounds checked,
// and the first error reported as "FILE:LINE: FIELD: what is wrong".
//
//   YamlReader r(node, "worlds/vehicles/x.yaml");
//   r.Req("mass_kg", &p.mass_kg, Positive());
//   r.Opt("drag", [&](YamlReader& d) { d.Opt("linear_Nspm", &p.drag_linear); });
//   r.ForEach("rotors", [&](YamlReader& item, size_t i) { ... });
//   HEXSIM_RETURN_IF_ERROR(r.Finish());
#pragma once

#include <functional>
#include <limits>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <yaml-cpp/yaml.h>

#include "hexsim/common/status.h"

namespace hexsim {

// A closed/open interval check on a number; `what` says the rule in words.
struct Bound {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;
  bool hi_open = false;
  bool Holds(double v) const;
  std::string Describe() const;
};
Bound Positive();      // > 0
Bound NonNegative();   // >= 0
Bound InRange(double lo, double hi);  // [lo, hi]

class YamlReader {
 public:
  // Parses a YAML file; a missing file or a syntax error is kBadInput naming file and line.
  static Result<YAML::Node> LoadFile(const std::string& path);
  // Parses YAML text; `name` is used in messages in place of a file name.
  static Result<YAML::Node> LoadString(const std::string& text, const std::string& name);

  YamlReader(YAML::Node node, std::string file, std::string prefix = "");

  bool Has(const std::string& key) const;
  // The keys present in this map, in file order.
  std::vector<std::string> Keys() const;

  // Required and optional scalar fields. Optional ones leave *out unchanged when absent.
  void Req(const std::string& key, double* out, Bound bound = {});
  void Opt(const std::string& key, double* out, Bound bound = {});
  void Req(const std::string& key, int* out, Bound bound = {});
  void Opt(const std::string& key, int* out, Bound bound = {});
  void Req(const std::string& key, uint64_t* out);
  void Opt(const std::string& key, uint64_t* out);
  void Req(const std::string& key, bool* out);
  void Opt(const std::string& key, bool* out);
  void Req(const std::string& key, std::string* out);
  void Opt(const std::string& key, std::string* out);
  // One of `allowed`.
  void Opt(const std::string& key, std::string* out, const std::vector<std::string>& allowed);
  // [x, y, z]
  void Req(const std::string& key, Eigen::Vector3d* out);
  void Opt(const std::string& key, Eigen::Vector3d* out);
  // 3x3 as [[a,b,c],[d,e,f],[g,h,i]] or a diagonal [a, b, c].
  void Opt(const std::string& key, Eigen::Matrix3d* out);
  // A list of numbers.
  void Opt(const std::string& key, std::vector<double>* out, Bound bound = {});

  // A nested map: runs `fn` on it, then rejects its unknown keys. Optional: absent → not called.
  void Child(const std::string& key, const std::function<void(YamlReader&)>& fn, bool required = false);
  // A sequence of maps: runs `fn` on each item, then rejects each item's unknown keys.
  void ForEach(const std::string& key, const std::function<void(YamlReader&, size_t)>& fn,
               bool required = false);

  // Accepts `key` without reading it (a section another parser reads from the same document).
  void Ignore(const std::string& key) { used_.insert(key); }

  // Records an error about `key` (the first error wins).
  void Fail(const std::string& key, const std::string& what);
  // Records an error about this map as a whole.
  void FailHere(const std::string& what);
  bool ok() const { return error_->ok(); }
  // Rejects unknown keys of this map; returns the first error seen by this reader or its children.
  Status Finish();

  const YAML::Node& node() const { return node_; }
  const std::string& file() const { return file_; }
  // "FILE:LINE: prefix.key"
  std::string Where(const std::string& key) const;

 private:
  YamlReader(YAML::Node node, std::string file, std::string prefix, std::shared_ptr<Status> error);
  YAML::Node Fetch(const std::string& key, bool required);
  template <class T>
  bool Scalar(const std::string& key, bool required, T* out);
  void CheckBound(const std::string& key, double v, const Bound& b);

  YAML::Node node_;
  std::string file_;
  std::string prefix_;
  std::set<std::string> used_;
  std::shared_ptr<Status> error_;  // shared by a reader and its children: the first error wins
};

// Applies one "--set a.b.c=value" override to a loaded document. The path must name an existing
// key (numbers index sequences): an unknown key is bad input, never silently added.
// With create_missing, an absent last key is added (for documents whose strict parser rejects
// unknown keys afterwards, so a typo is still caught).
Status ApplyOverride(YAML::Node root, const std::string& assignment, const std::string& file,
                     bool create_missing = false);

}  // namespace hexsim
