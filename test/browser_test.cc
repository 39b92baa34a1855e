// The HTML reports in a real browser: headless Chromium opens report.html (compare), gap.html (gap
// diagnose, with and without --sim), identify.html and the batch report; every <img> must load with
// a non-zero natural size, no block may be wider than a 1280 px window (unless inside a scrolling
// box), no text may be raw JSON, and a screenshot of the page must not be blank. Skipped, saying so,
// where Chromium is not installed (scripts/test.sh installs Debian's `chromium`).
#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "hexsim/render/image.h"

namespace {

namespace fs = std::filesystem;

std::string Slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// Runs a shell command; its exit code (-1 when it did not exit normally) and stdout.
int Shell(const std::string& cmd, std::string* out = nullptr) {
  const fs::path o = fs::temp_directory_path() / ("hexsim_browser_out_" + std::to_string(::getpid()));
  const int raw = std::system((cmd + " >" + o.string() + " 2>/dev/null").c_str());
  if (out) *out = Slurp(o);
  fs::remove(o);
  return WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
}

std::string FindChromium() {
  for (const char* name : {"chromium", "chromium-browser", "google-chrome"}) {
    std::string path;
    if (Shell(std::string("command -v ") + name, &path) == 0 && !path.empty()) {
      path.erase(path.find_last_not_of('\n') + 1);
      return path;
    }
  }
  return "";
}

// Headless Chromium as root in a container: no sandbox, no GPU, a throw-away profile.
std::string Chromium(const std::string& binary, const fs::path& profile) {
  return binary + " --headless --no-sandbox --disable-gpu --no-first-run --disable-dev-shm-usage "
                  "--user-data-dir=" + profile.string() + " ";
}

// Appended to a copy of the page (beside it, so relative image paths resolve): after load, writes
// how many images there are and which did not load into the DOM that --dump-dom prints.
constexpr const char* kImageCheck = R"(<script>
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images), bad = [];
  imgs.forEach(function (i) {
    if (!(i.complete && i.naturalWidth > 0 && i.naturalHeight > 0)) bad.push(i.getAttribute('src'));
  });
  // Blocks wider than the viewport that no scrolling container of theirs holds.
  var width = document.documentElement.clientWidth, over = [];
  function scrolls(e) {
    for (var a = e.parentElement; a && a !== document.body; a = a.parentElement) {
      var o = getComputedStyle(a).overflowX;
      if (o === 'auto' || o === 'scroll' || o === 'hidden') return true;
    }
    return false;
  }
  Array.prototype.forEach.call(document.body.querySelectorAll('*'), function (e) {
    var st = getComputedStyle(e);
    if (st.display === 'inline' || st.display === 'none' || st.position === 'fixed') return;
    var r = e.getBoundingClientRect();
    if (r.width > 0 && r.right > width + 1 && !scrolls(e)) over.push(e.tagName.toLowerCase() + (e.className ? '.' + e.className : ''));
  });
  // Raw JSON shown as text: a visible text node holding an object or array with quoted keys.
  var json = 0, walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  for (var n = walker.nextNode(); n; n = walker.nextNode()) {
    var t = n.nodeValue.trim();
    if (n.parentElement && n.parentElement.closest('script,style')) continue;
    if (t.length > 20 && /^[\[{]/.test(t) && /"[A-Za-z_][A-Za-z0-9_]*"\s*:/.test(t)) ++json;
  }
  var p = document.createElement('pre');
  p.textContent = 'HEXSIM-IMAGES ' + imgs.length + ' BROKEN ' + bad.length + ' ' + bad.join(' ') +
                  ' OVERFLOW ' + over.length + ' RAWJSON ' + json + ' ' + over.slice(0, 5).join(' ');
  document.body.appendChild(p);
});
</script>
)";

class Browser : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    chromium_ = new std::string(FindChromium());
    dir_ = new fs::path(fs::temp_directory_path() / ("hexsim_browser_" + std::to_string(::getpid())));
    fs::remove_all(*dir_);
    fs::create_directories(*dir_);
  }
  // Runs hexsim with `args` ({} = the scratch directory); small runs that still draw every figure kind.
  static void Hexsim(std::string args) {
    for (size_t at = args.find("{}"); at != std::string::npos; at = args.find("{}")) args.replace(at, 2, dir_->string());
    Shell(std::string(HEXSIM_BINARY) + " " + args);
  }
  static void TearDownTestSuite() {
    if (dir_) fs::remove_all(*dir_);
    delete dir_;
    delete chromium_;
    dir_ = nullptr;
    chromium_ = nullptr;
  }

  void SetUp() override {
    if (chromium_->empty()) {
      GTEST_SKIP() << "Chromium is not installed (apt-get install chromium): the reports were not opened in a browser";
    }
  }

  // What the check script found on a page opened headless in a 1280 px window.
  struct PageCheck {
    size_t img_tags = 0, images = 0, broken = 0, overflow = 0, raw_json = 0;
    std::string result;  // the script's line
  };
  static PageCheck Inspect(const fs::path& page) {
    PageCheck c;
    const fs::path check = page.parent_path() / ".browser_check.html";
    std::string html = Slurp(page);
    const size_t body_end = html.rfind("</body>");
    html.insert(body_end == std::string::npos ? html.size() : body_end, kImageCheck);
    std::ofstream(check) << html;
    for (size_t at = html.find("<img"); at != std::string::npos; at = html.find("<img", at + 1)) ++c.img_tags;
    std::string dom;
    const std::string base = Chromium(*chromium_, *dir_ / "profile");
    Shell(base + "--window-size=1280,1600 --virtual-time-budget=10000 --dump-dom 'file://" + check.string() + "'", &dom);
    fs::remove(check);
    const size_t at = dom.rfind("HEXSIM-IMAGES ");  // the result, after the script that writes it
    if (at == std::string::npos) return c;
    c.result = dom.substr(at, dom.find('<', at) - at);
    std::sscanf(c.result.c_str(), "HEXSIM-IMAGES %zu BROKEN %zu", &c.images, &c.broken);
    const size_t over_at = c.result.find(" OVERFLOW ");
    if (over_at != std::string::npos) std::sscanf(c.result.c_str() + over_at, " OVERFLOW %zu RAWJSON %zu", &c.overflow, &c.raw_json);
    return c;
  }

  // Opens `page` headless: every image loads with a natural size, no block is wider than the window
  // (outside a scrolling box), no text is raw JSON (unless `layout` is false), and the screenshot is
  // not blank.
  static void ExpectPageLoads(const fs::path& page, bool layout = true) {
    ASSERT_TRUE(fs::exists(page)) << page << " was not written";
    const PageCheck c = Inspect(page);
    ASSERT_FALSE(c.result.empty()) << "the check script did not run in " << page;
    EXPECT_EQ(c.images, c.img_tags) << page;
    EXPECT_GT(c.images, 0U) << page << ": no figures";
    EXPECT_EQ(c.broken, 0U) << page << ": " << c.result;
    if (layout) {
      EXPECT_EQ(c.overflow, 0U) << page << ": blocks wider than the window: " << c.result;
      EXPECT_EQ(c.raw_json, 0U) << page << ": raw JSON shown as text: " << c.result;
    }
    const std::string base = Chromium(*chromium_, *dir_ / "profile");

    const fs::path shot = *dir_ / (page.parent_path().filename().string() + "_screenshot.png");
    ASSERT_EQ(Shell(base + "--hide-scrollbars --window-size=1280,1600 --screenshot=" + shot.string() + " 'file://" +
                    page.string() + "'"),
              0);
    auto img = hexsim::render::ReadPng(shot.string());
    ASSERT_TRUE(img.ok()) << img.status().message();
    size_t ink = 0;
    std::set<uint32_t> colours;
    for (int y = 0; y < img->height; y += 2) {
      for (int x = 0; x < img->width; x += 2) {
        const auto p = img->At(x, y);
        if (p.r < 200 || p.g < 200 || p.b < 200) ++ink;
        colours.insert((p.r >> 3) << 10 | (p.g >> 3) << 5 | (p.b >> 3));
      }
    }
    const double share = static_cast<double>(ink) / (img->width / 2.0 * img->height / 2.0);
    EXPECT_GT(share, 0.01) << page << ": the screenshot is blank";
    EXPECT_GT(colours.size(), 20U) << page << ": the screenshot has hardly any colours";
  }

  static std::string* chromium_;
  static fs::path* dir_;
};

std::string* Browser::chromium_ = nullptr;
fs::path* Browser::dir_ = nullptr;

TEST_F(Browser, GivenACompareReportWhenOpenedHeadlessThenEveryImageLoadsAndThePageIsNotBlank) {
  Hexsim("compare climb_cruise_square --vehicle paper_hex --world changchun --seeds 2 --calibrations none,adaptive "
         "--duration 15 --jobs 2 --set sim.control_on_truth=true --out {}/compare");
  ExpectPageLoads(*dir_ / "compare" / "report.html");
}

TEST_F(Browser, GivenAGapReportWhenOpenedHeadlessThenEveryImageLoadsAndThePageIsNotBlank) {
  Hexsim("import " + std::string(HEXSIM_SOURCE_DIR) + "/data/real/ardupilot_copter_log171.bin --out {}/real/log.csv");
  Hexsim("gap diagnose --real {}/real/log.csv --sim quad_x --out {}/gap");
  ExpectPageLoads(*dir_ / "gap" / "gap.html");
}

// Without --sim: the vehicle identified first (gap.json's vehicle_source, the identification's table).
TEST_F(Browser, GivenAGapReportWithoutSimWhenOpenedHeadlessThenItFitsTheWindowWithoutRawJson) {
  Hexsim("gap diagnose --real " + std::string(HEXSIM_SOURCE_DIR) + "/data/real/ardupilot_copter_log171.bin --out {}/gap_nosim");
  ExpectPageLoads(*dir_ / "gap_nosim" / "gap.html");
}

TEST_F(Browser, GivenAnIdentifyReportWhenOpenedHeadlessThenItFitsTheWindowWithoutRawJson) {
  Hexsim("identify " + std::string(HEXSIM_SOURCE_DIR) + "/data/real/ardupilot_copter_log171.bin --out {}/identify/v.yaml");
  ExpectPageLoads(*dir_ / "identify" / "identify.html");
}

// The layout check itself: a page with a block twice the window's width and a JSON dump as text.
TEST_F(Browser, GivenAPageWithAWideBlockAndRawJsonWhenInspectedThenBothAreFound) {
  const fs::path page = *dir_ / "bad" / "bad.html";
  fs::create_directories(page.parent_path());
  std::ofstream(page) << "<!doctype html><html><body><h1>x</h1><div style=\"width:2600px\">wide</div>"
                         "<pre>{\"rows\": [1, 2], \"name\": \"uncorrected\"}</pre>"
                         "<div style=\"overflow-x:auto\"><table style=\"width:3000px\"><tr><td>ok</td></tr></table></div>"
                         "</body></html>";
  const PageCheck c = Inspect(page);
  ASSERT_FALSE(c.result.empty());
  EXPECT_EQ(c.overflow, 1U) << c.result;  // the wide div; the table scrolls inside its box
  EXPECT_EQ(c.raw_json, 1U) << c.result;
}

TEST_F(Browser, GivenABatchReportWhenOpenedHeadlessThenEveryImageLoadsAndThePageIsNotBlank) {
  std::ofstream(*dir_ / "batch.yaml") << "missions: [square]\nvehicles: [default_hex]\nduration_s: 5\nseeds: [1, 2]\n";
  Hexsim("batch {}/batch.yaml --jobs 2 --out {}/batch");
  Hexsim("batch-report {}/batch");
  ExpectPageLoads(*dir_ / "batch" / "report.html");
}

}  // namespace
