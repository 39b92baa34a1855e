#include "hexsim/vehicle/vehicle_io.h"
#include "hexsim/vehicle/vehicle_params.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "hexsim/common/yaml_reader.h"

namespace hexsim::vehicle {
namespace {

std::string VehiclePath(const std::string& name) {
  return std::string(HEXSIM_SOURCE_DIR) + "/worlds/vehicles/" + name + ".yaml";
}

const char* kMinimal = R"(name: tiny
mass_kg: 1.0
inertia_kgm2: [0.01, 0.01, 0.02]
motor: {kv_rpm_per_V: 900, winding_resistance_ohm: 0.1, no_load_current_A: 0.5, inertia_kgm2: 5.0e-5}
rotors:
  - {position_B_m: [0.2, 0.0, 0.0], spin: 1, k_T_Nprps2: 1.0e-5, k_Q_Nmprps2: 2.0e-7}
  - {position_B_m: [-0.2, 0.0, 0.0], spin: -1, k_T_Nprps2: 1.0e-5, k_Q_Nmprps2: 2.0e-7}
battery: {cells_series: 4, capacity_Ah: 5.0, internal_resistance_ohm: 0.02}
)";

Result<VehicleParams> ParseText(const std::string& text) {
  Result<YAML::Node> doc = YamlReader::LoadString(text, "v.yaml");
  if (!doc.ok()) return doc.status();
  return ParseVehicle(*doc, "v.yaml");
}

TEST(VehicleParams, GivenShippedVehicleFilesWhenParsedThenTheyLoadWithTheirRotorsAndCompasses) {
  struct Expect {
    const char* name;
    size_t rotors;
    size_t compasses;
  };
  for (const Expect& e : {Expect{"default_hex", 6, 1}, Expect{"paper_hex", 6, 1}, Expect{"quad_x", 4, 3},
                          Expect{"octo_x", 8, 1}}) {
    Result<VehicleParams> v = LoadVehicleFile(VehiclePath(e.name));
    ASSERT_TRUE(v.ok()) << v.status().message();
    EXPECT_EQ(v->name, e.name);
    EXPECT_EQ(v->rotors.size(), e.rotors);
    EXPECT_EQ(v->compasses.size(), e.compasses);
    // Spins alternate to balance yaw: as many CW as CCW rotors.
    int spin_sum = 0;
    for (const RotorParams& r : v->rotors) {
      spin_sum += r.spin;
      EXPECT_NEAR(r.axis_B.norm(), 1.0, 1e-12);
      EXPECT_GT(r.k_T_Nprps2, 0.0);
    }
    EXPECT_EQ(spin_sum, 0) << e.name;
    EXPECT_FALSE(v->wiring.segments.empty()) << e.name;
    EXPECT_EQ(v->wiring.dipoles.size(), e.rotors) << e.name;
  }
}

TEST(VehicleParams, GivenQuadXWhenParsedThenOneCompassIsExternalAndTwoInternal) {
  Result<VehicleParams> v = LoadVehicleFile(VehiclePath("quad_x"));
  ASSERT_TRUE(v.ok()) << v.status().message();
  int external = 0;
  for (const CompassParams& c : v->compasses) external += c.external ? 1 : 0;
  EXPECT_EQ(external, 1);
  EXPECT_TRUE(v->compasses[0].external);
}

TEST(VehicleParams, GivenNegativeMassWhenParsedThenErrorNamesFileLineAndField) {
  std::string text = kMinimal;
  text.replace(text.find("mass_kg: 1.0"), 12, "mass_kg: -1");
  Result<VehicleParams> v = ParseText(text);
  ASSERT_FALSE(v.ok());
  EXPECT_EQ(v.status().code(), StatusCode::kBadInput);
  EXPECT_EQ(v.status().message(), "v.yaml:2: mass_kg: must be > 0 (got -1)");
}

TEST(VehicleParams, GivenUnknownKeyWhenParsedThenRejected) {
  Result<VehicleParams> v = ParseText(std::string(kMinimal) + "colour: red\n");
  ASSERT_FALSE(v.ok());
  EXPECT_NE(v.status().message().find("colour: unknown key"), std::string::npos) << v.status().message();
  Result<VehicleParams> nested = ParseText(std::string(kMinimal) + "esc: {efficiency: 0.9, duty_idle: 0.1}\n");
  ASSERT_FALSE(nested.ok());
  EXPECT_NE(nested.status().message().find("esc.duty_idle: unknown key"), std::string::npos)
      << nested.status().message();
}

TEST(VehicleParams, GivenInvalidFieldsWhenParsedThenEachIsRejectedWithItsName) {
  struct Case {
    std::string from, to, field;
  };
  const Case cases[] = {
      {"spin: 1,", "spin: 0,", "rotors[0].spin"},
      {"kv_rpm_per_V: 900", "kv_rpm_per_V: 0", "motor.kv_rpm_per_V"},
      {"capacity_Ah: 5.0", "capacity_Ah: -5.0", "battery.capacity_Ah"},
      {"inertia_kgm2: [0.01, 0.01, 0.02]", "inertia_kgm2: [0.01, 0.01, 0.05]", "inertia_kgm2"},
      {"k_Q_Nmprps2: 2.0e-7}\n  - ", "k_Q_Nmprps2: -2.0e-7}\n  - ", "rotors[0].k_Q_Nmprps2"},
      {"internal_resistance_ohm: 0.02}", "internal_resistance_ohm: 0.02, c_rating: 0}", "battery.c_rating"},
      {"internal_resistance_ohm: 0.02}", "internal_resistance_ohm: 0.02, c_rating: 20, max_current_A: 90}",
       "battery.c_rating"},
      {"battery:", "esc: {current_limit_A: -3}\nbattery:", "esc.current_limit_A"},
  };
  for (const Case& c : cases) {
    std::string text = kMinimal;
    const size_t at = text.find(c.from);
    ASSERT_NE(at, std::string::npos) << c.from;
    text.replace(at, c.from.size(), c.to);
    Result<VehicleParams> v = ParseText(text);
    ASSERT_FALSE(v.ok()) << c.field;
    EXPECT_NE(v.status().message().find(": " + c.field + ":"), std::string::npos) << v.status().message();
  }
}

TEST(VehicleParams, GivenWiringThatNamesAMissingMotorWhenParsedThenRejected) {
  const std::string text = std::string(kMinimal) +
                           "wiring:\n  segments:\n    - {a_B_m: [0, 0, 0], b_B_m: [0.1, 0, 0], source: motor, motor: 3}\n";
  Result<VehicleParams> v = ParseText(text);
  ASSERT_FALSE(v.ok());
  EXPECT_NE(v.status().message().find("wiring.segments[0].motor: must name a rotor 1..2 (got 3)"), std::string::npos)
      << v.status().message();
}

TEST(VehicleParams, GivenNoiseDensityWhenParsedThenPerSampleStdIsDensityTimesRootRate) {
  const std::string text =
      std::string(kMinimal) + "sensors:\n  gyro: {rate_hz: 400, noise_density_radps_per_sqrt_hz: 1.0e-4}\n";
  Result<VehicleParams> v = ParseText(text);
  ASSERT_TRUE(v.ok()) << v.status().message();
  EXPECT_NEAR(v->sensors.gyro.noise.noise_std, 1.0e-4 * std::sqrt(400.0), 1e-15);
}

TEST(VehicleParams, GivenMotorNumbersInFileWhenParsedThenStoredZeroBased) {
  const std::string text = std::string(kMinimal) +
                           "wiring:\n  dipoles:\n    - {motor: 2, p_B_m: [-0.2, 0, 0], moment_per_A_Am2: [0, 0, 0.001]}\n";
  Result<VehicleParams> v = ParseText(text);
  ASSERT_TRUE(v.ok()) << v.status().message();
  ASSERT_EQ(v->wiring.dipoles.size(), 1u);
  EXPECT_EQ(v->wiring.dipoles[0].motor_index, 1);
}

TEST(VehicleParams, GivenBatteryTableWhenQueriedThenVoltageInterpolatesAndClamps) {
  BatteryParams b;
  b.cells_series = 6;
  EXPECT_NEAR(b.OpenCircuitVoltage_V(1.0), 6 * 4.20, 1e-12);
  EXPECT_NEAR(b.OpenCircuitVoltage_V(1.5), 6 * 4.20, 1e-12);
  EXPECT_NEAR(b.OpenCircuitVoltage_V(0.85), 6 * 0.5 * (4.00 + 4.08), 1e-12);
  EXPECT_NEAR(b.OpenCircuitVoltage_V(-0.1), 6 * 3.27, 1e-12);
}

TEST(VehicleParams, GivenACRatingWhenParsedThenTheBatteryLimitIsCTimesCapacity) {
  std::string text = kMinimal;
  text.replace(text.find("internal_resistance_ohm: 0.02}"), 30, "internal_resistance_ohm: 0.02, c_rating: 25}");
  Result<VehicleParams> v = ParseText(text);
  ASSERT_TRUE(v.ok()) << v.status().message();
  EXPECT_DOUBLE_EQ(v->battery.max_current_A, 125.0);
  EXPECT_FALSE(std::isfinite(v->esc.current_limit_A));  // no ESC limit unless given
  EXPECT_DOUBLE_EQ(v->esc.spool_up_time_s, 0.5);        // ArduPilot's MOT_SPOOL_TIME default
}

}  // namespace
}  // namespace hexsim::vehicle
