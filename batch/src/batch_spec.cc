#include "hexsim/batch/batch_spec.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <set>

#include <fmt/format.h>

#include "hexsim/batch/sha256.h"
#include "hexsim/common/paths.h"
#include "hexsim/common/rng.h"
#include "hexsim/common/yaml_reader.h"

namespace hexsim::batch {

using nlohmann::json;

namespace {

constexpr double kMaxExactInteger = 9007199254740992.0;  // 2^53

// "FILE:LINE: field: what"
Status BadAt(const std::string& file, const YAML::Node& node, const std::string& field, const std::string& what) {
  const int line = node.Mark().line >= 0 ? node.Mark().line + 1 : 0;
  if (line > 0) return Status::BadInput(fmt::format("{}:{}: {}: {}", file, line, field, what));
  return Status::BadInput(fmt::format("{}: {}: {}", file, field, what));
}

bool ParseDouble(const std::string& s, double* out) {
  if (s.empty()) return false;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end == s.c_str() || *end != '\0' || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

// Run parameters become canonical JSON, which must be valid UTF-8 (nlohmann::json throws on dump).
Status CheckUtf8(const std::string& file, const YAML::Node& at, const std::string& field, const json& v) {
  try {
    (void)v.dump();
  } catch (const json::type_error&) {
    return BadAt(file, at, field, "not valid UTF-8 text");
  }
  return Status::Ok();
}

const std::set<std::string> kSetRoots = {"mission", "vehicle", "world", "control", "nav", "sim"};

Status CheckSetKey(const std::string& file, const YAML::Node& at, const std::string& field, const std::string& key) {
  HEXSIM_RETURN_IF_ERROR(CheckUtf8(file, at, field, json(key)));
  const std::string root = key.substr(0, key.find('.'));
  if (key.find('.') == std::string::npos || key.back() == '.' || !kSetRoots.count(root)) {
    return BadAt(file, at, field,
                 fmt::format("'{}' is not a parameter key (mission.*, vehicle.*, world.*, control.*, nav.*, sim.*)", key));
  }
  return Status::Ok();
}

// A non-empty list of strings; `kind` ("missions", ...) set → each name must resolve under worlds/.
Status ReadNames(const std::string& file, const YAML::Node& root, const std::string& field, const std::string& kind,
                 std::vector<std::string>* out) {
  const YAML::Node n = root[field];
  if (!n.IsDefined()) return Status::Ok();
  if (n.IsScalar()) {
    out->assign(1, n.as<std::string>());
  } else if (n.IsSequence()) {
    if (n.size() == 0) return BadAt(file, n, field, "empty list (nothing to sweep)");
    out->clear();
    for (size_t i = 0; i < n.size(); ++i) {
      if (!n[i].IsScalar()) return BadAt(file, n[i], fmt::format("{}[{}]", field, i), "expected a name");
      out->push_back(n[i].as<std::string>());
    }
  } else {
    return BadAt(file, n, field, "expected a name or a list of names");
  }
  for (size_t i = 0; i < out->size(); ++i) {
    const YAML::Node at = n.IsSequence() ? n[i] : n;
    HEXSIM_RETURN_IF_ERROR(CheckUtf8(file, at, n.IsSequence() ? fmt::format("{}[{}]", field, i) : field, json((*out)[i])));
  }
  if (kind.empty()) return Status::Ok();
  for (size_t i = 0; i < out->size(); ++i) {
    std::string name = (*out)[i];
    auto resolved = ResolveWorldFile(kind, name);
    if (!resolved.ok()) {
      // A relative path in a batch file is taken relative to the batch file.
      const std::string beside = DirName(file) + "/" + name;
      if (name.find('/') != std::string::npos && ResolveWorldFile(kind, beside).ok()) {
        (*out)[i] = beside;
        continue;
      }
      const YAML::Node at = n.IsSequence() ? n[i] : n;
      return BadAt(file, at, n.IsSequence() ? fmt::format("{}[{}]", field, i) : field,
                   fmt::format("no such {} '{}'", kind.substr(0, kind.size() - 1), name));
    }
  }
  return Status::Ok();
}

Status ReadSeeds(const std::string& file, const YAML::Node& root, std::vector<uint64_t>* out) {
  const YAML::Node n = root["seeds"];
  if (!n.IsDefined()) return Status::Ok();
  auto as_seed = [&](const YAML::Node& v, const std::string& field, uint64_t* s) -> Status {
    double d = 0;
    if (!v.IsScalar() || !ParseDouble(v.Scalar(), &d) || d < 0 || d != std::floor(d) || d > kMaxExactInteger) {
      return BadAt(file, v, field, "expected a non-negative integer");
    }
    *s = static_cast<uint64_t>(d);
    return Status::Ok();
  };
  out->clear();
  if (n.IsSequence()) {
    if (n.size() == 0) return BadAt(file, n, "seeds", "empty list (nothing to sweep)");
    for (size_t i = 0; i < n.size(); ++i) {
      uint64_t s = 0;
      HEXSIM_RETURN_IF_ERROR(as_seed(n[i], fmt::format("seeds[{}]", i), &s));
      out->push_back(s);
    }
    return Status::Ok();
  }
  if (n.IsMap()) {  // {first: 1, count: 10}
    for (const auto& kv : n) {
      const std::string k = kv.first.as<std::string>();
      if (k != "first" && k != "count") return BadAt(file, kv.first, "seeds." + k, "unknown key (first, count)");
    }
    if (!n["count"].IsDefined()) return BadAt(file, n, "seeds.count", "required");
    uint64_t first = 1, count = 0;
    if (n["first"].IsDefined()) HEXSIM_RETURN_IF_ERROR(as_seed(n["first"], "seeds.first", &first));
    HEXSIM_RETURN_IF_ERROR(as_seed(n["count"], "seeds.count", &count));
    if (count == 0) return BadAt(file, n["count"], "seeds.count", "must be at least 1 (nothing to sweep)");
    if (count > kMaxBatchRuns) {
      return BadAt(file, n["count"], "seeds.count",
                   fmt::format("{} seeds: a batch holds at most {} runs (split it into several batch files)", count,
                               kMaxBatchRuns));
    }
    for (uint64_t i = 0; i < count; ++i) out->push_back(first + i);
    return Status::Ok();
  }
  return BadAt(file, n, "seeds", "expected a list of integers or {first: N, count: M}");
}

Status ReadNumber(const std::string& file, const YAML::Node& n, const std::string& field, double* out) {
  if (!n.IsScalar() || !ParseDouble(n.Scalar(), out)) return BadAt(file, n, field, "expected a number");
  return Status::Ok();
}

Status ReadRandom(const std::string& file, const YAML::Node& n, BatchSpec* spec) {
  if (!n.IsMap()) return BadAt(file, n, "random", "expected a map with samples, seed, params");
  for (const auto& kv : n) {
    const std::string k = kv.first.as<std::string>();
    if (k != "samples" && k != "seed" && k != "params") {
      return BadAt(file, kv.first, "random." + k, "unknown key (samples, seed, params)");
    }
  }
  if (!n["samples"].IsDefined()) return BadAt(file, n, "random.samples", "required");
  double samples = 0;
  HEXSIM_RETURN_IF_ERROR(ReadNumber(file, n["samples"], "random.samples", &samples));
  if (samples < 1 || samples != std::floor(samples) || samples > 1e7) {
    return BadAt(file, n["samples"], "random.samples", "must be a whole number ≥ 1 (nothing to sweep)");
  }
  spec->random_samples = static_cast<int>(samples);
  if (n["seed"].IsDefined()) {
    double s = 0;
    HEXSIM_RETURN_IF_ERROR(ReadNumber(file, n["seed"], "random.seed", &s));
    if (s < 0 || s != std::floor(s) || s > kMaxExactInteger) {
      return BadAt(file, n["seed"], "random.seed", "expected a non-negative integer");
    }
    spec->random_seed = static_cast<uint64_t>(s);
  }
  const YAML::Node params = n["params"];
  if (!params.IsDefined() || !params.IsMap() || params.size() == 0) {
    return BadAt(file, params.IsDefined() ? params : n, "random.params", "expected a non-empty map KEY: {uniform|normal|choice: ...}");
  }
  for (const auto& kv : params) {
    RandomParam p;
    p.key = kv.first.as<std::string>();
    const std::string field = "random.params." + p.key;
    HEXSIM_RETURN_IF_ERROR(CheckSetKey(file, kv.first, field, p.key));
    const YAML::Node& d = kv.second;
    if (!d.IsMap() || d.size() != 1) {
      return BadAt(file, d, field, "expected exactly one of {uniform: [lo, hi]}, {normal: [mean, std]}, {choice: [...]}");
    }
    const std::string kind = d.begin()->first.as<std::string>();
    const std::string field_kind = fmt::format("{}.{}", field, kind);
    const YAML::Node args = d.begin()->second;
    if (kind == "choice") {
      p.kind = RandomParam::Kind::kChoice;
      if (!args.IsSequence() || args.size() == 0) return BadAt(file, args, field + ".choice", "expected a non-empty list");
      for (const auto& c : args) {
        p.choices.push_back(CanonicalValue(YamlToJson(c)));
        HEXSIM_RETURN_IF_ERROR(CheckUtf8(file, c, field + ".choice", p.choices.back()));
      }
    } else if (kind == "uniform" || kind == "normal") {
      if (!args.IsSequence() || args.size() != 2) {
        return BadAt(file, args, field_kind, kind == "uniform" ? "expected [lo, hi]" : "expected [mean, std]");
      }
      HEXSIM_RETURN_IF_ERROR(ReadNumber(file, args[0], field_kind + "[0]", &p.a));
      HEXSIM_RETURN_IF_ERROR(ReadNumber(file, args[1], field_kind + "[1]", &p.b));
      if (kind == "uniform") {
        p.kind = RandomParam::Kind::kUniform;
        if (!(p.b > p.a)) return BadAt(file, args, field + ".uniform", "expected lo < hi");
      } else {
        p.kind = RandomParam::Kind::kNormal;
        if (!(p.b >= 0)) return BadAt(file, args, field + ".normal", "std must be ≥ 0");
      }
    } else {
      return BadAt(file, d.begin()->first, field_kind, "unknown distribution (uniform, normal, choice)");
    }
    spec->random.push_back(std::move(p));
  }
  return Status::Ok();
}

std::string SetValueText(const json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); }

}  // namespace

json CanonicalValue(const json& v) {
  if (v.is_number_float()) {
    const double d = v.get<double>();
    if (std::isfinite(d) && d == std::floor(d) && std::fabs(d) < kMaxExactInteger) {
      return json(static_cast<int64_t>(d));
    }
    return v;
  }
  if (v.is_number_unsigned()) return json(static_cast<int64_t>(v.get<uint64_t>()));
  if (v.is_array()) {
    json out = json::array();
    for (const auto& e : v) out.push_back(CanonicalValue(e));
    return out;
  }
  return v;
}

json YamlToJson(const YAML::Node& node) {
  if (node.IsSequence()) {
    json out = json::array();
    for (const auto& e : node) out.push_back(YamlToJson(e));
    return out;
  }
  if (node.IsMap()) {
    json out = json::object();
    for (const auto& kv : node) out[kv.first.as<std::string>()] = YamlToJson(kv.second);
    return out;
  }
  if (!node.IsScalar()) return json(nullptr);
  const std::string& s = node.Scalar();
  double d = 0;
  if (node.Tag() != "!" && ParseDouble(s, &d)) return CanonicalValue(json(d));
  if (node.Tag() != "!" && (s == "true" || s == "false")) return json(s == "true");
  return json(s);
}

json RunPoint::Params() const {
  json sets_json = json::object();
  for (const auto& [k, v] : sets) sets_json[k] = CanonicalValue(v);
  return json{{"mission", mission},       {"vehicle", vehicle}, {"world", world},
              {"calibration", calibration}, {"estimator", estimator},
              {"seed", seed},             {"duration_s", CanonicalValue(json(duration_s))},
              {"set", sets_json}};
}

std::string RunPoint::CanonicalJson() const { return Params().dump(); }

std::string RunPoint::RunId() const { return Sha256Hex(CanonicalJson()).substr(0, 16); }

std::vector<std::string> RunPoint::SetAssignments() const {
  std::vector<std::string> out;
  for (const auto& [k, v] : sets) out.push_back(k + "=" + SetValueText(v));
  return out;
}

Result<RunPoint> RunPointFromParams(const json& p) {
  try {
    RunPoint r;
    r.mission = p.at("mission").get<std::string>();
    r.vehicle = p.at("vehicle").get<std::string>();
    r.world = p.at("world").get<std::string>();
    r.calibration = p.at("calibration").get<std::string>();
    r.estimator = p.at("estimator").get<std::string>();
    r.seed = p.at("seed").get<uint64_t>();
    r.duration_s = p.at("duration_s").get<double>();
    for (const auto& [k, v] : p.at("set").items()) r.sets[k] = v;
    return r;
  } catch (const json::exception& e) {
    return Status::BadInput(std::string("params_json: ") + e.what());
  }
}

Result<BatchSpec> LoadBatchFile(const std::string& path) {
  auto resolved = ResolveWorldFile("batches", path);
  if (!resolved.ok()) return resolved.status();
  auto node = YamlReader::LoadFile(*resolved);
  if (!node.ok()) return node.status();
  return ParseBatch(*node, *resolved);
}

namespace {
Result<BatchSpec> ParseBatchOrThrow(const YAML::Node& root, const std::string& file);
}  // namespace

Result<BatchSpec> ParseBatch(const YAML::Node& root, const std::string& file) {
  // yaml-cpp throws where a node is not what a conversion expects (a key that is itself a list or a
  // map, `[a]: 1`): bad input at that node's line, not an escaping exception.
  try {
    return ParseBatchOrThrow(root, file);
  } catch (const YAML::Exception& e) {
    if (e.mark.line >= 0) return Status::BadInput(fmt::format("{}:{}: {}", file, e.mark.line + 1, e.msg));
    return Status::BadInput(fmt::format("{}: {}", file, e.msg));
  }
}

namespace {
Result<BatchSpec> ParseBatchOrThrow(const YAML::Node& root, const std::string& file) {
  if (!root.IsMap()) return Status::BadInput(file + ": expected a map (missions, vehicles, ..., grid, random)");
  static const std::set<std::string> kKeys = {"name",   "missions", "vehicles", "worlds",     "calibrations", "estimators",
                                              "seeds",  "duration_s", "set",    "grid",       "random"};
  for (const auto& kv : root) {
    const std::string k = kv.first.as<std::string>();
    if (!kKeys.count(k)) return BadAt(file, kv.first, k, "unknown key");
  }
  BatchSpec spec;
  spec.file = file;
  spec.name = root["name"].IsDefined() && root["name"].IsScalar() ? root["name"].Scalar() : FileStem(file);
  if (!root["missions"].IsDefined()) return BadAt(file, root, "missions", "required (a list of mission names or files)");
  HEXSIM_RETURN_IF_ERROR(ReadNames(file, root, "missions", "missions", &spec.missions));
  HEXSIM_RETURN_IF_ERROR(ReadNames(file, root, "vehicles", "vehicles", &spec.vehicles));
  HEXSIM_RETURN_IF_ERROR(ReadNames(file, root, "worlds", "environments", &spec.worlds));
  HEXSIM_RETURN_IF_ERROR(ReadNames(file, root, "calibrations", "", &spec.calibrations));
  for (auto& c : spec.calibrations) {  // a calib.yaml path is taken relative to the batch file
    std::error_code ec;
    const bool looks_like_file = c.find('/') != std::string::npos || c.find(".yaml") != std::string::npos;
    if (!looks_like_file || std::filesystem::exists(c, ec)) continue;
    std::string beside_file = fmt::format("{}/{}", DirName(file), c);
    if (std::filesystem::exists(beside_file, ec)) c = std::move(beside_file);
  }
  HEXSIM_RETURN_IF_ERROR(ReadNames(file, root, "estimators", "", &spec.estimators));
  for (size_t i = 0; i < spec.estimators.size(); ++i) {
    const std::string& e = spec.estimators[i];
    if (e != "eskf" && e != "complementary" && e != "truth" && !e.empty()) {
      return BadAt(file, root["estimators"].IsSequence() ? root["estimators"][i] : root["estimators"],
                   fmt::format("estimators[{}]", i), "no such estimator '" + e + "' (eskf, complementary, truth)");
    }
  }
  HEXSIM_RETURN_IF_ERROR(ReadSeeds(file, root, &spec.seeds));
  if (root["duration_s"].IsDefined()) {
    HEXSIM_RETURN_IF_ERROR(ReadNumber(file, root["duration_s"], "duration_s", &spec.duration_s));
    if (spec.duration_s < 0) return BadAt(file, root["duration_s"], "duration_s", "must be ≥ 0 (0: until the mission ends)");
  }
  if (const YAML::Node s = root["set"]; s.IsDefined()) {
    if (!s.IsMap()) return BadAt(file, s, "set", "expected a map KEY: VALUE");
    for (const auto& kv : s) {
      const std::string k = kv.first.as<std::string>();
      HEXSIM_RETURN_IF_ERROR(CheckSetKey(file, kv.first, "set." + k, k));
      spec.sets[k] = CanonicalValue(YamlToJson(kv.second));
      HEXSIM_RETURN_IF_ERROR(CheckUtf8(file, kv.second, "set." + k, spec.sets[k]));
    }
  }
  if (const YAML::Node g = root["grid"]; g.IsDefined()) {
    if (!g.IsMap() || g.size() == 0) return BadAt(file, g, "grid", "expected a non-empty map KEY: [values...]");
    for (const auto& kv : g) {
      const std::string k = kv.first.as<std::string>();
      const std::string field = "grid." + k;
      HEXSIM_RETURN_IF_ERROR(CheckSetKey(file, kv.first, field, k));
      if (!kv.second.IsSequence()) return BadAt(file, kv.second, field, "expected a list of values");
      if (kv.second.size() == 0) return BadAt(file, kv.second, field, "empty sweep (no values)");
      std::vector<json> values;
      for (const auto& v : kv.second) {
        values.push_back(CanonicalValue(YamlToJson(v)));
        HEXSIM_RETURN_IF_ERROR(CheckUtf8(file, v, field, values.back()));
      }
      for (const auto& [prev, unused] : spec.grid) {
        if (prev == k) return BadAt(file, kv.first, field, "listed twice");
      }
      spec.grid.emplace_back(k, std::move(values));
    }
  }
  if (const YAML::Node r = root["random"]; r.IsDefined()) HEXSIM_RETURN_IF_ERROR(ReadRandom(file, r, &spec));
  const double runs = CountRuns(spec);
  if (runs > static_cast<double>(kMaxBatchRuns)) {
    return BadAt(file, root, "batch",
                 fmt::format("{:.0f} runs (missions x vehicles x worlds x calibrations x estimators x seeds x "
                             "(grid points + random samples)): at most {} (split it into several batch files)",
                             runs, kMaxBatchRuns));
  }
  return spec;
}
}  // namespace

double CountRuns(const BatchSpec& spec) {
  double base = 1.0;
  for (size_t n : {spec.missions.size(), spec.vehicles.size(), spec.worlds.size(), spec.calibrations.size(),
                   spec.estimators.size(), spec.seeds.size()}) {
    base *= static_cast<double>(n);
  }
  double grid_points = 0.0;
  if (!spec.grid.empty() || spec.random_samples == 0) {
    grid_points = 1.0;
    for (const auto& axis : spec.grid) grid_points *= static_cast<double>(axis.second.size());
  }
  return base * (grid_points + static_cast<double>(spec.random_samples));
}

std::vector<RunPoint> ExpandBatch(const BatchSpec& spec) {
  std::vector<RunPoint> out;
  // Calls emit(point) for every base combination crossed with `extra` (grid values), seeds innermost.
  auto for_base = [&](const std::map<std::string, json>& extra) {
    for (const auto& m : spec.missions) {
      for (const auto& v : spec.vehicles) {
        for (const auto& w : spec.worlds) {
          for (const auto& c : spec.calibrations) {
            for (const auto& e : spec.estimators) {
              for (uint64_t seed : spec.seeds) {
                RunPoint p;
                p.mission = m;
                p.vehicle = v;
                p.world = w;
                p.calibration = c;
                p.estimator = e;
                p.seed = seed;
                p.duration_s = spec.duration_s;
                p.sets = spec.sets;
                for (const auto& [k, val] : extra) p.sets[k] = val;
                out.push_back(std::move(p));
              }
            }
          }
        }
      }
    }
  };
  // Grid: an odometer over the axes, the first axis slowest; no grid: the base product once.
  if (!spec.grid.empty() || spec.random_samples == 0) {
    std::vector<size_t> idx(spec.grid.size(), 0);
    auto advance = [&] {
      for (size_t a = spec.grid.size(); a-- > 0;) {
        if (++idx[a] < spec.grid[a].second.size()) return true;
        idx[a] = 0;
      }
      return false;
    };
    do {
      std::map<std::string, json> extra;
      for (size_t a = 0; a < spec.grid.size(); ++a) extra[spec.grid[a].first] = spec.grid[a].second[idx[a]];
      for_base(extra);
    } while (advance());
  }
  RngStream rng(spec.random_seed, "batch.random");
  for (int s = 0; s < spec.random_samples; ++s) {
    std::map<std::string, json> extra;
    for (const auto& p : spec.random) {
      switch (p.kind) {
        case RandomParam::Kind::kUniform: extra[p.key] = CanonicalValue(json(p.a + (p.b - p.a) * rng.Uniform())); break;
        case RandomParam::Kind::kNormal: extra[p.key] = CanonicalValue(json(rng.Normal(p.a, p.b))); break;
        case RandomParam::Kind::kChoice: {
          size_t i = static_cast<size_t>(rng.Uniform() * static_cast<double>(p.choices.size()));
          if (i >= p.choices.size()) i = p.choices.size() - 1;
          extra[p.key] = p.choices[i];
          break;
        }
      }
    }
    for_base(extra);
  }
  return out;
}

Result<Shard> ParseShard(const std::string& text) {
  const size_t slash = text.find('/');
  auto bad = [&] { return Status::BadInput("--shard " + text + ": expected i/N with 0 <= i < N (0-based)"); };
  if (slash == std::string::npos) return bad();
  char* end = nullptr;
  const std::string a = text.substr(0, slash), b = text.substr(slash + 1);
  const long i = std::strtol(a.c_str(), &end, 10);
  if (a.empty() || *end != '\0') return bad();
  const long n = std::strtol(b.c_str(), &end, 10);
  if (b.empty() || *end != '\0') return bad();
  if (n < 1 || i < 0 || i >= n || n > 1000000) return bad();
  return Shard{static_cast<int>(i), static_cast<int>(n)};
}

std::vector<RunPoint> SelectShard(const std::vector<RunPoint>& expanded, const Shard& shard) {
  std::vector<RunPoint> out;
  std::set<std::string> seen;
  for (size_t k = 0; k < expanded.size(); ++k) {
    if (!seen.insert(expanded[k].RunId()).second) continue;
    if (static_cast<int>(k % static_cast<size_t>(shard.count)) == shard.index) out.push_back(expanded[k]);
  }
  return out;
}

}  // namespace hexsim::batch
