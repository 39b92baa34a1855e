#include "hexsim/logs/dataflash.h"

#include <cmath>
#include <map>

#include <gtest/gtest.h>

#include "hexsim/common/rng.h"
#include "hexsim/logs/dataflash_import.h"
#include "support/dataflash_writer.h"

namespace hexsim::logs {
namespace {

using testing::DataFlashWriter;
using testing::RealLogBytes;

std::map<std::string, size_t> CountTypes(const std::string& bytes, DataFlashDamage* damage = nullptr) {
  std::map<std::string, size_t> counts;
  DataFlashReader reader(bytes);
  DataFlashMessage m;
  while (reader.Next(&m)) ++counts[m.name()];
  if (damage) *damage = reader.damage();
  return counts;
}

// A small log in the 3.3 layout: ATT (centidegrees) and CURR (hundredths).
DataFlashWriter SmallLog(int n_att) {
  DataFlashWriter w;
  w.Fmt(130, "ATT", "IccccCCCC", "TimeMS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw");
  w.Fmt(131, "CURR", "IhhhHfh", "TimeMS,Throttle,Volt,Curr,Vcc,CurrTot,Volt2");
  for (int i = 0; i < n_att; ++i) {
    w.Msg(130, "IccccCCCC", {1000.0 + 100 * i, 0, 1234, 0, -567, 0, 35900, 0, 0});
    w.Msg(131, "IhhhHfh", {1000.0 + 100 * i, 0, 1650, 2744, 5000, 0, 0});
  }
  return w;
}

TEST(DataFlashReader, GivenTheRealLog_WhenRead_ThenMessageCountsMatchTheFileAndNothingIsSkipped) {
  DataFlashDamage damage;
  const auto counts = CountTypes(RealLogBytes(), &damage);
  // Counted independently with a throw-away Python decoder while writing this test.
  EXPECT_EQ(counts.at("FMT"), 72u);
  EXPECT_EQ(counts.at("ATT"), 2383u);
  EXPECT_EQ(counts.at("MAG"), 2384u);
  EXPECT_EQ(counts.at("MAG2"), 2384u);
  EXPECT_EQ(counts.at("MAG3"), 2383u);
  EXPECT_EQ(counts.at("CURR"), 2384u);
  EXPECT_EQ(counts.at("IMU"), 11916u);
  EXPECT_EQ(counts.at("RCOU"), 11916u);
  EXPECT_EQ(counts.at("GPS"), 1199u);
  EXPECT_EQ(counts.at("PARM"), 491u);
  EXPECT_EQ(counts.at("MODE"), 3u);
  EXPECT_EQ(damage.skipped_bytes, 0u);
  EXPECT_EQ(damage.bad_formats, 0u);
}

TEST(DataFlashReader, GivenFormatCharsWithoutUnits_WhenDecoded_ThenStandardAndTableScalesApply) {
  const DataFlashWriter w = SmallLog(1);
  DataFlashReader reader(w.bytes());
  DataFlashMessage m;
  std::map<std::string, std::map<std::string, double>> got;
  while (reader.Next(&m)) {
    if (m.name() == "ATT") got["ATT"] = {{"Roll", m.Get("Roll")}, {"Pitch", m.Get("Pitch")}, {"Yaw", m.Get("Yaw")}};
    if (m.name() == "CURR") got["CURR"] = {{"Volt", m.Get("Volt")}, {"Curr", m.Get("Curr")}, {"Vcc", m.Get("Vcc")}};
    if (m.type() != kDataFlashFmtType) {
      EXPECT_DOUBLE_EQ(m.BootTime_s(), 1.0);
    }
  }
  EXPECT_DOUBLE_EQ(got["ATT"]["Roll"], 12.34);  // 'c': centidegrees
  EXPECT_DOUBLE_EQ(got["ATT"]["Pitch"], -5.67);
  EXPECT_DOUBLE_EQ(got["ATT"]["Yaw"], 359.0);  // 'C'
  EXPECT_DOUBLE_EQ(got["CURR"]["Volt"], 16.5);  // 3.3 scale table: hundredths of a volt
  EXPECT_DOUBLE_EQ(got["CURR"]["Curr"], 27.44);
  EXPECT_DOUBLE_EQ(got["CURR"]["Vcc"], 5.0);  // mV
  EXPECT_TRUE(std::isnan(m.Get("NoSuchField")));
}

TEST(DataFlashReader, GivenFmtuAndMult_WhenDecoded_ThenTheLoggedMultiplierAndUnitApply) {
  DataFlashWriter w;
  w.Fmt(150, "UNIT", "QbZ", "TimeUS,Id,Label");
  w.Fmt(151, "MULT", "Qbd", "TimeUS,Id,Mult");
  w.Fmt(152, "FMTU", "QBNN", "TimeUS,FmtType,UnitIds,MultIds");
  w.Fmt(153, "MAG", "QBhhh", "TimeUS,I,MagX,MagY,MagZ");
  w.Msg(150, "QbZ", {0, 'G'}, {"Gauss"});
  w.Msg(151, "Qbd", {0, 'C', 1e-3});
  w.Msg(151, "Qbd", {0, 'F', 1e-6});
  w.Msg(152, "QBNN", {0, 153}, {"s#GGG", "F-CCC"});
  w.Msg(153, "QBhhh", {2500000, 0, 217, 4, -586});
  DataFlashReader reader(w.bytes());
  DataFlashMessage m;
  bool seen = false;
  while (reader.Next(&m)) {
    if (m.name() != "MAG") continue;
    seen = true;
    EXPECT_NEAR(m.Get("MagX"), 0.217, 1e-12);
    EXPECT_NEAR(m.Get("MagZ"), -0.586, 1e-12);
    EXPECT_EQ(m.format().units[2], "Gauss");
    EXPECT_DOUBLE_EQ(m.BootTime_s(), 2.5);
  }
  EXPECT_TRUE(seen);
  EXPECT_FALSE(reader.damage().any());
}

TEST(DataFlashReader, GivenGarbageBetweenMessages_WhenRead_ThenItResynchronisesAndCountsTheSkippedBytes) {
  DataFlashWriter w = SmallLog(3);
  const std::string& clean = w.bytes();
  // Garbage with a fake header (unknown type 0xEE) inserted after the first ATT message.
  const size_t insert_at = 2 * 89 + 23;  // two FMT, one ATT
  std::string damaged = clean.substr(0, insert_at) + std::string("\x01\x02\xA3\x95\xEE\x10garbage!", 14) +
                        clean.substr(insert_at);
  DataFlashDamage damage;
  const auto counts = CountTypes(damaged, &damage);
  // The ATT just before the garbage is not followed by a header, so it cannot be told from a
  // false header inside damaged bytes: it is dropped too (strict by design).
  EXPECT_EQ(counts.at("ATT"), 2u);
  EXPECT_EQ(counts.at("CURR"), 3u);
  EXPECT_EQ(damage.skipped_bytes, 14u + 23u);
  EXPECT_EQ(damage.misaligned_messages, 1u);
  EXPECT_EQ(damage.unknown_type_messages, 1u);
  EXPECT_GE(damage.bad_header_runs, 1u);
}

TEST(DataFlashReader, GivenAFmtThatLiesAboutItsLength_WhenRead_ThenTheFormatIsRejectedAndOtherTypesSurvive) {
  DataFlashWriter w;
  w.Fmt(130, "ATT", "IccccCCCC", "TimeMS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw", 30);  // real: 23
  w.Fmt(131, "CURR", "IhhhHfh", "TimeMS,Throttle,Volt,Curr,Vcc,CurrTot,Volt2");
  for (int i = 0; i < 5; ++i) {
    w.Msg(130, "IccccCCCC", {1000.0 + i, 0, 0, 0, 0, 0, 0, 0, 0});
    w.Msg(131, "IhhhHfh", {1000.0 + i, 0, 1650, 100, 5000, 0, 0});
  }
  DataFlashDamage damage;
  const auto counts = CountTypes(w.bytes(), &damage);
  EXPECT_EQ(counts.count("ATT"), 0u);
  EXPECT_EQ(counts.at("CURR"), 5u);
  EXPECT_EQ(damage.bad_formats, 1u);
  EXPECT_EQ(damage.unknown_type_messages, 5u);
  EXPECT_EQ(damage.skipped_bytes, 5u * 23u);
}

TEST(DataFlashReader, GivenATruncatedFile_WhenRead_ThenTheTailIsCountedAndEveryWholeMessageIsKept) {
  DataFlashWriter w = SmallLog(4);
  const std::string& clean = w.bytes();
  const std::string cut = clean.substr(0, clean.size() - 7);  // last CURR (21 bytes) loses 7
  DataFlashDamage damage;
  const auto counts = CountTypes(cut, &damage);
  EXPECT_EQ(counts.at("ATT"), 4u);
  EXPECT_EQ(counts.at("CURR"), 3u);
  EXPECT_EQ(damage.truncated_tail_bytes, 14u);
  EXPECT_EQ(damage.skipped_bytes, 14u);
}

// Damage tests on the real log: the importer returns a FlightLog or a clean BadInput, never crashes
// (CI runs these under ASan/UBSan too) and counts what it skipped.
void ExpectImportOkOrBadInput(const std::string& bytes, const std::string& what) {
  auto r = ImportDataFlash(bytes, what);
  if (r.ok()) {
    ASSERT_GT(r->log.rows(), 0u) << what;
    const auto& t = r->log.Column("t_s");
    for (size_t i = 1; i < t.size(); ++i) ASSERT_GE(t[i], t[i - 1]) << what;
    // What was written parses back as a FlightLog.
    ASSERT_TRUE(ParseFlightLogCsv(FlightLogToCsv(r->log), what).ok()) << what;
    (void)r->log.meta.dump();  // valid UTF-8 JSON
  } else {
    ASSERT_EQ(r.status().code(), StatusCode::kBadInput) << what << ": " << r.status().message();
    ASSERT_FALSE(r.status().message().empty());
  }
}

TEST(DataFlashImportDamage, GivenTheRealLogTruncatedAtManyOffsets_WhenImported_ThenOkOrBadInput) {
  const std::string& full = RealLogBytes();
  RngStream rng(17, "truncate");
  std::vector<size_t> cuts = {0, 1, 2, 3, 88, 89, 90, 1000, 65536, full.size() - 1};
  for (int i = 0; i < 12; ++i) cuts.push_back(static_cast<size_t>(rng.Uniform() * static_cast<double>(full.size())));
  for (size_t cut : cuts) {
    const std::string part = full.substr(0, cut);
    ExpectImportOkOrBadInput(part, "cut at " + std::to_string(cut));
    if (cut > 200000) {
      auto r = ImportDataFlash(part, "x");
      ASSERT_TRUE(r.ok());
      // A cut mid-message leaves at most one message's bytes unread (the longest here is 89).
      EXPECT_LE(r->damage.skipped_bytes, 89u);
    }
  }
  EXPECT_EQ(ImportDataFlash("", "empty.bin").status().code(), StatusCode::kBadInput);
}

TEST(DataFlashImportDamage, GivenRandomlyFlippedBytes_WhenImported_ThenMostRowsSurviveAndDamageIsCounted) {
  const std::string& full = RealLogBytes();
  auto clean = ImportDataFlash(full, "clean");
  ASSERT_TRUE(clean.ok());
  for (uint64_t seed = 1; seed <= 4; ++seed) {
    RngStream rng(seed, "flip");
    std::string bytes = full;
    const int flips = 300;
    for (int i = 0; i < flips; ++i) {
      const size_t at = static_cast<size_t>(rng.Uniform() * static_cast<double>(bytes.size()));
      bytes[at] = static_cast<char>(bytes[at] ^ static_cast<char>(1 + rng.NextU64() % 255));
    }
    ExpectImportOkOrBadInput(bytes, "flips seed " + std::to_string(seed));
    auto r = ImportDataFlash(bytes, "flipped");
    ASSERT_TRUE(r.ok());
    EXPECT_GT(r->damage.skipped_bytes, 0u);
    // 300 flips in ~130 000 messages: each costs at most a few messages (or, in an FMT, one type).
    EXPECT_GT(r->log.rows(), clean->log.rows() * 9 / 10);
  }
}

TEST(DataFlashImportDamage, GivenGarbageInsertedAndAFmtLengthCorrupted_WhenImported_ThenRowsAreKept) {
  const std::string& full = RealLogBytes();
  RngStream rng(5, "garbage");
  std::string bytes;
  size_t pos = 0, inserted = 0;
  while (pos < full.size()) {
    const size_t chunk = 20000 + static_cast<size_t>(rng.Uniform() * 40000.0);
    bytes += full.substr(pos, chunk);
    pos += chunk;
    std::string junk(1 + rng.NextU64() % 300, '\0');
    for (auto& ch : junk) ch = static_cast<char>(rng.NextU64());
    bytes += junk;
    inserted += junk.size();
  }
  auto r = ImportDataFlash(bytes, "garbage");
  ASSERT_TRUE(r.ok()) << r.status().message();
  EXPECT_GE(r->damage.skipped_bytes, inserted);
  EXPECT_GT(r->log.rows(), 2300u);

  // Corrupt the length byte of the MAG2 FMT: MAG2 disappears, everything else stays.
  std::string lying = full;
  const std::string needle = std::string("MAG2");
  size_t fmt_at = lying.find(needle);
  ASSERT_NE(fmt_at, std::string::npos);
  lying[fmt_at - 1] = static_cast<char>(lying[fmt_at - 1] + 5);  // Length precedes Name
  auto l = ImportDataFlash(lying, "lying");
  ASSERT_TRUE(l.ok());
  EXPECT_EQ(l->damage.bad_formats, 1u);
  EXPECT_FALSE(l->log.Has("mag2_x_uT"));
  EXPECT_TRUE(l->log.Has("mag_x_uT"));
  EXPECT_EQ(l->log.rows(), 2383u);
}

TEST(DataFlashImportDamage, GivenBytesThatAreNotDataFlash_WhenImported_ThenBadInputNamesTheFile) {
  auto r = ImportDataFlash(std::string(5000, 'x'), "notes.txt");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kBadInput);
  EXPECT_EQ(r.status().message().rfind("notes.txt: ", 0), 0u) << r.status().message();
  // FMT and a few messages but no attitude: nothing to make rows from.
  DataFlashWriter w;
  w.Fmt(131, "CURR", "IhhhHfh", "TimeMS,Throttle,Volt,Curr,Vcc,CurrTot,Volt2");
  w.Msg(131, "IhhhHfh", {1000, 0, 1650, 100, 5000, 0, 0});
  auto n = ImportDataFlash(w.bytes(), "noatt.bin");
  ASSERT_FALSE(n.ok());
  EXPECT_NE(n.status().message().find("ATT"), std::string::npos);
}

}  // namespace
}  // namespace hexsim::logs
