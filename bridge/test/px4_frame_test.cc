// PX4's rotor order for the shipped vehicles, the output mapping, and the committed airframe files.
#include "hexsim/bridge/px4_frame.h"

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "hexsim/vehicle/vehicle_io.h"
#include "hexsim/vehicle/powertrain.h"

namespace hexsim::bridge {
namespace {

vehicle::VehicleParams Load(const std::string& name) {
  auto v = vehicle::LoadVehicleFile(std::string(HEXSIM_SOURCE_DIR) + "/worlds/vehicles/" + name + ".yaml");
  EXPECT_TRUE(v.ok()) << v.status().message();
  return *v;
}

// quad_x and the hexes are numbered as ArduPilot's QUAD X / HEXA X, which is PX4's order too.
TEST(Px4RotorOrder, ShippedVehiclesAreInPx4Order) {
  for (const char* name : {"quad_x", "paper_hex", "default_hex"}) {
    auto map = MapPx4Rotors(Load(name));
    ASSERT_TRUE(map.ok()) << name << ": " << map.status().message();
    for (size_t i = 0; i < map->rotor.size(); ++i) EXPECT_EQ(map->rotor[i], i) << name;
  }
}

// Given a quad whose file lists the rotors in another order, PX4's channel i still drives the rotor
// at PX4's position i, and a command on channel 0 moves the front-right CCW rotor.
TEST(Px4RotorOrder, PermutedVehicleMapsByGeometry) {
  vehicle::VehicleParams v = Load("quad_x");
  std::swap(v.rotors[0], v.rotors[3]);  // file order: RR(CW), RL, FL, FR(CCW)
  auto map = MapPx4Rotors(v);
  ASSERT_TRUE(map.ok());
  EXPECT_EQ(map->rotor[0], 3u);
  EXPECT_EQ(map->rotor[3], 0u);
  float controls[16] = {0.7f, 0.1f, 0.2f, 0.3f};
  std::vector<double> cmd(4, 0.0);
  CommandsFromPx4Outputs(*map, controls, 16, &cmd);
  EXPECT_FLOAT_EQ(cmd[3], 0.7f);
  EXPECT_GT(v.rotors[3].position_B_m.x(), 0);
  EXPECT_GT(v.rotors[3].position_B_m.y(), 0);
  EXPECT_EQ(v.rotors[3].spin, 1);
}

TEST(Px4RotorOrder, WrongSpinOrCountIsBadInput) {
  vehicle::VehicleParams v = Load("quad_x");
  v.rotors[0].spin = -1;
  EXPECT_FALSE(MapPx4Rotors(v).ok());
  v = Load("quad_x");
  v.rotors.pop_back();
  EXPECT_FALSE(MapPx4Rotors(v).ok());
}

TEST(Px4Outputs, NanAndOutOfRangeAreClamped) {
  auto map = MapPx4Rotors(Load("quad_x"));
  float controls[4] = {std::nanf(""), 1.5f, -0.2f, 0.4f};
  std::vector<double> cmd(4, 0.5);
  CommandsFromPx4Outputs(*map, controls, 4, &cmd);
  EXPECT_EQ(cmd[0], 0.0);
  EXPECT_EQ(cmd[1], 1.0);
  EXPECT_EQ(cmd[2], 0.0);
  EXPECT_FLOAT_EQ(cmd[3], 0.4f);
}

std::string ParamLines(const std::string& path) {
  std::ifstream in(path);
  std::string line, out;
  while (std::getline(in, line)) {
    if (line.rfind("param set-default ", 0) == 0) out += line + "\n";
  }
  return out;
}

// The committed airframe files say what the vehicle files say (regenerate them when a vehicle
// changes: the expected text is written next to the build's test binary).
TEST(Px4Airframe, CommittedFilesMatchTheVehicles) {
  for (const auto& [vehicle_name, file] : {std::pair{"quad_x", "22001_hexsim_quad_x"},
                                           std::pair{"paper_hex", "22002_hexsim_paper_hex"}}) {
    auto expected = Px4AirframeParams(Load(vehicle_name));
    ASSERT_TRUE(expected.ok()) << expected.status().message();
    const std::string path = std::string(HEXSIM_SOURCE_DIR) + "/worlds/px4/" + file;
    const std::string got = ParamLines(path);
    if (got != *expected) {
      std::ofstream(std::string(HEXSIM_BINARY_DIR) + "/" + file + ".expected") << *expected;
    }
    EXPECT_EQ(got, *expected) << path << " differs from the vehicle; expected text in " << HEXSIM_BINARY_DIR << "/"
                              << file << ".expected";
  }
}

// Hover thrust: the file's MPC_THR_HOVER command lifts the vehicle's weight (quad_x: 1.5 kg).
TEST(Px4Airframe, HoverCommandCarriesTheWeight) {
  const vehicle::VehicleParams v = Load("quad_x");
  auto text = Px4AirframeParams(v);
  ASSERT_TRUE(text.ok());
  const size_t at = text->find("MPC_THR_HOVER ");
  ASSERT_NE(at, std::string::npos);
  const double hover = std::stod(text->substr(at + 14));
  const double V = v.battery.OpenCircuitVoltage_V(v.battery.initial_soc);
  const double thrust = 4 * vehicle::ThrustForCommand(v, 0, hover, V);
  EXPECT_NEAR(thrust / (v.mass_kg * 9.80665), 1.0, 0.03);
}

}  // namespace
}  // namespace hexsim::bridge
