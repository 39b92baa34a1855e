// The comparison report and `hexsim plot` as a user meets them: report.html with its figures beside
// it, the tables' numbers, the standard figures of a log, and one-line errors on bad input.
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "hexsim/render/image.h"

namespace {

namespace fs = std::filesystem;

struct CmdResult {
  int code = -1;
  std::string out, err;
};

fs::path TempDir(const std::string& name) {
  fs::path p = fs::temp_directory_path() / ("hexsim_report_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

std::string Slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

CmdResult Hexsim(const std::string& args, const fs::path& scratch) {
  const fs::path out = scratch / "stdout.txt", err = scratch / "stderr.txt";
  const std::string cmd = std::string(HEXSIM_BINARY) + " " + args + " >" + out.string() + " 2>" + err.string();
  const int raw = std::system(cmd.c_str());
  CmdResult r;
  r.code = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  r.out = Slurp(out);
  r.err = Slurp(err);
  return r;
}

int Lines(const std::string& s) { return static_cast<int>(std::count(s.begin(), s.end(), '\n')); }

// A figure shows something: a good share of non-white pixels (axes, text, data) and some saturated,
// coloured pixels (the data series; axes and text are grey).
struct PixelStats {
  double ink_fraction = 0.0;
  int coloured = 0;
};
PixelStats Inspect(const fs::path& png) {
  PixelStats st;
  auto image = hexsim::render::ReadPng(png.string());
  if (!image.ok() || image->empty()) return st;
  long ink = 0;
  for (int y = 0; y < image->height; ++y) {
    for (int x = 0; x < image->width; ++x) {
      const hexsim::render::Rgba8 p = image->At(x, y);
      const int mx = std::max({p.r, p.g, p.b}), mn = std::min({p.r, p.g, p.b});
      if (mn < 235) ++ink;
      if (mx - mn > 80) ++st.coloured;
    }
  }
  st.ink_fraction = static_cast<double>(ink) / (static_cast<double>(image->width) * image->height);
  return st;
}

void ExpectFigure(const fs::path& png) {
  ASSERT_TRUE(fs::exists(png)) << png;
  const PixelStats st = Inspect(png);
  EXPECT_GT(st.ink_fraction, 0.01) << png << " looks blank";
  EXPECT_LT(st.ink_fraction, 0.90) << png << " looks filled";
  EXPECT_GT(st.coloured, 200) << png << " has no coloured data";
}

std::string Fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// One small comparison shared by the report tests (about 2 s).
class CompareReport : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(TempDir("compare"));
    result_ = new CmdResult(Hexsim("compare climb_cruise_square --vehicle paper_hex --world changchun --seeds 2 "
                                   "--calibrations none,traditional,adaptive --duration 20 --jobs 2 "
                                   "--set sim.control_on_truth=true --out " +
                                       (*dir_ / "out").string(),
                                   *dir_));
  }
  static void TearDownTestSuite() {
    delete dir_;
    delete result_;
  }
  static fs::path Out() { return *dir_ / "out"; }
  static nlohmann::json Comparison() { return nlohmann::json::parse(Slurp(Out() / "comparison.json")); }
  static fs::path* dir_;
  static CmdResult* result_;
};
fs::path* CompareReport::dir_ = nullptr;
CmdResult* CompareReport::result_ = nullptr;

TEST_F(CompareReport, GivenSmallCompareWhenItFinishesThenReportHtmlLinksOnlyExistingNonBlankPngsBesideIt) {
  ASSERT_EQ(result_->code, 0) << result_->err;
  EXPECT_NE(result_->out.find("report.html"), std::string::npos) << "compare prints the report's path";
  const std::string html = Slurp(Out() / "report.html");
  ASSERT_FALSE(html.empty());
  std::set<std::string> srcs;
  const std::string img = "<img src=\"";
  for (size_t at = html.find(img); at != std::string::npos; at = html.find(img, at + 1)) {
    const size_t begin = at + img.size();
    const size_t end = html.find('"', begin);
    ASSERT_NE(end, std::string::npos) << "unterminated <img src=";
    srcs.insert(html.substr(begin, end - begin));
  }
  for (const std::string& s : srcs) {
    EXPECT_EQ(s.find('/'), std::string::npos) << s << ": links must be relative, beside report.html";
    EXPECT_EQ(s.substr(s.size() - 4), ".png");
    ExpectFigure(Out() / s);
  }
  // The paper's figures and the flight figures are all there.
  for (const char* f : {"fig3_ellipsoids.png", "fig4_centre_line.png", "fig5_heading_uncorrected.png",
                        "fig6_heading_traditional.png", "fig7_heading_adaptive.png", "tracks_none.png",
                        "tracks_traditional.png", "tracks_adaptive.png", "tracks_all.png", "yaw_error.png",
                        "current.png"}) {
    EXPECT_TRUE(srcs.count(f)) << f << " missing from report.html";
  }
  // Every figure has a caption, and the page needs no server: inline CSS, no scripts, no remote links.
  EXPECT_EQ(srcs.count(std::string()), 0u);
  size_t n_captions = 0;
  for (size_t at = html.find("<figcaption>"); at != std::string::npos; at = html.find("<figcaption>", at + 1)) {
    ++n_captions;
  }
  EXPECT_EQ(n_captions, srcs.size());
  EXPECT_NE(html.find("<style>"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(html.find("http"), std::string::npos);
}

TEST_F(CompareReport, GivenComparisonJsonWhenReportWrittenThenBothTablesShowItsNumbersAndThePapersTable1) {
  ASSERT_EQ(result_->code, 0) << result_->err;
  const std::string html = Slurp(Out() / "report.html");
  const nlohmann::json c = Comparison();
  // Heading-error table: our max and RMS per control amount for every calibration.
  ASSERT_TRUE(c.contains("heading_error"));
  for (const auto& row : c["heading_error"]["rows"]) {
    EXPECT_NE(html.find(">" + row["name"].get<std::string>() + "<"), std::string::npos);
    for (double v : row["max_deg"].get<std::vector<double>>()) {
      EXPECT_NE(html.find("<td>" + Fixed(v, 2) + "</td>"), std::string::npos) << v;
    }
    for (double v : row["rms_deg"].get<std::vector<double>>()) {
      EXPECT_NE(html.find("<td>" + Fixed(v, 2) + "</td>"), std::string::npos) << v;
    }
  }
  // The paper's own Table 1, beside ours.
  for (const char* v : {"12.5", "13.3", "14.3", "2.5", "5.0", "7.6", "2.4", "2.6"}) {
    EXPECT_NE(html.find(std::string("<td class=\"paper\">") + v + "</td>"), std::string::npos) << v;
  }
  // Track-error table: mean ± std and the 95 % interval of each group's figures (two seeds).
  for (const auto& g : c["groups"]) {
    for (const char* m : {"yaw_error_deg.max", "cross_track_m.rms"}) {
      const auto& v = g["metrics"][m];
      EXPECT_NE(html.find(Fixed(v["mean"].get<double>(), 2) + " ± " + Fixed(v["std"].get<double>(), 2)), std::string::npos) << m;
      // A non-negative figure's interval stops at 0, marked "*" (ci95_clipped).
      EXPECT_GE(v["ci95"][0].get<double>(), 0.0) << m;
      const std::string clip = v.value("ci95_clipped", false) ? "*" : "";
      EXPECT_NE(html.find("CI95 [" + Fixed(v["ci95"][0].get<double>(), 2) + clip + ", " +
                          Fixed(v["ci95"][1].get<double>(), 2) + "]"),
                std::string::npos)
          << m;
    }
  }
}

// One Table 1: `turntable`, `calibrate` and `heading-error` on their defaults (the README's commands)
// give compare's table. They differed (traditional 2.17 / 5.45 / 7.54 against 2.43 / 5.45 / 7.46): the
// turntable's seed 1 was not the ground session compare's first seed learns from.
TEST_F(CompareReport, GivenTheDefaultSeedsWhenTable1IsMadeByHandThenItIsCompareTable1) {
  ASSERT_EQ(result_->code, 0) << result_->err;
  const fs::path d = *dir_ / "by_hand";
  ASSERT_EQ(Hexsim("turntable --out " + d.string(), *dir_).code, 0);
  std::string calibs;
  for (const char* m : {"traditional", "adaptive"}) {
    const CmdResult r = Hexsim("calibrate " + (d / "samples.csv").string() + " --method " + m + " --out " +
                                   (d / (std::string(m) + ".yaml")).string(),
                               *dir_);
    ASSERT_EQ(r.code, 0) << r.err;
    calibs += " --calib " + (d / (std::string(m) + ".yaml")).string();
  }
  ASSERT_EQ(Hexsim("heading-error" + calibs + " --json " + (d / "table1.json").string(), *dir_).code, 0);
  const auto by_hand = nlohmann::json::parse(Slurp(d / "table1.json"));
  const nlohmann::json he = Comparison()["heading_error"];
  ASSERT_EQ(by_hand["control_u"], he["control_u"]);
  int compared = 0;
  for (const auto& row : by_hand["rows"]) {
    for (const auto& other : he["rows"]) {
      if (other["name"] != row["name"]) continue;
      const auto a = row["max_deg"].get<std::vector<double>>(), b = other["max_deg"].get<std::vector<double>>();
      ASSERT_EQ(a.size(), b.size());
      // samples.csv holds the session at 6 significant digits: agreement to 0.01 deg.
      for (size_t k = 0; k < a.size(); ++k) EXPECT_NEAR(a[k], b[k], 0.01) << row["name"] << " u " << k;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 3);  // uncorrected, traditional, adaptive
}

TEST_F(CompareReport, GivenReportHeadingFiguresWhenTheirDataIsReadThenTheyReproduceTable1AndAdaptiveBeatsUncorrected) {
  ASSERT_EQ(result_->code, 0) << result_->err;
  // heading_residuals.csv holds every point of Figs. 5–7; the report regenerates the turntable
  // sessions itself, so its largest |error| per curve must be Table 1's figure from compare.
  std::map<std::pair<std::string, double>, double> max_abs;
  std::istringstream csv(Slurp(Out() / "heading_residuals.csv"));
  std::string line;
  std::getline(csv, line);
  ASSERT_EQ(line, "method,control_u,current_A,angle_deg,heading_error_deg");
  int points = 0;
  while (std::getline(csv, line)) {
    std::stringstream ss(line);
    std::string method, u, current, angle, err;
    std::getline(ss, method, ',');
    std::getline(ss, u, ',');
    std::getline(ss, current, ',');
    std::getline(ss, angle, ',');
    std::getline(ss, err, ',');
    auto& m = max_abs[{method, std::stod(u)}];
    m = std::max(m, std::fabs(std::stod(err)));
    ++points;
  }
  EXPECT_GE(points, 3 * 3 * 36);  // 3 methods × 3 control amounts × a turn in ≤ 10° steps
  const nlohmann::json he = Comparison()["heading_error"];
  const auto controls = he["control_u"].get<std::vector<double>>();
  for (const auto& row : he["rows"]) {
    const auto mx = row["max_deg"].get<std::vector<double>>();
    const std::string name = row["name"].get<std::string>();
    for (size_t k = 0; k < controls.size(); ++k) {
      const auto key = std::make_pair(name, controls[k]);
      ASSERT_TRUE(max_abs.count(key)) << name << " " << controls[k];
      EXPECT_NEAR(max_abs[key], mx[k], 1e-9) << name << " " << controls[k];
    }
  }
  // The physics the figures show: at the highest control amount the current's field turns the
  // uncorrected heading by more than the adaptive correction leaves (the paper: 14.3° vs 2.6°).
  const double uncorrected_deg = max_abs[std::make_pair(std::string("uncorrected"), controls.back())];
  const double adaptive_deg = max_abs[std::make_pair(std::string("adaptive"), controls.back())];
  EXPECT_GT(uncorrected_deg, 2.0 * adaptive_deg);
}

class PlotCommand : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(TempDir("plot"));
    run_ = new CmdResult(Hexsim("run climb_cruise_square --vehicle paper_hex --world changchun --duration 12 "
                                "--set sim.control_on_truth=true --out " +
                                    (*dir_ / "run").string(),
                                *dir_));
  }
  static void TearDownTestSuite() {
    delete dir_;
    delete run_;
  }
  static fs::path* dir_;
  static CmdResult* run_;
};
fs::path* PlotCommand::dir_ = nullptr;
CmdResult* PlotCommand::run_ = nullptr;

TEST_F(PlotCommand, GivenShortSimulatedLogWhenPlottedThenEveryStandardFigureIsWrittenAndNotBlank) {
  ASSERT_EQ(run_->code, 0) << run_->err;
  const fs::path out = *dir_ / "figs";
  const CmdResult r = Hexsim("plot " + (*dir_ / "run" / "log.csv").string() + " --out " + out.string(), *dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* f : {"track_top.png", "track_3d.png", "altitude.png", "attitude.png", "yaw_error.png",
                        "compass_mag.png", "power.png", "motors.png"}) {
    ExpectFigure(out / f);
    EXPECT_NE(r.out.find(f), std::string::npos) << "plot lists what it wrote";
  }
}

TEST_F(PlotCommand, GivenTwoLogsWhenPlottedThenEachGetsItsSetAndTheirTracksAndYawErrorsAreOverlaid) {
  ASSERT_EQ(run_->code, 0) << run_->err;
  const fs::path a = *dir_ / "a.csv", b = *dir_ / "b.csv";
  fs::copy_file(*dir_ / "run" / "log.csv", a, fs::copy_options::overwrite_existing);
  fs::copy_file(*dir_ / "run" / "log.csv", b, fs::copy_options::overwrite_existing);
  const fs::path out = *dir_ / "overlay";
  const CmdResult r = Hexsim("plot " + a.string() + " " + b.string() + " --out " + out.string(), *dir_);
  ASSERT_EQ(r.code, 0) << r.err;
  ExpectFigure(out / "overlay_tracks.png");
  ExpectFigure(out / "overlay_yaw_error.png");
  ExpectFigure(out / "a" / "track_top.png");
  ExpectFigure(out / "b" / "track_top.png");
}

TEST(PlotErrors, GivenMissingLogWhenPlottedThenExit2WithOneLineNamingTheFileAndNothingWritten) {
  const fs::path d = TempDir("missing");
  const fs::path out = d / "figs";
  const CmdResult r = Hexsim("plot " + (d / "no_such_log.csv").string() + " --out " + out.string(), d);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(Lines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("no_such_log.csv"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

TEST(PlotErrors, GivenCsvWithoutTimeColumnWhenPlottedThenExit2NamingTheFile) {
  const fs::path d = TempDir("no_t");
  {
    std::ofstream f(d / "bad.csv");
    f << "pos_N_m,pos_E_m\n1,2\n3,4\n";
  }
  const fs::path out = d / "figs";
  const CmdResult r = Hexsim("plot " + (d / "bad.csv").string() + " --out " + out.string(), d);
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(Lines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find("bad.csv"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
