#include "hexsim/batch/batch_spec.h"

#include <set>
#include <string>

#include <gtest/gtest.h>

#include "hexsim/batch/sha256.h"
#include "hexsim/common/yaml_reader.h"
#include "test_util.h"

namespace hexsim::batch {
namespace {

using nlohmann::json;

Result<BatchSpec> Parse(const std::string& yaml, const std::string& name = "test.yaml") {
  auto node = YamlReader::LoadString(yaml, name);
  if (!node.ok()) return node.status();
  return ParseBatch(*node, name);
}

TEST(Sha256, GivenFipsTestVectorsWhenHashedThenDigestsMatchThePublishedValues) {
  EXPECT_EQ(Sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(Sha256Hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_EQ(Sha256Hex(std::string(1000000, 'a')), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
  // Lengths around the padding boundary (55, 56, 63, 64 bytes) are distinct and well-formed.
  std::set<std::string> seen;
  for (size_t n : {55u, 56u, 63u, 64u, 65u}) seen.insert(Sha256Hex(std::string(n, 'x')));
  EXPECT_EQ(seen.size(), 5u);
}

TEST(RunPoint, GivenTheSameParametersInAnyOrderAndNumberSpellingWhenHashedThenTheRunIdIsTheSame) {
  RunPoint a, b;
  a.sets["control.rate.roll.kp"] = CanonicalValue(json(0.12));
  a.sets["world.wind.mean_N_mps"] = CanonicalValue(json::array({0.0, 5.0, 0.0}));
  b.sets["world.wind.mean_N_mps"] = CanonicalValue(json::array({0, 5, 0}));
  b.sets["control.rate.roll.kp"] = CanonicalValue(json(0.12));
  EXPECT_EQ(a.CanonicalJson(), b.CanonicalJson());
  EXPECT_EQ(a.RunId(), b.RunId());
  EXPECT_EQ(a.RunId().size(), 16u);
  EXPECT_EQ(a.RunId(), Sha256Hex(a.CanonicalJson()).substr(0, 16));
  // Canonical: sorted keys, no spaces, shortest round-trip numbers.
  EXPECT_EQ(a.CanonicalJson(),
            R"({"calibration":"none","duration_s":0,"estimator":"","mission":"square","seed":1,)"
            R"("set":{"control.rate.roll.kp":0.12,"world.wind.mean_N_mps":[0,5,0]},"vehicle":"default_hex","world":"default"})");
  b.seed = 2;
  EXPECT_NE(a.RunId(), b.RunId());
}

TEST(RunPoint, GivenParamsWhenReadBackThenThePointAndItsIdRoundTrip) {
  RunPoint a;
  a.mission = "figure_eight";
  a.seed = 42;
  a.duration_s = 7.5;
  a.sets["world.wind.mean_N_mps"] = json::array({1, 2.5, 0});
  auto b = RunPointFromParams(json::parse(a.CanonicalJson()));
  ASSERT_TRUE(b.ok());
  EXPECT_EQ(b->RunId(), a.RunId());
  EXPECT_EQ(b->SetAssignments(), std::vector<std::string>{"world.wind.mean_N_mps=[1,2.5,0]"});
}

TEST(ExpandBatch, GivenAGridAndSeedsWhenExpandedThenEveryCombinationAppearsOnceInFileOrder) {
  auto spec = Parse(R"(
missions: [square, figure_eight]
seeds: [1, 2]
grid:
  control.rate.roll.kp: [0.1, 0.2, 0.3]
  world.wind.mean_N_mps: [[0, 0, 0], [0, 5, 0]]
)");
  ASSERT_TRUE(spec.ok()) << spec.status().message();
  const auto runs = ExpandBatch(*spec);
  ASSERT_EQ(runs.size(), 2u * 2u * 3u * 2u);
  std::set<std::string> ids;
  for (const auto& r : runs) ids.insert(r.RunId());
  EXPECT_EQ(ids.size(), runs.size());
  // The first grid axis varies slowest, the seeds fastest.
  EXPECT_EQ(runs[0].sets.at("control.rate.roll.kp"), json(0.1));
  EXPECT_EQ(runs[0].seed, 1u);
  EXPECT_EQ(runs[1].seed, 2u);
  EXPECT_EQ(runs[1].mission, "square");
  EXPECT_EQ(runs[2].mission, "figure_eight");
  EXPECT_EQ(runs[4].sets.at("world.wind.mean_N_mps"), json::array({0, 5, 0}));
  EXPECT_EQ(runs.back().sets.at("control.rate.roll.kp"), json(0.3));
}

TEST(ExpandBatch, GivenRandomSamplingWhenExpandedTwiceThenDrawsRepeatAndStayInsideTheirRanges) {
  const std::string yaml = R"(
missions: [square]
random:
  samples: 200
  seed: 9
  params:
    control.rate.roll.kp: {uniform: [0.08, 0.16]}
    vehicle.mass_kg: {normal: [2.0, 0.1]}
    world.wind.mean_N_mps: {choice: [[0, 0, 0], [3, 0, 0]]}
)";
  auto spec = Parse(yaml);
  ASSERT_TRUE(spec.ok()) << spec.status().message();
  const auto a = ExpandBatch(*spec);
  const auto b = ExpandBatch(*Parse(yaml));
  ASSERT_EQ(a.size(), 200u);
  double mass_sum = 0;
  size_t windy = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].RunId(), b[i].RunId());
    const double kp = a[i].sets.at("control.rate.roll.kp").get<double>();
    EXPECT_GE(kp, 0.08);
    EXPECT_LT(kp, 0.16);
    mass_sum += a[i].sets.at("vehicle.mass_kg").get<double>();
    const json wind = a[i].sets.at("world.wind.mean_N_mps");
    EXPECT_TRUE(wind == json::array({0, 0, 0}) || wind == json::array({3, 0, 0}));
    windy += wind == json::array({3, 0, 0});
  }
  // Mean of 200 N(2, 0.1) draws: standard error 0.007; 5 sigma.
  EXPECT_NEAR(mass_sum / 200.0, 2.0, 0.035);
  // Binomial(200, 0.5): std 7.1; 5 sigma.
  EXPECT_NEAR(static_cast<double>(windy), 100.0, 36.0);
  spec->random_seed = 10;
  EXPECT_NE(ExpandBatch(*spec)[0].RunId(), a[0].RunId());
}

TEST(SelectShard, GivenNShardsWhenSelectedThenTheyPartitionTheRunsByIndexModN) {
  auto spec = Parse("missions: [square]\nseeds: {first: 1, count: 10}\n");
  ASSERT_TRUE(spec.ok());
  const auto all = ExpandBatch(*spec);
  std::multiset<std::string> union_ids;
  for (int i = 0; i < 4; ++i) {
    const auto part = SelectShard(all, Shard{i, 4});
    for (size_t j = 0; j < part.size(); ++j) {
      EXPECT_EQ(part[j].RunId(), all[static_cast<size_t>(i) + 4 * j].RunId());
      union_ids.insert(part[j].RunId());
    }
  }
  EXPECT_EQ(union_ids.size(), all.size());
  EXPECT_EQ(std::set<std::string>(union_ids.begin(), union_ids.end()).size(), all.size());
}

TEST(SelectShard, GivenAPointListedTwiceWhenShardedThenItRunsOnceInTheWholeBatch) {
  auto spec = Parse("missions: [square, square]\nseeds: [1, 2, 1]\n");
  ASSERT_TRUE(spec.ok());
  const auto all = ExpandBatch(*spec);
  ASSERT_EQ(all.size(), 6u);
  size_t total = 0;
  for (int i = 0; i < 3; ++i) total += SelectShard(all, Shard{i, 3}).size();
  EXPECT_EQ(total, 2u);
  EXPECT_EQ(SelectShard(all, Shard{0, 1}).size(), 2u);
}

TEST(ParseShard, GivenShardTextWhenParsedThenOnlyZeroBasedInRangeIsAccepted) {
  ASSERT_TRUE(ParseShard("0/4").ok());
  EXPECT_EQ(ParseShard("3/4")->index, 3);
  for (const char* bad : {"4/4", "-1/4", "1", "a/b", "1/0", "/3", "1/"}) EXPECT_FALSE(ParseShard(bad).ok()) << bad;
}

TEST(ParseBatch, GivenAnUnknownMissionWhenParsedThenTheErrorNamesFileLineAndListEntry) {
  auto spec = Parse("name: x\nmissions: [square, no_such_mission_here]\n", "b.yaml");
  ASSERT_FALSE(spec.ok());
  EXPECT_EQ(spec.status().code(), StatusCode::kBadInput);
  EXPECT_NE(spec.status().message().find("b.yaml:2: missions[1]: no such mission"), std::string::npos)
      << spec.status().message();
}

TEST(ParseBatch, GivenEmptySweepsOrUnknownKeysWhenParsedThenEachIsBadInputNamingTheField) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"missions: []\n", "missions: empty list"},
      {"missions: [square]\ngrid:\n  control.rate.roll.kp: []\n", "grid.control.rate.roll.kp: empty sweep"},
      {"missions: [square]\nseeds: []\n", "seeds: empty list"},
      {"missions: [square]\nseeds: {first: 1, count: 0}\n", "seeds.count"},
      {"missions: [square]\nrandom: {samples: 0, params: {sim.x: {uniform: [0, 1]}}}\n", "random.samples"},
      {"missions: [square]\nrandom: {samples: 2, params: {sim.x: {uniform: [1, 0]}}}\n", "expected lo < hi"},
      {"missions: [square]\nmissoins: [square]\n", "missoins: unknown key"},
      {"missions: [square]\ngrid:\n  kp: [1]\n", "not a parameter key"},
      {"missions: [square]\nestimators: [ekf]\n", "no such estimator"},
      {"vehicles: [default_hex]\n", "missions: required"},
      // A key that is a list: yaml-cpp's conversion threw out of ParseBatch.
      {"missions: [square]\nset: {[a, b]: 1}\n", "test.yaml:2:"},
      {"missions: [square]\n[x]: 1\n", "test.yaml:2:"},
      // Bytes that are not UTF-8 (found by fuzz_batch_yaml): the canonical JSON's dump threw.
      {"missions: [square]\nset: {world.wind\xff: 1}\n", "test.yaml:2: set.world.wind"},
      {"missions: [square]\ncalibrations: [\"none\xc3\"]\n", "calibrations[0]: not valid UTF-8"},
      {"missions: [square]\ngrid: {sim.a: [\"\xff\"]}\n", "grid.sim.a: not valid UTF-8"},
  };
  for (const auto& [yaml, expected] : cases) {
    auto spec = Parse(yaml);
    ASSERT_FALSE(spec.ok()) << yaml;
    EXPECT_EQ(spec.status().code(), StatusCode::kBadInput);
    EXPECT_NE(spec.status().message().find(expected), std::string::npos) << spec.status().message();
  }
}

TEST(ParseBatch, GivenMoreRunsThanABatchHoldsWhenParsedThenBadInputBeforeAnythingIsExpanded) {
  // 10^8 seeds alone (this threw std::bad_alloc while the list was filled), and a product of
  // modest axes beyond the limit: each a one-line error naming the field.
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"missions: [square]\nseeds: {first: 1, count: 100000000}\n", "test.yaml:2: seeds.count: 100000000 seeds"},
      {"missions: [square]\nseeds: {first: 1, count: 10000}\ngrid:\n  sim.a: [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]\n"
       "  sim.b: [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]\n  sim.c: [1, 2]\n",
       "test.yaml:1: batch: 2000000 runs"},
      {"missions: [square]\nseeds: {first: 1, count: 100}\n"
       "random: {samples: 20000, params: {sim.x: {uniform: [0, 1]}}}\n",
       "batch: 2000000 runs"},
  };
  for (const auto& [yaml, expected] : cases) {
    auto spec = Parse(yaml);
    ASSERT_FALSE(spec.ok()) << yaml;
    EXPECT_EQ(spec.status().code(), StatusCode::kBadInput);
    EXPECT_NE(spec.status().message().find(expected), std::string::npos) << spec.status().message();
  }
  // At the limit it parses, and CountRuns is what ExpandBatch makes.
  auto ok = Parse("missions: [square, figure_eight]\nseeds: {first: 1, count: 3}\ngrid:\n  sim.a: [1, 2]\n"
                  "random: {samples: 4, params: {sim.x: {uniform: [0, 1]}}}\n");
  ASSERT_TRUE(ok.ok()) << ok.status().message();
  EXPECT_EQ(CountRuns(*ok), static_cast<double>(ExpandBatch(*ok).size()));
  EXPECT_EQ(ExpandBatch(*ok).size(), 2u * 3u * (2u + 4u));
}

TEST(LoadBatchFile, GivenTheShippedExampleWhenLoadedThenItValidatesAndExpands) {
  auto spec = LoadBatchFile(std::string(HEXSIM_SOURCE_DIR) + "/worlds/batches/example.yaml");
  ASSERT_TRUE(spec.ok()) << spec.status().message();
  EXPECT_GT(ExpandBatch(*spec).size(), 0u);
  auto bad = LoadBatchFile(testing::DataFile("does_not_exist.yaml"));
  EXPECT_FALSE(bad.ok());
}

}  // namespace
}  // namespace hexsim::batch
