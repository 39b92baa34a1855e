// A batch file (worlds/batches/*.yaml; format in the comment header of example.yaml) and its
// expansion into runs. Each run is one point: mission, vehicle, world, calibration, estimator, seed,
// duration and `--set` overrides. Its id is the first 16 hex digits of the SHA-256 of its canonical
// JSON parameters (sorted keys, no spaces, numbers in shortest round-trip form; see CONTRACTS.md).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "hexsim/common/status.h"

namespace hexsim::batch {

struct RunPoint {
  std::string mission = "square";
  std::string vehicle = "default_hex";
  std::string world = "default";
  std::string calibration = "none";
  std::string estimator;   // empty: the simulator's default
  uint64_t seed = 1;
  double duration_s = 0.0; // 0: until the mission ends
  // `--set` overrides: key → value (number, string, bool or list), kept canonical (integral numbers
  // as integers).
  std::map<std::string, nlohmann::json> sets;

  // {"calibration":…,"duration_s":…,"estimator":…,"mission":…,"seed":…,"set":{…},"vehicle":…,"world":…}
  nlohmann::json Params() const;
  std::string CanonicalJson() const;
  std::string RunId() const;  // 16 lower-case hex digits
  // "key=value" strings for sim::RunRequest::sets.
  std::vector<std::string> SetAssignments() const;
};

// Inverse of RunPoint::Params() (for rows read back from a results file).
Result<RunPoint> RunPointFromParams(const nlohmann::json& params);

// A number in canonical form: integral values below 2^53 as integers, others as doubles (which
// nlohmann::json prints in shortest round-trip form); non-numbers unchanged, lists element-wise.
nlohmann::json CanonicalValue(const nlohmann::json& v);
// A YAML scalar or sequence as JSON (numbers and booleans typed, everything else a string).
nlohmann::json YamlToJson(const YAML::Node& node);

struct RandomParam {
  enum class Kind { kUniform, kNormal, kChoice };
  std::string key;
  Kind kind = Kind::kUniform;
  double a = 0.0, b = 0.0;  // uniform: [lo, hi); normal: mean, std
  std::vector<nlohmann::json> choices;
};

struct BatchSpec {
  std::string file;
  std::string name;
  std::vector<std::string> missions;
  std::vector<std::string> vehicles = {"default_hex"};
  std::vector<std::string> worlds = {"default"};
  std::vector<std::string> calibrations = {"none"};
  std::vector<std::string> estimators = {""};
  std::vector<uint64_t> seeds = {1};
  double duration_s = 0.0;
  std::map<std::string, nlohmann::json> sets;  // applied to every run
  std::vector<std::pair<std::string, std::vector<nlohmann::json>>> grid;  // axes in file order
  int random_samples = 0;
  uint64_t random_seed = 1;
  std::vector<RandomParam> random;  // in file order
};

// The most runs one batch file may expand to. Every shard expands and hashes the whole file in
// memory: 10^6 runs took 610 MB and 25 s to `--list` on one core; 10^5 take 61 MB and 2.5 s. A larger
// sweep is several batch files.
constexpr uint64_t kMaxBatchRuns = 100000;

// Reads and validates a batch file: unknown keys, empty lists, unknown missions/vehicles/worlds,
// malformed YAML are kBadInput "FILE:LINE: FIELD: what is wrong".
Result<BatchSpec> LoadBatchFile(const std::string& path);
Result<BatchSpec> ParseBatch(const YAML::Node& root, const std::string& file);

// Every run in order: the grid points in file order (grid axes outermost, the first axis slowest; at
// each grid point missions × vehicles × worlds × calibrations × estimators × seeds, seeds fastest),
// then the random samples in draw order, each crossed with the same base axes. Without a grid the
// base product is one grid point; with only `random`, there are no grid points. Duplicates are kept.
std::vector<RunPoint> ExpandBatch(const BatchSpec& spec);
// How many runs ExpandBatch makes (a double: the product cannot overflow).
double CountRuns(const BatchSpec& spec);

struct Shard {
  int index = 0;  // 0 ≤ index < count
  int count = 1;
};
// "i/N" (0-based).
Result<Shard> ParseShard(const std::string& text);

// The runs of one shard: run k (counting the expanded list) belongs to shard k mod N; a point listed
// again later (same run id) is dropped, so it runs once in the whole batch.
std::vector<RunPoint> SelectShard(const std::vector<RunPoint>& expanded, const Shard& shard);

}  // namespace hexsim::batch
