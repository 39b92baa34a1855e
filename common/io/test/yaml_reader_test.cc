#include "hexsim/common/yaml_reader.h"

#include <gtest/gtest.h>

namespace hexsim {
namespace {

Result<YAML::Node> Load(const char* text) { return YamlReader::LoadString(text, "t.yaml"); }

TEST(YamlReader, ReadsFieldsAndNestedMaps) {
  auto node = Load("mass_kg: 2.5\nname: hex\nbattery:\n  cells: 6\npos: [1, 2, 3]\n");
  ASSERT_TRUE(node.ok());
  YamlReader r(*node, "t.yaml");
  double mass = 0;
  std::string name;
  int cells = 0;
  Eigen::Vector3d pos = Eigen::Vector3d::Zero();
  r.Req("mass_kg", &mass, Positive());
  r.Opt("name", &name);
  r.Child("battery", [&](YamlReader& b) { b.Req("cells", &cells, Positive()); });
  r.Req("pos", &pos);
  ASSERT_TRUE(r.Finish().ok()) << r.Finish().message();
  EXPECT_EQ(mass, 2.5);
  EXPECT_EQ(name, "hex");
  EXPECT_EQ(cells, 6);
  EXPECT_EQ(pos, Eigen::Vector3d(1, 2, 3));
}

TEST(YamlReader, NegativeMassNamesFileLineAndField) {
  auto node = Load("name: x\nmass_kg: -1\n");
  ASSERT_TRUE(node.ok());
  YamlReader r(*node, "t.yaml");
  double mass = 0;
  std::string name;
  r.Opt("name", &name);
  r.Req("mass_kg", &mass, Positive());
  const Status s = r.Finish();
  EXPECT_EQ(s.code(), StatusCode::kBadInput);
  EXPECT_EQ(s.message(), "t.yaml:2: mass_kg: must be > 0 (got -1)");
}

TEST(YamlReader, UnknownNestedKeyIsRejected) {
  auto node = Load("battery:\n  cells: 6\n  colour: red\n");
  ASSERT_TRUE(node.ok());
  YamlReader r(*node, "t.yaml");
  int cells = 0;
  r.Child("battery", [&](YamlReader& b) { b.Req("cells", &cells); });
  const Status s = r.Finish();
  EXPECT_EQ(s.message(), "t.yaml:3: battery.colour: unknown key");
}

TEST(YamlReader, SyntaxErrorNamesLine) {
  auto node = Load("a: 1\nb: [1, 2\n");
  ASSERT_FALSE(node.ok());
  EXPECT_NE(node.status().message().find("t.yaml:"), std::string::npos);
  EXPECT_EQ(node.status().code(), StatusCode::kBadInput);
}

TEST(YamlReader, MissingRequiredFieldInListItem) {
  auto node = Load("rotors:\n  - {x: 1}\n  - {y: 2}\n");
  ASSERT_TRUE(node.ok());
  YamlReader r(*node, "t.yaml");
  r.ForEach("rotors", [&](YamlReader& item, size_t) {
    double x = 0, y = 0;
    item.Req("x", &x);
    item.Opt("y", &y);
  });
  EXPECT_EQ(r.Finish().message(), "t.yaml:3: rotors[1].x: required field is missing");
}

TEST(ApplyOverride, SetsExistingKeyAndRejectsUnknown) {
  auto node = Load("control:\n  rate:\n    kp: 0.1\nlist: [1, 2]\n");
  ASSERT_TRUE(node.ok());
  ASSERT_TRUE(ApplyOverride(*node, "control.rate.kp=0.25", "t.yaml").ok());
  EXPECT_DOUBLE_EQ((*node)["control"]["rate"]["kp"].as<double>(), 0.25);
  ASSERT_TRUE(ApplyOverride(*node, "list.1=5", "t.yaml").ok());
  EXPECT_DOUBLE_EQ((*node)["list"][1].as<double>(), 5.0);
  const Status s = ApplyOverride(*node, "control.rate.kd=1", "t.yaml");
  EXPECT_EQ(s.code(), StatusCode::kBadInput);
  EXPECT_NE(s.message().find("unknown key 'kd'"), std::string::npos);
}

}  // namespace
}  // namespace hexsim
