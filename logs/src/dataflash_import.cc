#include "hexsim/logs/dataflash_import.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <initializer_list>
#include <map>
#include <optional>

#include <fmt/format.h>

#include "hexsim/common/atomic_file.h"
#include "hexsim/common/rotation.h"
#include "dataflash_facts.h"
#include "dataflash_streams.h"
#include "hexsim/logs/current_check.h"
#include "hexsim/logs/dataflash_plausibility.h"

namespace hexsim::logs {

namespace {

using internal::DamageJson;
using internal::FirmwareOf;
using internal::FrameNameOf;
using internal::GpsBootTime_s;
using internal::InstanceOf;
using internal::IsoUtc;
using internal::MagToMicroTesla;
using internal::MotorsForFrameClass;
using internal::MotorsForFrameName;
using internal::ParamsOfInterest;
using internal::Printable;
using internal::StartsWith;
using internal::UnixFromGps;
using internal::VehicleTypeOf;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kThrottleScale = 1000.0;  // control_u: 0..1000
constexpr int kGps3dFix = 3;
constexpr size_t kMaxOutputs = 14;  // RCOU C1..C14
// WGS-84.
constexpr double kWgs84A_m = 6378137.0;
constexpr double kWgs84E2 = 6.69437999014e-3;

// A sample-and-hold channel: its samples in time order, each with `columns.size()` values.
struct Channel {
  std::string t_column;
  std::vector<std::string> columns;
  std::vector<double> t;
  std::vector<double> values;
  size_t dropped = 0;  // samples with damaged time (see Finalize)

  Channel(std::string t_col, std::vector<std::string> cols) : t_column(std::move(t_col)), columns(std::move(cols)) {}
  size_t size() const { return t.size(); }
  double At(size_t sample, size_t col) const { return values[sample * columns.size() + col]; }
  template <class Values>
  void AddValues(double time_s, const Values& v) {
    if (!std::isfinite(time_s)) {
      ++dropped;
      return;
    }
    t.push_back(time_s);
    auto it = v.begin();
    for (size_t i = 0; i < columns.size(); ++i) values.push_back(it != v.end() ? *it++ : kNaN);
  }
  void Add(double time_s, std::initializer_list<double> v) { AddValues(time_s, v); }
  void Add(double time_s, const std::vector<double>& v) { AddValues(time_s, v); }
  // Drops samples whose time is damaged, keeping time non-decreasing: a sample later than both
  // of its next two (an upward spike), or earlier than the last kept one.
  void Finalize() {
    const size_t n = t.size(), w = columns.size();
    std::vector<double> nt, nv;
    double last = -std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < n; ++i) {
      const bool spike = i + 1 < n && t[i] > t[i + 1] && (i + 2 >= n || t[i] > t[i + 2]);
      if (spike || t[i] < last) {
        ++dropped;
        continue;
      }
      last = t[i];
      nt.push_back(t[i]);
      nv.insert(nv.end(), values.begin() + static_cast<std::ptrdiff_t>(i * w),
                values.begin() + static_cast<std::ptrdiff_t>((i + 1) * w));
    }
    t.swap(nt);
    values.swap(nv);
  }
};

double Clamp01(double x) { return std::isfinite(x) ? std::clamp(x, 0.0, 1.0) : kNaN; }

double Median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Everything the first pass collects.
struct Collected {
  std::map<std::string, double> params;
  std::vector<std::string> texts;
  Channel att{"", {"roll_deg", "pitch_deg", "yaw_deg"}};
  Channel imu{"imu_t_s", {"gyro_x_radps", "gyro_y_radps", "gyro_z_radps", "accel_x_mps2", "accel_y_mps2",
                          "accel_z_mps2", "imu_temp_C"}};
  std::vector<Channel> mags;  // mag, mag2, mag3
  Channel batt{"batt_t_s", {"current_A", "voltage_V"}};
  Channel rcou{"rcou_t_s", {}};  // raw PWM, converted later
  std::vector<size_t> rcou_fields;  // RCOU field index of each output channel, in channel order
  Channel ctun{"ctun_t_s", {"control_u"}};
  Channel gps{"gps_t_s", {"lat_deg", "lon_deg", "alt_m", "gps_vel_N_mps", "gps_vel_E_mps", "gps_vel_D_mps"}};
  Channel baro{"baro_t_s", {"baro_alt_m"}};
  std::map<std::string, Channel> ekf;  // by message name
  Channel mode{"", {"mode"}};
  Channel waypoint{"", {"waypoint_index"}};
  // EV ARMED (10) / DISARMED (11) as 1/0. 3.3's EV has no time field: it takes the time of the
  // latest message that had one (last_time_s); an event before any timed message (a log that starts
  // at arming writes EV ARMED first) takes the first time that follows (pending_events).
  Channel armed{"", {"armed"}};
  double last_time_s = kNaN;
  std::vector<double> pending_events;  // armed values waiting for a time
  std::optional<nlohmann::json> first_fix;
  std::optional<nlohmann::json> home;
  int gps_week = -1;
  double gps_tow_s = kNaN;
  std::vector<double> mag_mot_nonzero = {0, 0, 0};  // samples with a non-zero motor offset, per compass
  size_t messages = 0;
};

Channel MakeMagChannel(const std::string& prefix) {
  return Channel(prefix + "_t_s", {prefix + "_x_uT", prefix + "_y_uT", prefix + "_z_uT", prefix + "_mot_x_uT",
                                   prefix + "_mot_y_uT", prefix + "_mot_z_uT"});
}

// Why a compass never measured a field ("" when it did): every sample the same vector. ArduPilot logs
// (0, 0, 0) for a compass that is absent or disabled; no working magnetometer reads one vector through
// a log (the Earth's field alone is 22-67 uT and turns with the vehicle, noise moves the last digits).
std::string NeverMeasured(const Channel& m) {
  if (m.size() < 2) return "";
  for (size_t i = 1; i < m.size(); ++i) {
    for (size_t a = 0; a < 3; ++a) {
      if (m.At(i, a) != m.At(0, a)) return "";
    }
  }
  return fmt::format("every one of its {} samples is ({:.4g}, {:.4g}, {:.4g}): the compass is absent, disabled or "
                     "stuck, not a field",
                     m.size(), m.At(0, 0), m.At(0, 1), m.At(0, 2));
}

void CollectMessage(const DataFlashMessage& m, Collected* c) {
  const std::string& name = m.name();
  ++c->messages;
  constexpr int64_t kEvArmed = 10, kEvDisarmed = 11;  // ArduPilot LogEvent ids
  if (name != "GPS" && std::isfinite(m.BootTime_s())) {
    c->last_time_s = m.BootTime_s();
    for (const double a : c->pending_events) c->armed.Add(c->last_time_s, {a});
    c->pending_events.clear();
  }
  if (name == "EV" && m.Has("Id")) {
    const int64_t id = m.GetRawInt("Id");
    const double t = std::isfinite(m.BootTime_s()) ? m.BootTime_s() : c->last_time_s;
    if (id == kEvArmed || id == kEvDisarmed) {
      if (std::isfinite(t)) {
        c->armed.Add(t, {id == kEvArmed ? 1.0 : 0.0});
      } else {
        c->pending_events.push_back(id == kEvArmed ? 1.0 : 0.0);
      }
    }
    return;
  }
  if (name == "PARM") {
    const std::string pname = Printable(m.GetString("Name"));
    const double v = m.Get("Value");
    if (!pname.empty() && std::isfinite(v)) c->params[pname] = v;
  } else if (name == "MSG") {
    if (c->texts.size() < 64) c->texts.push_back(Printable(m.GetString("Message")));
  } else if (name == "ATT") {
    c->att.Add(m.BootTime_s(), {m.Get("Roll"), m.Get("Pitch"), m.Get("Yaw")});
  } else if (StartsWith(name, "IMU") && (name.size() == 3 || name.size() == 4)) {
    if (InstanceOf(m, "IMU") != 0) return;
    c->imu.Add(m.BootTime_s(), {m.Get("GyrX"), m.Get("GyrY"), m.Get("GyrZ"), m.Get("AccX"), m.Get("AccY"),
                                m.Get("AccZ"), m.Has("Temp") ? m.Get("Temp") : m.Get("T")});
  } else if (StartsWith(name, "MAG") && (name.size() == 3 || name.size() == 4)) {
    const int inst = InstanceOf(m, "MAG");
    if (inst < 0 || inst > 2) return;
    const size_t k = static_cast<size_t>(inst);
    const double mx = MagToMicroTesla(m, m.Has("MOfsX") ? "MOfsX" : "MOX");
    const double my = MagToMicroTesla(m, m.Has("MOfsY") ? "MOfsY" : "MOY");
    const double mz = MagToMicroTesla(m, m.Has("MOfsZ") ? "MOfsZ" : "MOZ");
    if ((std::isfinite(mx) && mx != 0) || (std::isfinite(my) && my != 0) || (std::isfinite(mz) && mz != 0)) {
      ++c->mag_mot_nonzero[k];
    }
    c->mags[k].Add(m.BootTime_s(), {MagToMicroTesla(m, "MagX"), MagToMicroTesla(m, "MagY"),
                                    MagToMicroTesla(m, "MagZ"), mx, my, mz});
  } else if (name == "CURR" || name == "BAT" || name == "BATT") {
    if (name != "CURR" && InstanceOf(m, name) > 0) return;
    c->batt.Add(m.BootTime_s(), {m.Get("Curr"), m.Get("Volt")});
  } else if (name == "RCOU") {
    // Output channels: C1..C14 (3.4+), Ch1..Ch14 (3.3) or Chan1..Chan8 (3.2), looked up once.
    if (c->rcou_fields.empty()) {
      for (size_t i = 1; i <= kMaxOutputs; ++i) {
        const int f = internal::RcouField(m.format(), i);
        if (f < 0) continue;
        c->rcou_fields.push_back(static_cast<size_t>(f));
        c->rcou.columns.push_back(fmt::format("pwm_{}", i));
      }
      if (c->rcou_fields.empty()) return;
    }
    std::vector<double> pwm(c->rcou_fields.size());
    for (size_t i = 0; i < pwm.size(); ++i) {
      pwm[i] = m.GetIndex(c->rcou_fields[i]);
      if (!IsPlausiblePwm_us(pwm[i])) pwm[i] = kNaN;  // an unused channel's garbage: absent
    }
    c->rcou.AddValues(m.BootTime_s(), pwm);
  } else if (name == "CTUN") {
    double u = kNaN;
    if (m.Has("ThrOut")) {
      u = m.Get("ThrOut");  // 3.x: 0..1000
    } else if (m.Has("ThO")) {
      u = m.Get("ThO") * kThrottleScale;  // 3.4+: 0..1
    }
    c->ctun.Add(m.BootTime_s(), {u});
  } else if (name == "GPS") {
    if (m.Has("I") && m.GetRawInt("I") != 0) return;
    if (m.GetRawInt("Status") < kGps3dFix) return;
    const double lat = m.Get("Lat"), lon = m.Get("Lng"), alt = m.Get("Alt");
    if (!std::isfinite(lat) || !std::isfinite(lon) || std::fabs(lat) > 90 || std::fabs(lon) > 180 ||
        (lat == 0 && lon == 0)) {
      return;
    }
    const double spd = m.Get("Spd"), crs = m.Get("GCrs") * kDegToRad;
    const double t = GpsBootTime_s(m);
    c->gps.Add(t, {lat, lon, alt, spd * std::cos(crs), spd * std::sin(crs), m.Get("VZ")});
    if (!c->first_fix && std::isfinite(t)) {
      c->first_fix = nlohmann::json{{"lat_deg", lat}, {"lon_deg", lon}, {"alt_m", alt}, {"t_s", t}};
      const bool old = m.Has("Week");
      c->gps_week = static_cast<int>(m.GetRawInt(old ? "Week" : "GWk"));
      c->gps_tow_s = static_cast<double>(m.GetRawInt(old ? "TimeMS" : "GMS")) * 1e-3;
    }
  } else if (name == "BARO") {
    if (m.Has("I") && m.GetRawInt("I") != 0) return;
    c->baro.Add(m.BootTime_s(), {m.Get("Alt")});
  } else if (name == "EKF1" || name == "NKF1" || name == "XKF1") {
    if (m.Has("C") && m.GetRawInt("C") != 0) return;
    auto it = c->ekf.find(name);
    if (it == c->ekf.end()) {
      it = c->ekf.emplace(name, Channel("ekf_t_s", {"pos_N_m", "pos_E_m", "pos_D_m", "vel_N_mps", "vel_E_mps",
                                                    "vel_D_mps"})).first;
    }
    it->second.Add(m.BootTime_s(), {m.Get("PN"), m.Get("PE"), m.Get("PD"), m.Get("VN"), m.Get("VE"), m.Get("VD")});
  } else if (name == "MODE") {
    c->mode.Add(m.BootTime_s(), {m.Has("ModeNum") ? m.Get("ModeNum") : m.Get("Mode")});
  } else if (name == "CMD") {
    const double seq = m.Get("CNum");
    c->waypoint.Add(m.BootTime_s(), {seq});
    if (seq == 0 && !c->home) {
      const double lat = m.Get("Lat"), lon = m.Get("Lng"), alt = m.Get("Alt");
      if (std::isfinite(lat) && std::isfinite(lon) && std::isfinite(alt)) {
        c->home = nlohmann::json{{"lat_deg", lat}, {"lon_deg", lon}, {"alt_m", alt}, {"source", "CMD 0 (home)"}};
      }
    }
  }
}

std::optional<double> Param(const Collected& c, const std::string& name) {
  auto it = c.params.find(name);
  if (it == c.params.end()) return std::nullopt;
  return it->second;
}

// Whether compass k's per-sample motor offsets are real: ArduPilot fills them only when motor
// compensation is on (COMPASS_MOTCT != 0); a log without that parameter needs them non-zero in most
// samples. A few non-zero samples in a log without compensation are damage, and make no columns.
bool HasMotorOffsets(const Collected& c, size_t k) {
  if (auto motct = Param(c, "COMPASS_MOTCT")) return *motct != 0 && c.mag_mot_nonzero[k] > 0;
  return 2.0 * c.mag_mot_nonzero[k] > static_cast<double>(c.mags[k].size());
}

// Adds a channel's held samples to the log (columns only when the channel has samples).
void AddHeld(const Channel& ch, const std::vector<size_t>& cols_to_use, FlightLog* log) {
  if (ch.size() == 0) return;
  std::vector<size_t> out_cols;
  out_cols.reserve(cols_to_use.size());
  for (size_t c : cols_to_use) out_cols.push_back(log->AddColumn(ch.columns[c]));
  const bool has_t = !ch.t_column.empty();
  const size_t t_col = has_t ? log->AddColumn(ch.t_column) : 0;
  const auto& t_rows = log->Column("t_s");
  size_t next = 0;
  for (size_t r = 0; r < log->rows(); ++r) {
    while (next < ch.size() && ch.t[next] <= t_rows[r]) ++next;
    if (next == 0) continue;
    const size_t s = next - 1;
    for (size_t k = 0; k < cols_to_use.size(); ++k) {
      const double v = ch.At(s, cols_to_use[k]);
      log->MutableColumn(out_cols[k])[r] = std::isfinite(v) ? v : kMissing;
    }
    if (has_t) log->MutableColumn(t_col)[r] = ch.t[s];
  }
}

std::vector<size_t> AllColumns(const Channel& ch) {
  std::vector<size_t> v(ch.columns.size());
  for (size_t i = 0; i < v.size(); ++i) v[i] = i;
  return v;
}

// The columns that hold at least one number: a battery monitor without a current sensor logs its
// current as "not available" (NaN) in every record, and a log without a current has no current_A.
std::vector<size_t> MeasuredColumns(const Channel& ch) {
  std::vector<size_t> v;
  for (size_t c = 0; c < ch.columns.size(); ++c) {
    for (size_t s = 0; s < ch.size(); ++s) {
      if (std::isfinite(ch.At(s, c))) {
        v.push_back(c);
        break;
      }
    }
  }
  return v;
}

// The meta's description of compass instance k (0-based) from its parameters.
nlohmann::json CompassMeta(const Collected& c, size_t k, const std::string& prefix) {
  const std::string n = k == 0 ? "" : std::to_string(k + 1);
  auto p = [&](const std::string& name) -> nlohmann::json {
    auto v = Param(c, name);
    return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
  };
  auto vec = [&](const std::string& base) -> nlohmann::json {
    auto x = Param(c, base + "_X"), y = Param(c, base + "_Y"), z = Param(c, base + "_Z");
    if (!x || !y || !z) return nullptr;
    return nlohmann::json::array({*x, *y, *z});
  };
  nlohmann::json j;
  j["column"] = prefix;
  j["instance"] = k + 1;
  const auto ext = Param(c, k == 0 ? "COMPASS_EXTERNAL" : "COMPASS_EXTERN" + n);
  j["external"] = ext ? nlohmann::json(*ext != 0) : nlohmann::json(nullptr);
  j["orientation"] = p("COMPASS_ORIENT" + n);
  const auto use = Param(c, "COMPASS_USE" + n);
  j["use"] = use ? nlohmann::json(*use != 0) : nlohmann::json(nullptr);
  j["offsets_mG"] = vec("COMPASS_OFS" + n);
  j["diagonals"] = vec("COMPASS_DIA" + n);
  j["offdiagonals"] = vec("COMPASS_ODI" + n);
  j["scale"] = p("COMPASS_SCALE" + n);
  j["motor_compensation_mG"] = vec("COMPASS_MOT" + n);
  j["dev_id"] = p("COMPASS_DEV_ID" + n);
  const auto ofs = Param(c, "COMPASS_OFS" + n + "_X");
  const bool calibrated = ofs && (*ofs != 0 || Param(c, "COMPASS_OFS" + n + "_Y").value_or(0) != 0 ||
                                  Param(c, "COMPASS_OFS" + n + "_Z").value_or(0) != 0);
  j["offsets_set"] = calibrated;
  j["motor_offset_columns"] = HasMotorOffsets(c, k)
                                  ? nlohmann::json::array({prefix + "_mot_x_uT", prefix + "_mot_y_uT", prefix + "_mot_z_uT"})
                                  : nlohmann::json("all zero: not written");
  return j;
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return kNaN;
  const auto k = v.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), k, v.end());
  return *k;
}

// A motor output's swing over a flight is hundreds of µs (idle to climb); a channel moving less than
// this is an unused output or a fixed servo.
constexpr double kMinMotorSwing_us = 50.0;
// Motors share the collective: in flight they differ from motor 1 by the attitude corrections, a small
// part of the collective's swing (median |pwm_i − pwm_1| well under a quarter of it); a servo or an RC
// pass-through does not follow it.
constexpr double kMaxMotorSpread = 0.25;

// Motors of a log whose frame is not named: the leading output channels that move with channel 1,
// rounded down to a multirotor's motor count (3, 4, 6, 8, 10, 12); 0 when channel 1 does not move.
int MotorsFromOutputs(const Channel& rcou, std::string* source) {
  const size_t channels = rcou.columns.size();
  auto swing = [&](size_t ch) {
    std::vector<double> v;
    for (size_t s = 0; s < rcou.size(); ++s) {
      if (std::isfinite(rcou.At(s, ch))) v.push_back(rcou.At(s, ch));
    }
    return Quantile(v, 0.95) - Quantile(v, 0.05);
  };
  if (channels == 0 || !(swing(0) >= kMinMotorSwing_us)) return 0;
  const double swing1_us = swing(0);
  size_t following = 1;
  for (size_t ch = 1; ch < channels; ++ch) {
    std::vector<double> d;
    for (size_t s = 0; s < rcou.size(); ++s) {
      const double a = rcou.At(s, 0), b = rcou.At(s, ch);
      if (std::isfinite(a) && std::isfinite(b)) d.push_back(std::fabs(b - a));
    }
    if (d.empty() || !(swing(ch) >= kMinMotorSwing_us) || !(Median(d) <= kMaxMotorSpread * swing1_us)) break;
    ++following;
  }
  for (const int n : {12, 10, 8, 6, 4, 3}) {
    if (following >= static_cast<size_t>(n)) {
      *source = fmt::format("frame not named: {} leading RCOU channels move with channel 1, taken as {} motors", following, n);
      return n;
    }
  }
  return 0;
}

// Motor count: FRAME_CLASS (3.5+), else the "Frame: QUAD" message, else the outputs that move together.
int MotorCount(const Collected& c, const std::string& frame_name, std::string* source) {
  if (auto fc = Param(c, "FRAME_CLASS"); fc && MotorsForFrameClass(static_cast<int>(*fc)) > 0) {
    *source = "FRAME_CLASS";
    return MotorsForFrameClass(static_cast<int>(*fc));
  }
  if (MotorsForFrameName(frame_name) > 0) {
    *source = "MSG Frame: " + frame_name;
    return MotorsForFrameName(frame_name);
  }
  if (const int n = MotorsFromOutputs(c.rcou, source); n > 0) return n;
  // No channels moving together (a bench log): the leading channels that ever hold a plausible
  // output (a multirotor's motors take the first outputs; unused ones log nothing plausible).
  int active = 0;
  for (size_t ch = 0; ch < c.rcou.columns.size(); ++ch, ++active) {
    bool any = false;
    for (size_t s = 0; s < c.rcou.size() && !any; ++s) any = std::isfinite(c.rcou.At(s, ch));
    if (!any) break;
  }
  *source = active > 0 ? "frame not named and no outputs moving together: the leading RCOU channels with plausible "
                         "outputs"
                       : "not determined: no FRAME_CLASS, no Frame message, no motor outputs";
  return active;
}
}  // namespace

namespace {

// Rows need a finite attitude: the ATT samples without one are dropped (counted in att.dropped).
void KeepFiniteAttitude(Collected* c) {
  Channel att = c->att;
  c->att = Channel("", att.columns);
  for (size_t i = 0; i < att.size(); ++i) {
    if (std::isfinite(att.At(i, 0)) && std::isfinite(att.At(i, 1)) && std::isfinite(att.At(i, 2))) {
      c->att.Add(att.t[i], {att.At(i, 0), att.At(i, 1), att.At(i, 2)});
    } else {
      ++c->att.dropped;
    }
  }
  c->att.dropped += att.dropped;
}

// Samples dropped for their time (damaged or out of order), every channel but the attitude's.
size_t SamplesDropped(const Collected& c) {
  size_t n = c.imu.dropped + c.batt.dropped + c.rcou.dropped + c.ctun.dropped + c.gps.dropped + c.baro.dropped +
             c.mode.dropped + c.waypoint.dropped;
  for (const auto& mc : c.mags) n += mc.dropped;
  for (const auto& [name, e] : c.ekf) n += e.dropped;
  return n;
}

// Why a log without attitude rows has none.
Status NoAttitudeRows(const Collected& c, const RecordDamage& records, const std::string& name) {
  const auto att_dropped = records.by_message.find("ATT");
  if (att_dropped != records.by_message.end() || c.att.dropped > 0) {
    return Status::BadInput(fmt::format("{}: ATT: every attitude record is damaged ({} dropped), so no rows to import",
                                        name, c.att.dropped + (att_dropped == records.by_message.end()
                                                                    ? 0 : att_dropped->second)));
  }
  return Status::BadInput(name + ": ATT: no attitude messages, so no rows to import");
}

// The autopilot's EKF position/velocity channel (XKF1, NKF1 or EKF1, the first with samples), or null.
const Channel* EkfChannel(const Collected& c, std::string* ekf_name) {
  for (const char* n : {"XKF1", "NKF1", "EKF1"}) {
    auto it = c.ekf.find(n);
    if (it != c.ekf.end() && it->second.size() > 0) {
      *ekf_name = n;
      return &it->second;
    }
  }
  return nullptr;
}

// q_w..q_z from ATT's Euler angles: w >= 0 first, then continuous.
void AddAttitude(const Collected& c, FlightLog* log) {
  const size_t qw = log->AddColumn("q_w"), qx = log->AddColumn("q_x"), qy = log->AddColumn("q_y"),
               qz = log->AddColumn("q_z");
  Eigen::Quaterniond prev(1, 0, 0, 0);
  for (size_t r = 0; r < log->rows(); ++r) {
    Eigen::Quaterniond q =
        QuatFromEuler(c.att.At(r, 0) * kDegToRad, c.att.At(r, 1) * kDegToRad, c.att.At(r, 2) * kDegToRad).normalized();
    if ((r == 0 && q.w() < 0) || (r > 0 && q.dot(prev) < 0)) q.coeffs() = -q.coeffs();  // w >= 0 first, then continuous
    prev = q;
    log->MutableColumn(qw)[r] = q.w();
    log->MutableColumn(qx)[r] = q.x();
    log->MutableColumn(qy)[r] = q.y();
    log->MutableColumn(qz)[r] = q.z();
  }
}

// GPS relative to the first 3-D fix (flat Earth about that point, WGS-84 radii).
void AddGps(const Collected& c, FlightLog* log) {
  if (c.gps.size() == 0) return;
  const double lat0 = c.gps.At(0, 0), lon0 = c.gps.At(0, 1), alt0 = c.gps.At(0, 2);
  const double s = std::sin(lat0 * kDegToRad);
  const double den = 1.0 - kWgs84E2 * s * s;
  const double r_n = kWgs84A_m * (1.0 - kWgs84E2) / (den * std::sqrt(den));
  const double r_e = kWgs84A_m / std::sqrt(den);
  Channel g("gps_t_s", {"gps_N_m", "gps_E_m", "gps_D_m", "gps_vel_N_mps", "gps_vel_E_mps", "gps_vel_D_mps"});
  for (size_t i = 0; i < c.gps.size(); ++i) {
    const double dlat = (c.gps.At(i, 0) - lat0) * kDegToRad;
    const double dlon = WrapPi((c.gps.At(i, 1) - lon0) * kDegToRad);
    g.Add(c.gps.t[i], {dlat * (r_n + alt0), dlon * (r_e + alt0) * std::cos(lat0 * kDegToRad),
                       -(c.gps.At(i, 2) - alt0), c.gps.At(i, 3), c.gps.At(i, 4), c.gps.At(i, 5)});
  }
  AddHeld(g, AllColumns(g), log);
}

// The motors' PWM range: the import option, MOT_PWM_MIN/MAX, RC3_MIN/MAX, else 1000..2000 µs.
struct PwmRange {
  double min_us = 1000.0, max_us = 2000.0;
  std::string source = "default 1000..2000";
};

PwmRange PwmRangeOf(const Collected& c, const ImportOptions& options) {
  PwmRange r;
  if (options.pwm_min_us > 0 && options.pwm_max_us > options.pwm_min_us) {
    r = {options.pwm_min_us, options.pwm_max_us, "import option"};
  } else if (Param(c, "MOT_PWM_MIN").value_or(0) > 0 && Param(c, "MOT_PWM_MAX").value_or(0) > *Param(c, "MOT_PWM_MIN")) {
    r = {*Param(c, "MOT_PWM_MIN"), *Param(c, "MOT_PWM_MAX"), "MOT_PWM_MIN/MAX"};
  } else if (Param(c, "RC3_MIN").value_or(0) > 0 && Param(c, "RC3_MAX").value_or(0) > *Param(c, "RC3_MIN")) {
    r = {*Param(c, "RC3_MIN"), *Param(c, "RC3_MAX"), "RC3_MIN/MAX"};
  }
  return r;
}

// Motors: PWM -> 0..1 over the range.
void AddMotors(const Collected& c, int motors, const PwmRange& pwm, FlightLog* log) {
  if (c.rcou.size() == 0 || motors <= 0) return;
  const size_t n = std::min<size_t>(static_cast<size_t>(motors), c.rcou.columns.size());
  Channel u("rcou_t_s", {});
  for (size_t i = 0; i < n; ++i) u.columns.push_back(fmt::format("motor_{}_u", i + 1));
  for (size_t s = 0; s < c.rcou.size(); ++s) {
    std::vector<double> v;
    for (size_t i = 0; i < n; ++i) v.push_back(Clamp01((c.rcou.At(s, i) - pwm.min_us) / (pwm.max_us - pwm.min_us)));
    u.Add(c.rcou.t[s], v);
  }
  AddHeld(u, AllColumns(u), log);
}

// The armed state. Before the first event the state is the opposite of it (a log starts disarmed,
// or armed when its first event is a disarm).
void AddArmed(const Collected& c, FlightLog* log) {
  if (c.armed.size() == 0) return;
  const std::vector<double>& att_t = c.att.t;
  Channel armed("", {"armed"});
  if (att_t.front() < c.armed.t.front()) armed.Add(att_t.front(), {1.0 - c.armed.At(0, 0)});
  for (size_t i = 0; i < c.armed.size(); ++i) armed.Add(c.armed.t[i], {c.armed.At(i, 0)});
  AddHeld(armed, AllColumns(armed), log);
}

// What the import decided besides the table, for the meta.
struct ImportFacts {
  std::string frame_name, motors_source, ekf_name;
  int motors = 0;
  bool has_ekf = false;
  PwmRange pwm;
  size_t data_messages = 0, stream_dropped = 0;
};

// Place, date and compasses of the meta.
void WritePlaceAndCompasses(const Collected& c, nlohmann::json* meta) {
  nlohmann::json& m = *meta;
  if (c.first_fix) {
    m["location"] = *c.first_fix;
    m["location"]["source"] = "first GPS 3-D fix";
  } else if (c.home) {
    m["location"] = *c.home;
  }
  if (c.home) m["home"] = *c.home;
  if (c.gps_week > 0 && std::isfinite(c.gps_tow_s)) {
    m["date_decimal_year"] = DecimalYearFromGps(c.gps_week, c.gps_tow_s);
    m["date_utc"] = IsoUtc(UnixFromGps(c.gps_week, c.gps_tow_s));
    m["gps_week"] = c.gps_week;
  }
  const char* mag_prefix[] = {"mag", "mag2", "mag3"};
  nlohmann::json compasses = nlohmann::json::array();
  std::string external;
  for (size_t k = 0; k < 3; ++k) {
    if (c.mags[k].size() == 0) continue;
    compasses.push_back(CompassMeta(c, k, mag_prefix[k]));
    if (compasses.back()["external"] == true && external.empty()) external = mag_prefix[k];
  }
  m["compasses"] = compasses;
  m["external_compass"] = external.empty() ? nlohmann::json(nullptr) : nlohmann::json(external);
  if (auto motct = Param(c, "COMPASS_MOTCT")) m["compass_motct"] = *motct;
  m["params"] = ParamsOfInterest(c.params);
}

// The log's meta (hexsim.log_meta/1).
void WriteMeta(const Collected& c, const std::string& name, const ImportFacts& f, ImportResult* result) {
  FlightLog& log = result->log;
  nlohmann::json& meta = log.meta;
  const std::vector<double>& att_t = c.att.t;
  const std::string firmware = FirmwareOf(c.texts);
  meta["schema"] = "hexsim.log_meta/1";
  meta["source"] = name;
  meta["format"] = "ardupilot-dataflash";
  meta["firmware"] = firmware;
  meta["vehicle_type"] = VehicleTypeOf(firmware);
  meta["frame"] = f.frame_name;
  meta["motor_count"] = f.motors;
  meta["motor_count_source"] = f.motors_source;
  meta["messages_text"] = c.texts;
  const double t0 = att_t.front(), t1 = att_t.back();
  std::vector<double> dt;
  for (size_t i = 1; i < att_t.size(); ++i) dt.push_back(att_t[i] - att_t[i - 1]);
  const double median_dt = Median(dt);
  meta["time"] = {{"start_s", t0}, {"end_s", t1}, {"duration_s", t1 - t0}, {"base", "seconds since autopilot boot"}};
  meta["rows"] = log.rows();
  meta["row_source"] = "ATT";
  meta["row_rate_hz"] = median_dt > 0 ? 1.0 / median_dt : kNaN;
  meta["mean_row_rate_hz"] = t1 > t0 ? static_cast<double>(log.rows() - 1) / (t1 - t0) : kNaN;
  meta["sampling"] = "one row per ATT sample; other channels sample-and-hold (latest sample at or before the row), "
                     "<channel>_t_s = time of the held sample";
  meta["attitude_source"] = "ATT Roll/Pitch/Yaw: the autopilot's own attitude estimate";
  meta["position_source"] = f.has_ekf ? f.ekf_name + " PN/PE/PD, VN/VE/VD (autopilot EKF, core 0): pos_*/vel_* and est_*"
                                      : "none";
  meta["gps_reference"] = "first 3-D fix (gps_N/E/D = 0 there)";
  meta["motor_pwm_range_us"] = {{"min", f.pwm.min_us}, {"max", f.pwm.max_us}, {"source", f.pwm.source}};
  meta["compass_units"] = "uT, as logged by the autopilot (offsets and, where the firmware applies them, "
                          "COMPASS_DIA/ODI and motor compensation included)";
  WritePlaceAndCompasses(c, &meta);
  nlohmann::json damage = DamageJson(result->damage);
  damage["rows_dropped"] = result->rows_dropped;
  damage["samples_dropped"] = SamplesDropped(c);
  damage["stream_samples_dropped"] = f.stream_dropped;
  damage.update(RecordDamageJson(result->records));
  damage["damaged_record_share"] = DamagedRecordShare(result->damage, result->records, f.data_messages);
  meta["damage"] = damage;
  WriteCurrentCheck(CheckCurrentSensor(log), &meta);
}

// The table: one row per ATT sample, the other channels held (the EKF's position right after t_s,
// as in the schema), the motors' outputs, the native-rate streams beside it.
void FillTable(const std::string& bytes, const Collected& c, const Channel* ekf, ImportFacts* f, FlightLog* log) {
  const size_t t_col = log->AddColumn("t_s");
  for (const double t_s : c.att.t) {
    log->AppendRow();
    log->Set(t_col, t_s);
  }
  if (ekf) AddHeld(*ekf, AllColumns(*ekf), log);
  AddAttitude(c, log);
  AddHeld(c.imu, AllColumns(c.imu), log);
  // Compasses; motor-offset columns only when the log has any non-zero.
  for (size_t k = 0; k < 3; ++k) {
    std::vector<size_t> cols = {0, 1, 2};
    if (HasMotorOffsets(c, k)) cols.insert(cols.end(), {3, 4, 5});
    AddHeld(c.mags[k], cols, log);
  }
  AddHeld(c.baro, AllColumns(c.baro), log);
  AddGps(c, log);
  AddHeld(c.ctun, AllColumns(c.ctun), log);
  AddHeld(c.batt, MeasuredColumns(c.batt), log);
  f->frame_name = FrameNameOf(c.texts);
  f->motors = MotorCount(c, f->frame_name, &f->motors_source);
  AddMotors(c, f->motors, f->pwm, log);
  // Native-rate streams beside the table (same motor mapping).
  for (auto& [sname, table] : internal::DataFlashStreams(
           bytes, {f->pwm.min_us, f->pwm.max_us, static_cast<size_t>(std::max(0, f->motors))}, &f->stream_dropped)) {
    log->SetStream(sname, std::move(table));
  }
  if (ekf) {
    Channel est("", {"est_pos_N_m", "est_pos_E_m", "est_pos_D_m", "est_vel_N_mps", "est_vel_E_mps", "est_vel_D_mps"});
    est.t = ekf->t;
    est.values = ekf->values;
    AddHeld(est, AllColumns(est), log);
  }
  const size_t yaw_col = log->AddColumn("yaw_true_deg");
  for (size_t r = 0; r < log->rows(); ++r) log->MutableColumn(yaw_col)[r] = WrapDeg180(c.att.At(r, 2));
  AddHeld(c.mode, AllColumns(c.mode), log);
  AddHeld(c.waypoint, AllColumns(c.waypoint), log);
  AddArmed(c, log);
}

}  // namespace

Result<ImportResult> ImportDataFlash(const std::string& bytes, const std::string& name,
                                     const ImportOptions& options) {
  if (bytes.empty()) return Status::BadInput(name + ": empty file");
  Collected c;
  c.mags = {MakeMagChannel("mag"), MakeMagChannel("mag2"), MakeMagChannel("mag3")};
  DataFlashReader reader(bytes);
  DataFlashMessage m;
  ImportFacts facts;
  RecordPlausibility plausibility;  // drops records damage made implausible (dataflash_plausibility.h)
  while (reader.Next(&m)) {
    if (m.type() != kDataFlashFmtType) ++facts.data_messages;
    if (plausibility.Accept(m)) CollectMessage(m, &c);
  }
  if (facts.data_messages == 0) {
    return Status::BadInput(fmt::format("{}: not an ArduPilot DataFlash log: no readable messages ({} bytes skipped)",
                                        name, reader.damage().skipped_bytes));
  }
  KeepFiniteAttitude(&c);
  for (Channel* ch : {&c.att, &c.imu, &c.batt, &c.rcou, &c.ctun, &c.gps, &c.baro, &c.mode, &c.waypoint, &c.armed}) {
    ch->Finalize();
  }
  for (auto& ch : c.mags) ch.Finalize();
  for (auto& [n, ch] : c.ekf) ch.Finalize();
  // A compass that never measured a field writes no columns (its samples are dropped here).
  nlohmann::json absent = nlohmann::json::array();
  std::vector<std::string> warnings;
  const char* const mag_prefix[] = {"mag", "mag2", "mag3"};
  for (size_t k = 0; k < c.mags.size(); ++k) {
    const std::string why = NeverMeasured(c.mags[k]);
    if (why.empty()) continue;
    absent.push_back({{"column", mag_prefix[k]}, {"why", why}});
    warnings.push_back(fmt::format("{}: {}: {}: its columns are left out", name, mag_prefix[k], why));
    c.mags[k] = MakeMagChannel(mag_prefix[k]);
  }
  RecordDamage& records = plausibility.mutable_damage();
  records.time = c.att.dropped + SamplesDropped(c);
  if (const double share = DamagedRecordShare(reader.damage(), records, facts.data_messages); share > kMaxDamagedRecordShare) {
    return Status::BadInput(fmt::format("{}: damage: {:.0f} % of the records are damaged (more than {:.0f} %), refused: {}",
                                        name, 100.0 * share, 100.0 * kMaxDamagedRecordShare,
                                        DamageSummaryLine(name, reader.damage(), records, facts.data_messages)));
  }
  if (c.att.size() == 0) return NoAttitudeRows(c, records, name);
  ImportResult result;
  result.damage = reader.damage();
  result.rows_dropped = c.att.dropped;
  result.records = records;
  result.records_accepted = facts.data_messages;
  const Channel* ekf = EkfChannel(c, &facts.ekf_name);
  facts.has_ekf = ekf != nullptr;
  facts.pwm = PwmRangeOf(c, options);
  FillTable(bytes, c, ekf, &facts, &result.log);
  WriteMeta(c, name, facts, &result);
  result.log.meta["compasses_absent"] = absent;
  result.log.meta["warnings"] = warnings;
  result.warnings = std::move(warnings);
  return result;
}

Result<ImportResult> ImportDataFlashFile(const std::string& path, const ImportOptions& options) {
  auto bytes = ReadFile(path);
  if (!bytes.ok()) return bytes.status();
  const size_t slash = path.find_last_of('/');
  auto result = ImportDataFlash(*bytes, path, options);
  if (result.ok()) result->log.meta["source"] = slash == std::string::npos ? path : path.substr(slash + 1);
  return result;
}

Status WriteImport(const ImportResult& result, const std::string& csv_path) {
  return WriteFlightLog(result.log, csv_path);
}

}  // namespace hexsim::logs
