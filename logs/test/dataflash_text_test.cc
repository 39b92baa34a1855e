// The text DataFlash log (.log, Mission Planner's and MAVProxy's dump of a .bin): re-encoded as the
// binary it came from, so it imports as its .bin does.
#include <cmath>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "hexsim/logs/dataflash.h"
#include "hexsim/logs/dataflash_import.h"
#include "hexsim/logs/dataflash_text.h"
#include "support/dataflash_writer.h"

namespace hexsim::logs {
namespace {

// A .bin written as a ground station writes its text form: FMT lines, then each message's fields by
// their format char's scale (c/C/e/E /100, L 1e-7 degrees; no FMTU multiplier), text as text.
std::string AsText(const std::string& bin) {
  std::string out;
  DataFlashReader reader(bin);
  DataFlashMessage m;
  while (reader.Next(&m)) {
    const DataFlashFormat& f = m.format();
    if (m.type() == kDataFlashFmtType) {
      const DataFlashFormat* def = reader.FormatByType(static_cast<uint8_t>(m.GetRawInt("Type")));
      if (def == nullptr) continue;
      std::string cols;
      for (size_t k = 0; k < def->labels.size(); ++k) cols += (k ? "," : "") + def->labels[k];
      out += fmt::format("FMT, {}, {}, {}, {}, {}\n", def->type, def->length, def->name, def->format, cols);
      continue;
    }
    out += f.name;
    for (size_t k = 0; k < f.format.size(); ++k) {
      const char c = f.format[k];
      if (c == 'n' || c == 'N' || c == 'Z') {
        out += ", " + m.GetString(f.labels[k]);
      } else if (c == 'f' || c == 'd' || c == 'g') {
        const double mult = f.multipliers.size() > k && f.multipliers[k] != 0 ? f.multipliers[k] : 1.0;
        out += fmt::format(", {:.17g}", m.GetIndex(k) / mult);
      } else if (c == 'a') {
        out += ", []";
      } else {
        out += fmt::format(", {:.12g}", static_cast<double>(m.GetRawInt(f.labels[k])) * DataFlashFormatCharScale(c));
      }
    }
    out += "\n";
  }
  return out;
}

bool SameValue(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

TEST(DataFlashText, GivenTheRealLogWrittenAsText_WhenImported_ThenItsFlightLogEqualsTheBinarysImport) {
  const std::string& bin = testing::RealLogBytes();
  const std::string text = AsText(bin);
  ASSERT_TRUE(IsDataFlashText(text));
  ASSERT_FALSE(IsDataFlashText(bin));
  DataFlashTextStats st;
  auto back = DataFlashTextToBinary(text, "log171.log", &st);
  ASSERT_TRUE(back.ok()) << back.status().message();
  EXPECT_EQ(st.skipped(), 0u);
  auto a = ImportDataFlash(bin, "log171.bin");
  auto b = ImportDataFlash(*back, "log171.log");
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a->log.rows(), b->log.rows());
  ASSERT_EQ(a->log.columns(), b->log.columns());
  for (const std::string& name : a->log.columns()) {
    const auto& x = a->log.Column(name);
    const auto& y = b->log.Column(name);
    size_t differ = 0;
    for (size_t i = 0; i < x.size(); ++i) differ += SameValue(x[i], y[i]) ? 0 : 1;
    EXPECT_EQ(differ, 0u) << name;
  }
}

// As Mission Planner writes it: a message text holding commas, a mode written as its name beside its
// number, a line whose type was never defined, a truncated last line.
TEST(DataFlashText, GivenAGroundStationsTextLog_WhenReencoded_ThenEachLineIsTheBinaryMessageOrCountedAsSkipped) {
  const std::string text =
      "FMT, 128, 89, FMT, BBnNZ, Type,Length,Name,Format,Columns\r\n"
      "FMT, 133, 75, MSG, QZ, TimeUS,Message\r\n"
      "FMT, 173, 14, MODE, QMBB, TimeUS,Mode,ModeNum,Rsn\r\n"
      "FMT, 168, 23, CURR, Qfff, TimeUS,Volt,Curr,CurrTot\r\n"
      "FMT, 167, 27, ATT, QccccCCCC, TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw\r\n"
      "MSG, 148952786, Frame: QUAD, X\r\n"
      "MODE, 148882206, AltHold, 2, 1\r\n"
      "CURR, 148980280, 11.69827, 14.5, 12\r\n"
      "ATT, 148982850, 0.00, -3.06, 0.00, 1.12, 328.72, 328.22, 0.00, 0.06\r\n"
      "NKF1, 148982900, 1, 2\r\n"
      "ATT, 148982950, 0.00, -3.";
  DataFlashTextStats st;
  auto bin = DataFlashTextToBinary(text, "mp.log", &st);
  ASSERT_TRUE(bin.ok()) << bin.status().message();
  EXPECT_EQ(st.unknown_type, 1u);  // NKF1
  EXPECT_EQ(st.unreadable, 1u);    // the truncated ATT
  EXPECT_EQ(st.bad_formats, 0u);
  DataFlashReader reader(*bin);
  DataFlashMessage m;
  int msgs = 0;
  while (reader.Next(&m)) {
    if (m.name() == "MSG") {
      EXPECT_EQ(m.GetString("Message"), "Frame: QUAD, X");
    }
    if (m.name() == "MODE") {
      EXPECT_EQ(m.GetRawInt("Mode"), 2);
    }
    if (m.name() == "CURR") {
      EXPECT_FLOAT_EQ(static_cast<float>(m.Get("Curr")), 14.5f);
      EXPECT_FLOAT_EQ(static_cast<float>(m.Get("Volt")), 11.69827f);
    }
    if (m.name() == "ATT") {
      EXPECT_EQ(m.GetRawInt("Pitch"), 112);
      EXPECT_EQ(m.GetRawInt("Yaw"), 32822);
      EXPECT_DOUBLE_EQ(m.BootTime_s(), 148.98285);
    }
    msgs += m.type() == kDataFlashFmtType ? 0 : 1;
  }
  EXPECT_EQ(msgs, 4);
  EXPECT_EQ(reader.damage().skipped_bytes, 0u);
}

// Values the binary field could not hold are unreadable lines, not wrapped or converted: 2^64 in a
// uint64 (max() as a double rounds up to it), 2^63 in an int64, 1e39 in a float.
TEST(DataFlashText, GivenValuesBeyondTheirFieldsRange_WhenReencoded_ThenTheLinesAreUnreadable) {
  const std::string text =
      "FMT, 150, 11, TQ, Q, V\nFMT, 151, 11, TS, q, V\nFMT, 152, 7, TF, f, V\n"
      "TQ, 18446744073709551616\nTS, 9223372036854775808\nTF, 1e39\n"
      "TQ, 18446744073709549568\nTS, -9223372036854775808\nTF, 3e38\n";
  DataFlashTextStats st;
  auto bin = DataFlashTextToBinary(text, "range.log", &st);
  ASSERT_TRUE(bin.ok()) << bin.status().message();
  EXPECT_EQ(st.unreadable, 3u);
  EXPECT_EQ(st.messages, 6u);  // 3 FMT + 3 in range
}

TEST(DataFlashText, GivenTextWithoutAnFmtLine_WhenReencoded_ThenItIsBadInputNamingTheFile) {
  EXPECT_FALSE(IsDataFlashText("time,mag_x\n0,1\n"));
  auto bin = DataFlashTextToBinary("FMT, x, 89, FMT\n", "broken.log");
  ASSERT_FALSE(bin.ok());
  EXPECT_NE(bin.status().message().find("broken.log"), std::string::npos);
}

}  // namespace
}  // namespace hexsim::logs
