// `hexsim calibrate` on plain dumps written here, and `hexsim field` on official WMM test points:
// exit codes, outputs, one-line errors, nothing half-written.
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace {

namespace fs = std::filesystem;

struct CliRun {
  int code = -1;
  std::string out, err;
};

fs::path Dir(const std::string& name) {
  fs::path p = fs::temp_directory_path() / ("hexsim_calcli_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

std::string Slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

CliRun Hexsim(const std::string& args) {
  const fs::path d = fs::temp_directory_path() / ("hexsim_calcli_io_" + std::to_string(::getpid()));
  fs::create_directories(d);
  const int raw = std::system((std::string(HEXSIM_BINARY) + " " + args + " >" + (d / "o").string() + " 2>" +
                               (d / "e").string()).c_str());
  return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, Slurp(d / "o"), Slurp(d / "e")};
}

// A dump in mG, whitespace-separated, no header: raw = diag(1.05, 0.97, 1.0)·B + (120, -80, 300) mG,
// B on a spiral over the whole sphere (full) or a level spin (flat), |B| = 500 mG.
fs::path WriteDump(const fs::path& dir, const std::string& kind, int n) {
  fs::path p = dir / (kind + ".txt");
  std::ofstream f(p);
  for (int i = 0; i < n; ++i) {
    const double z = kind == "flat" ? 0.8 : 1.0 - (2.0 * i + 1.0) / n;
    const double rho = std::sqrt(1.0 - z * z), phi = kind == "flat" ? 2.0 * M_PI * i / n : 2.39996322972865332 * i;
    f << 1.05 * 500 * rho * std::cos(phi) + 120 << " " << 0.97 * 500 * rho * std::sin(phi) - 80 << " " << 500 * z + 300 << "\n";
  }
  return p;
}

TEST(CalibrateCli, GivenAPlainDumpInMilligauss_WhenAuto_ThenEllipsoidAndEveryOutputWritten) {
  const fs::path d = Dir("full");
  const CliRun r = Hexsim("calibrate " + WriteDump(d, "full", 400).string() + " --out " + (d / "c.yaml").string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("assuming mG"), std::string::npos) << r.out;
  for (const char* f : {"c.yaml", "c.report.json", "c.parm", "c.params", "c.png"}) EXPECT_TRUE(fs::exists(d / f)) << f;
  EXPECT_FALSE(fs::exists(d / "c.norm.png"));  // no times: no norm-against-time view
  const auto j = nlohmann::json::parse(Slurp(d / "c.report.json"));
  EXPECT_EQ(j["method_used"], "ellipsoid");
  EXPECT_EQ(j["units_assumed"], "mG");
  EXPECT_NEAR(j["offset_uT"][0].get<double>(), 12.0, 0.01);
  EXPECT_NEAR(j["offset_uT"][2].get<double>(), 30.0, 0.01);
  // COMPASS_OFS = −offset in mG.
  EXPECT_NE(Slurp(d / "c.parm").find("COMPASS_OFS_X -120"), std::string::npos) << Slurp(d / "c.parm");
  EXPECT_NE(Slurp(d / "c.params").find("\tCAL_MAG0_XOFF\t0.1"), std::string::npos) << Slurp(d / "c.params");
  // The written calibration reads back (heading-error takes it).
  EXPECT_EQ(Hexsim("heading-error --calib " + (d / "c.yaml").string() + " --step-deg 30").code, 0);
}

TEST(CalibrateCli, GivenMethodNone_WhenRun_ThenExit0WithTheSameReportKeys) {
  const fs::path d = Dir("none");
  const CliRun r = Hexsim("calibrate " + WriteDump(d, "full", 100).string() + " --method none --out " + (d / "c.yaml").string());
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(Slurp(d / "c.report.json"));
  EXPECT_EQ(j["method_used"], "none");
  EXPECT_TRUE(j["fitness_uT"].is_number());
  EXPECT_TRUE(j.contains("ardupilot_params"));
}

TEST(CalibrateCli, GivenAFlatSpin_WhenAutoOrEllipsoid_ThenWarningAndExit0OrExit2NamingTheRotation) {
  const fs::path d = Dir("flat");
  const fs::path dump = WriteDump(d, "flat", 72);
  CliRun r = Hexsim("calibrate " + dump.string() + " --out " + (d / "a.yaml").string());
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("warning: poor coverage"), std::string::npos) << r.out;
  r = Hexsim("calibrate " + dump.string() + " --method ellipsoid --out " + (d / "e.yaml").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("body z"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("flat.txt"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(d / "e.yaml"));
  EXPECT_FALSE(fs::exists(d / "e.report.json"));
}

TEST(CalibrateCli, GivenTooFewSamplesOrBadUnits_WhenRun_ThenExit2NamingWhy) {
  const fs::path d = Dir("few");
  CliRun r = Hexsim("calibrate " + WriteDump(d, "full", 5).string() + " --out " + (d / "c.yaml").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("at least 8"), std::string::npos) << r.err;
  r = Hexsim("calibrate " + WriteDump(d, "full", 50).string() + " --units counts --out " + (d / "c.yaml").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--field-norm"), std::string::npos) << r.err;
  r = Hexsim("calibrate " + WriteDump(d, "full", 50).string() + " --units counts --field-norm 50 --out " +
             (d / "c.yaml").string());
  EXPECT_EQ(r.code, 0) << r.err;
}

// Samples on a one-sheet hyperboloid (|B| from 40 to 57 uT, every direction but the poles): usable
// input, but no ellipsoid fits it. An explicit ellipsoid cannot converge: exit 3 with the reason and
// the coverage, nothing written; auto falls back to a sphere and says so.
TEST(CalibrateCli, GivenSamplesNoEllipsoidFits_WhenEllipsoidOrAuto_ThenExit3WithTheReasonOrASphereWithAWarning) {
  const fs::path d = Dir("hyper");
  const fs::path p = d / "hyper.txt";
  {
    std::ofstream f(p);
    for (int i = 0; i < 300; ++i) {
      const double t = 2.39996322972865332 * i, s = -0.9 + 1.8 * (i % 37) / 36.0;
      f << 40 * std::cosh(s) * std::cos(t) << " " << 40 * std::cosh(s) * std::sin(t) << " " << 40 * std::sinh(s) << "\n";
    }
  }
  CliRun r = Hexsim("calibrate " + p.string() + " --units uT --method ellipsoid --out " + (d / "e.yaml").string());
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("did not converge"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("coverage eigenvalues"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(d / "e.yaml"));
  EXPECT_FALSE(fs::exists(d / "e.report.json"));
  r = Hexsim("calibrate " + p.string() + " --units uT --out " + (d / "a.yaml").string());
  EXPECT_TRUE(r.code == 0 || r.code == 1) << r.err;  // 1: the sphere's residual fails the gate
  EXPECT_NE(r.out.find("fell back to a sphere"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(d / "a.report.json"));
}

TEST(FieldCli, GivenOfficialTestPoints_WhenAskedPerModel_ThenWithin1nT) {
  // The first and last official points of each model's test file (data/wmm/test_values_*.csv, NOAA's,
  // as shipped in ../shared/data/wmm20xx/) through the command: X, Y, Z, H, F within 1 nT, angles within
  // 0.01 deg. magnetics' WmmOfficialPoints checks every point of every file in the library (one
  // process per point here would cost ~0.5 s each on a loaded machine).
  for (const std::string id : {"2015", "2015v2", "2020", "2025"}) {
    std::istringstream csv(Slurp(fs::path(HEXSIM_SOURCE_DIR) / "data" / "wmm" / ("test_values_" + id + ".csv")));
    std::string header, row;
    std::getline(csv, header);
    std::vector<std::string> rows;
    while (std::getline(csv, row)) {
      if (!row.empty()) rows.push_back(row);
    }
    ASSERT_GE(rows.size(), 12u) << id;
    for (const std::string& row : {rows.front(), rows.back()}) {
      std::vector<double> v;
      std::stringstream ss(row);
      for (std::string cell; std::getline(ss, cell, ',');) v.push_back(std::stod(cell));
      ASSERT_EQ(v.size(), 12u) << row;
      const CliRun r = Hexsim("field " + std::to_string(v[2]) + " " + std::to_string(v[3]) + " " +
                              std::to_string(v[1] * 1000) + " " + std::to_string(v[0]) + " --model wmm" + id + " --json");
      ASSERT_EQ(r.code, 0) << r.err;
      const auto j = nlohmann::json::parse(r.out);
      EXPECT_EQ(j["schema"], "hexsim.field/1");
      EXPECT_EQ(j["model_id"], "wmm" + id);
      EXPECT_NEAR(j["north_nT"].get<double>(), v[4], 1.0) << id << ": " << row;
      EXPECT_NEAR(j["east_nT"].get<double>(), v[5], 1.0) << id << ": " << row;
      EXPECT_NEAR(j["down_nT"].get<double>(), v[6], 1.0) << id << ": " << row;
      EXPECT_NEAR(j["horizontal_nT"].get<double>(), v[7], 1.0) << id << ": " << row;
      EXPECT_NEAR(j["total_nT"].get<double>(), v[8], 1.0) << id << ": " << row;
      EXPECT_NEAR(j["inclination_deg"].get<double>(), v[9], 0.01) << id << ": " << row;
      EXPECT_NEAR(j["declination_deg"].get<double>(), v[10], 0.01) << id << ": " << row;
    }
  }
  const CliRun out = Hexsim("field 43.88 125.35 200 2030.4");
  EXPECT_EQ(out.code, 2);
  EXPECT_NE(out.err.find("2030.4 outside"), std::string::npos) << out.err;
  const CliRun text = Hexsim("field 43.88 125.35 200 2016-07-02");
  EXPECT_EQ(text.code, 0) << text.err;
  EXPECT_NE(text.out.find("WMM-2015v2"), std::string::npos) << text.out;
}

// The ground methods given what they cannot use: a flight log (here a simulated run's log.csv) or a
// plain dump. They used to exit 3 ("ellipsoid refinement did not converge", "sample 0: non-finite
// field, control, current or angle"); now one line says what they need and what to use instead.
TEST(CalibrateCli, GivenAFlightLogOrAPlainDump_WhenAGroundMethodIsAsked_ThenOneLineSaysWhatItNeedsAndExit2) {
  const fs::path d = Dir("ground_methods");
  ASSERT_EQ(Hexsim("run square --duration 8 --out " + (d / "run").string()).code, 0);
  for (const char* method : {"adaptive", "adaptive-current", "compassmot", "px4-ls", "traditional"}) {
    CliRun r = Hexsim("calibrate " + (d / "run" / "log.csv").string() + " --method " + method + " --out " +
                      (d / "c.yaml").string());
    EXPECT_EQ(r.code, 2) << method << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find("needs turntable samples"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("use --method flight"), std::string::npos) << r.err;
    r = Hexsim("calibrate " + WriteDump(d, "full", 300).string() + " --method " + method + " --out " +
               (d / "c.yaml").string());
    EXPECT_EQ(r.code, 2) << method << ": " << r.err;
    EXPECT_NE(r.err.find("plain field samples"), std::string::npos) << r.err;
  }
  EXPECT_FALSE(fs::exists(d / "c.yaml"));
}

// A fit its gate rejects (5 uT of noise against a 2 uT residual bound) writes calib.yaml and its
// report (exit 1) but no .parm/.params that an autopilot could load, and removes those an earlier
// run left at that path.
TEST(CalibrateCli, GivenANoisyDump_WhenTheGateRejectsTheFit_ThenNoAutopilotParameterFileIsLeft) {
  const fs::path d = Dir("rejected");
  {
    std::ofstream f(d / "noisy.txt");
    for (int i = 0; i < 300; ++i) {
      const double z = 1.0 - (2.0 * i + 1.0) / 300, rho = std::sqrt(1.0 - z * z), phi = 2.39996322972865332 * i;
      const double noise = 8.0 * std::sin(7.3 * i);  // deterministic, ~5.7 uT RMS per axis
      f << 50 * rho * std::cos(phi) + noise << " " << 50 * rho * std::sin(phi) - noise << " " << 50 * z + 0.5 * noise << "\n";
    }
  }
  std::ofstream(d / "c.parm") << "COMPASS_OFS_X 1\n";
  std::ofstream(d / "c.params") << "1\t1\tCAL_MAG0_XOFF\t0.1\t9\n";
  const CliRun r = Hexsim("calibrate " + (d / "noisy.txt").string() + " --method ellipsoid --units uT --out " +
                          (d / "c.yaml").string());
  ASSERT_EQ(r.code, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("REJECTED"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(d / "c.yaml"));
  EXPECT_TRUE(fs::exists(d / "c.report.json"));
  EXPECT_FALSE(fs::exists(d / "c.parm"));
  EXPECT_FALSE(fs::exists(d / "c.params"));
}

TEST(CalibrateCli, GivenAFieldNormOutsideTheEarthsField_WhenCalibrating_ThenExit2NamingTheFlag) {
  const fs::path d = Dir("field_norm");
  for (const char* norm : {"-5", "0.5", "500"}) {
    const CliRun r = Hexsim("calibrate " + WriteDump(d, "full", 300).string() + " --field-norm " + norm + " --out " +
                            (d / "c.yaml").string());
    EXPECT_EQ(r.code, 2) << norm;
    EXPECT_NE(r.err.find("--field-norm: "), std::string::npos) << r.err;
  }
  EXPECT_FALSE(fs::exists(d / "c.yaml"));
}

}  // namespace

// The shared real log (ArduCopter 3.3 quad, data/real): a flight log with an attitude and a place,
// so `auto` takes the attitude-aided flight fit in the log's flight windows. Independent references
// for this log (the real-log diagnosis issue: a stacked least-squares fit of field, offset and k·I
// over 82.9-236.9 s, 10 s block bootstrap): internal MAG2 |k| = 3.5 [2.8, 4.6] mG/A, external MAG
// 0.57 [0.21, 1.59] mG/A with every axis interval including 0.
TEST(CalibrateCli, GivenTheRealArduPilotLog_WhenAuto_ThenTheFlightFitFindsMag2sCurrentFieldAndNotMags) {
  const fs::path d = Dir("real");
  const std::string log = std::string(HEXSIM_SOURCE_DIR) + "/data/real/ardupilot_copter_log171.bin";
  CliRun r = Hexsim("calibrate " + log + " --compass mag2 --out " + (d / "m2" / "c.yaml").string());
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  // The field norm before and after against time and against current: two 700-px panels side by side.
  const std::string png = Slurp(d / "m2" / "c.norm.png");
  ASSERT_GT(png.size(), 24U);
  EXPECT_EQ(png.substr(1, 3), "PNG");
  const auto byte = [&](size_t i) { return static_cast<uint32_t>(static_cast<unsigned char>(png[i])); };
  EXPECT_EQ(byte(16) << 24 | byte(17) << 16 | byte(18) << 8 | byte(19), 1400U);  // IHDR width
  auto rep = nlohmann::json::parse(Slurp(d / "m2" / "c.report.json"));
  EXPECT_EQ(rep["method_used"], "flight") << r.out;
  const auto& cur = rep["flight_fit"]["current"];
  const double k = cur["norm_mG_per_A"].get<double>();
  EXPECT_GE(k, 2.2) << r.out;
  EXPECT_LE(k, 9.0) << r.out;
  EXPECT_LT(cur["norm_ci95_mG_per_A"][1].get<double>() - cur["norm_ci95_mG_per_A"][0].get<double>(), 10.0);
  EXPECT_TRUE(cur["applied"].get<bool>());
  // The flip at 238.9 s and the ground before take-off are not in the fit.
  EXPECT_GT(rep["flight_fit"]["outside_flight_windows"].get<int>(), 500);
  const std::string parm = Slurp(d / "m2" / "c.parm");
  EXPECT_NE(parm.find("COMPASS_MOTCT 2"), std::string::npos) << parm;
  EXPECT_NE(parm.find("COMPASS_MOT2_X"), std::string::npos) << parm;
  EXPECT_NE(Slurp(d / "m2" / "c.params").find("CAL_MAG_COMP_TYP"), std::string::npos);
  // The residual after the fit is a small part of the one before (the WMM field and no offset).
  EXPECT_LT(rep["flight_fit"]["residual_rms_after_uT"].get<double>(),
            0.2 * rep["flight_fit"]["residual_rms_before_uT"].get<double>());

  r = Hexsim("calibrate " + log + " --compass mag --out " + (d / "m1" / "c.yaml").string());
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  rep = nlohmann::json::parse(Slurp(d / "m1" / "c.report.json"));
  EXPECT_FALSE(rep["flight_fit"]["current"]["applied"].get<bool>()) << r.out;
  // No COMPASS_MOT* parameter line; the comment says why none was written.
  const std::string parm1 = Slurp(d / "m1" / "c.parm");
  EXPECT_EQ(parm1.find("\nCOMPASS_MOT"), std::string::npos) << parm1;
  EXPECT_NE(parm1.find("not written"), std::string::npos) << parm1;
  EXPECT_NE(r.out.find("not resolved from zero"), std::string::npos) << r.out;
}

// Without a place the Earth field is fitted freely (flight_fit.h field_free), which needs the attitude
// to change; this log never turns, so nothing tells the field from the offset.
TEST(CalibrateCli, GivenAFlightLogWithoutAPlace_WhenMethodFlight_ThenExit2SaysWhatIsMissing) {
  const fs::path d = Dir("noplace");
  {
    std::ofstream f(d / "log.csv");
    f << "t_s,q_w,q_x,q_y,q_z,mag_t_s,mag_x_uT,mag_y_uT,mag_z_uT\n";
    for (int i = 0; i < 200; ++i) f << 0.1 * i << ",1,0,0,0," << 0.1 * i << "," << 20 + i % 7 << ",5,-40\n";
  }
  const CliRun r = Hexsim("calibrate " + (d / "log.csv").string() + " --method flight --out " + (d / "c.yaml").string());
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("no place and date"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(d / "c.yaml"));
}

// One in-flight compass model: `calibrate --method flight` and `gap diagnose` fit the same samples on
// the same timing, so gap.json's absolute current term is calibrate's, and both write the same
// COMPASS_MOT2_* lines (gap with calibrate's writer, beside gap.json).
TEST(CalibrateCli, GivenTheRealArduPilotLog_WhenCalibratedAndDiagnosed_ThenBothReportTheSameAbsoluteCurrentTerm) {
  const fs::path d = Dir("same");
  const std::string log = std::string(HEXSIM_SOURCE_DIR) + "/data/real/ardupilot_copter_log171.bin";
  CliRun r = Hexsim("calibrate " + log + " --method flight --compass mag2 --out " + (d / "cal" / "c.yaml").string());
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const auto cal_fit = nlohmann::json::parse(Slurp(d / "cal" / "c.report.json"))["flight_fit"];
  const auto& cal = cal_fit["current"];
  r = Hexsim("import " + log + " --out " + (d / "l.csv").string());
  ASSERT_EQ(r.code, 0) << r.err;
  r = Hexsim("gap diagnose --real " + (d / "l.csv").string() + " --sim quad_x --out " + (d / "gap").string());
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const auto gap = nlohmann::json::parse(Slurp(d / "gap" / "gap.json"));
  const nlohmann::json* mag2 = nullptr;
  for (const auto& c : gap["channels"]) {
    if (c["channel"] == "mag2") mag2 = &c;
  }
  ASSERT_NE(mag2, nullptr) << r.out;
  const auto& term = (*mag2)["absolute_terms"]["current_term"];
  EXPECT_NEAR(term["norm_mG_per_A"].get<double>(), cal["norm_mG_per_A"].get<double>(), 1e-9);
  EXPECT_NEAR(term["norm_ci95_mG_per_A"][0].get<double>(), cal["norm_ci95_mG_per_A"][0].get<double>(), 1e-9);
  EXPECT_NEAR(term["norm_ci95_mG_per_A"][1].get<double>(), cal["norm_ci95_mG_per_A"][1].get<double>(), 1e-9);
  // The same current shift, chosen by the model's own fit inside current_staleness's range (0..1 s).
  const auto& timing = (*mag2)["absolute_terms"]["timing"];
  const double shift = cal_fit["current_shift_s"].get<double>();
  EXPECT_NEAR(timing["current_shift_s"].get<double>(), shift, 1e-9);
  EXPECT_GE(shift, 0.0);
  EXPECT_LE(shift, 1.0);
  EXPECT_LE(cal_fit["current_shift_range_s"][0].get<double>(), shift);
  EXPECT_GE(cal_fit["current_shift_range_s"][1].get<double>(), shift);
  EXPECT_EQ(timing["current_shift_range_s"], cal_fit["current_shift_range_s"]);
  // The same parameter lines for MAG2's compensation (a real internal compass, resolved).
  auto line = [](const std::string& text, const std::string& name) {
    const size_t at = text.find("\n" + name + " ");
    return at == std::string::npos ? std::string() : text.substr(at + 1, text.find('\n', at + 1) - at - 1);
  };
  const std::string cal_parm = Slurp(d / "cal" / "c.parm"), gap_parm = Slurp(d / "gap" / "calib.parm");
  for (const char* name : {"COMPASS_MOTCT", "COMPASS_MOT2_X", "COMPASS_MOT2_Y", "COMPASS_MOT2_Z", "COMPASS_OFS2_X"}) {
    EXPECT_FALSE(line(gap_parm, name).empty()) << name << "\n" << gap_parm;
    EXPECT_EQ(line(gap_parm, name), line(cal_parm, name)) << name;
  }
  EXPECT_NE(gap_parm.find("# mag2: COMPASS_MOTCT/COMPASS_MOT2_*: written"), std::string::npos) << gap_parm;
  EXPECT_NE(r.out.find("parameters to paste"), std::string::npos) << r.out;
}
