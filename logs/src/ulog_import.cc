#include "hexsim/logs/ulog_import.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>

#include <fmt/format.h>

#include "hexsim/logs/ulog.h"

namespace hexsim::logs {
namespace {

constexpr double kRadToDeg = 57.29577951308232;
constexpr double kMicroteslaPerGauss = 100.0;

// One sample-and-hold channel: a topic, its time column, and (column, value of record i) pairs.
struct Channel {
  const ULogTopic* topic = nullptr;
  std::string t_column;
  std::vector<std::pair<std::string, std::function<double(size_t)>>> columns;
};

void Hold(const Channel& ch, FlightLog* log, const std::vector<double>& row_t) {
  if (ch.topic == nullptr || ch.topic->records.empty()) return;
  const size_t tc = log->AddColumn(ch.t_column);
  std::vector<size_t> cols;
  for (const auto& c : ch.columns) cols.push_back(log->AddColumn(c.first));
  size_t next = 0;
  long held = -1;
  for (size_t r = 0; r < row_t.size(); ++r) {
    while (next < ch.topic->records.size() && ch.topic->TimeS(next) <= row_t[r]) held = static_cast<long>(next++);
    if (held < 0) continue;
    const size_t i = static_cast<size_t>(held);
    log->MutableColumn(tc)[r] = ch.topic->TimeS(i);
    for (size_t k = 0; k < cols.size(); ++k) log->MutableColumn(cols[k])[r] = ch.columns[k].second(i);
  }
}

// Three columns `prefix_{x,y,z}suffix` from fields `f0..f2` scaled by `scale`.
void Vec3(Channel* ch, const std::string& prefix, const std::string& suffix, const std::array<std::string, 3>& f,
          double scale) {
  const char* ax[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    const ULogTopic* t = ch->topic;
    const std::string& field = f[static_cast<size_t>(k)];
    std::string column = prefix;
    column += "_";
    column += ax[k];
    column += suffix;
    ch->columns.emplace_back(column, [t, field, scale](size_t i) { return t->Get(i, field) * scale; });
  }
}

}  // namespace

Result<ULogImport> ImportULog(const std::string& bytes, const std::string& name) {
  auto parsed = ParseULog(bytes, name);
  if (!parsed.ok()) return parsed.status();
  const ULog& u = *parsed;
  const ULogTopic* att = u.Find("vehicle_attitude");
  if (att == nullptr || att->records.empty() || !att->Has("q[0]")) {
    return Status::BadInput(name + ": vehicle_attitude: no attitude samples (rows are one per attitude sample)");
  }
  ULogImport out;
  FlightLog& log = out.log;
  std::vector<double> row_t;
  for (size_t i = 0; i < att->records.size(); ++i) {
    const double t = att->TimeS(i);
    if (!std::isfinite(t) || (!row_t.empty() && t <= row_t.back())) continue;  // damaged or repeated time
    row_t.push_back(t);
  }
  if (row_t.empty()) {
    return Status::BadInput(name + ": vehicle_attitude: no attitude sample has a usable timestamp");
  }
  const size_t t_col = log.AddColumn("t_s");
  std::vector<size_t> att_cols;
  for (const char* c : {"q_w", "q_x", "q_y", "q_z", "roll_deg", "pitch_deg", "yaw_deg", "yaw_true_deg"}) {
    att_cols.push_back(log.AddColumn(c));
  }
  log.Reserve(row_t.size());
  size_t rec = 0;
  for (double t : row_t) {
    while (att->TimeS(rec) != t) ++rec;
    const double w = att->Get(rec, "q[0]"), x = att->Get(rec, "q[1]"), y = att->Get(rec, "q[2]"), z = att->Get(rec, "q[3]");
    const double roll = std::atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y));
    const double pitch = std::asin(std::clamp(2 * (w * y - z * x), -1.0, 1.0));
    const double yaw = std::atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
    log.AppendRow();
    log.Set(t_col, t);
    const double v[8] = {w, x, y, z, roll * kRadToDeg, pitch * kRadToDeg, yaw * kRadToDeg, yaw * kRadToDeg};
    for (size_t k = 0; k < 8; ++k) log.Set(att_cols[k], v[k]);
  }

  nlohmann::json compasses = nlohmann::json::array();
  std::vector<Channel> channels;
  const ULogTopic* imu = u.Find("sensor_combined");
  if (imu != nullptr) {
    Channel c{imu, "imu_t_s", {}};
    Vec3(&c, "gyro", "_radps", {"gyro_rad[0]", "gyro_rad[1]", "gyro_rad[2]"}, 1.0);
    Vec3(&c, "accel", "_mps2", {"accelerometer_m_s2[0]", "accelerometer_m_s2[1]", "accelerometer_m_s2[2]"}, 1.0);
    channels.push_back(std::move(c));
  }
  const char* prefixes[3] = {"mag", "mag2", "mag3"};
  bool any_sensor_mag = false;
  for (int k = 0; k < 3; ++k) {
    const ULogTopic* m = u.Find("sensor_mag", k);
    if (m == nullptr || !m->Has("x")) continue;
    any_sensor_mag = true;
    Channel c{m, std::string(prefixes[k]) + "_t_s", {}};
    Vec3(&c, prefixes[k], "_uT", {"x", "y", "z"}, kMicroteslaPerGauss);
    channels.push_back(std::move(c));
    compasses.push_back({{"column", prefixes[k]}, {"instance", k}, {"source", "sensor_mag"}, {"calibrated", false},
                         {"device_id", m->Get(0, "device_id")}});
  }
  if (!any_sensor_mag) {
    const ULogTopic* vm = u.Find("vehicle_magnetometer");
    const ULogTopic* old = imu != nullptr && imu->Has("magnetometer_ga[0]") ? imu : nullptr;
    const ULogTopic* m = vm != nullptr && vm->Has("magnetometer_ga[0]") ? vm : old;
    if (m != nullptr) {
      Channel c{m, "mag_t_s", {}};
      Vec3(&c, "mag", "_uT", {"magnetometer_ga[0]", "magnetometer_ga[1]", "magnetometer_ga[2]"}, kMicroteslaPerGauss);
      channels.push_back(std::move(c));
      const bool calibrated = m == vm;
      compasses.push_back({{"column", "mag"}, {"instance", 0}, {"source", m->name}, {"calibrated", calibrated}});
      if (calibrated) {
        out.warnings.push_back(name + ": mag: from vehicle_magnetometer, which PX4 has already calibrated (no raw "
                               "sensor_mag in this log): a calibration from it is relative to the one in force");
      }
    }
  }
  if (const ULogTopic* b = u.Find("battery_status"); b != nullptr) {
    Channel c{b, "batt_t_s", {}};
    c.columns.emplace_back("current_A", [b](size_t i) { return b->Get(i, "current_a"); });
    c.columns.emplace_back("voltage_V", [b](size_t i) { return b->Get(i, "voltage_v"); });
    channels.push_back(std::move(c));
  }
  const auto rotors_it = u.params.find("CA_ROTOR_COUNT");
  const int motors = rotors_it != u.params.end() && rotors_it->second >= 1 && rotors_it->second <= 12
                         ? static_cast<int>(rotors_it->second) : 4;
  const ULogTopic* am = u.Find("actuator_motors");
  const ULogTopic* ao = u.Find("actuator_outputs");
  if (am != nullptr || ao != nullptr) {
    const auto pmin = u.params.find("PWM_MAIN_MIN"), pmax = u.params.find("PWM_MAIN_MAX");
    const double lo = pmin != u.params.end() ? pmin->second : 1000.0, hi = pmax != u.params.end() ? pmax->second : 2000.0;
    const ULogTopic* t = am != nullptr ? am : ao;
    Channel c{t, "rcou_t_s", {}};
    for (int k = 0; k < motors; ++k) {
      const std::string f = fmt::format(am != nullptr ? "control[{}]" : "output[{}]", k);
      const bool pwm = am == nullptr;
      c.columns.emplace_back(fmt::format("motor_{}_u", k + 1), [t, f, pwm, lo, hi](size_t i) {
        const double v = t->Get(i, f);
        return std::clamp(pwm ? (v - lo) / (hi - lo) : v, 0.0, 1.0);
      });
    }
    channels.push_back(std::move(c));
  }
  if (const ULogTopic* th = u.Find("vehicle_thrust_setpoint"); th != nullptr && th->Has("xyz[2]")) {
    channels.push_back({th, "ctun_t_s", {{"control_u", [th](size_t i) { return -1000.0 * th->Get(i, "xyz[2]"); }}}});
  } else if (const ULogTopic* ac = u.Find("actuator_controls_0"); ac != nullptr && ac->Has("control[3]")) {
    channels.push_back({ac, "ctun_t_s", {{"control_u", [ac](size_t i) { return 1000.0 * ac->Get(i, "control[3]"); }}}});
  }
  if (const ULogTopic* lp = u.Find("vehicle_local_position"); lp != nullptr) {
    Channel c{lp, "ekf_t_s", {}};
    const std::pair<const char*, const char*> m[6] = {{"N_m", "x"},   {"E_m", "y"},   {"D_m", "z"},
                                                      {"N_mps", "vx"}, {"E_mps", "vy"}, {"D_mps", "vz"}};
    for (const auto& [suffix, field] : m) {
      const std::string f = field, kind = std::string(suffix).find("mps") != std::string::npos ? "vel_" : "pos_";
      c.columns.emplace_back(kind + suffix, [lp, f](size_t i) { return lp->Get(i, f); });
      c.columns.emplace_back("est_" + kind + suffix, [lp, f](size_t i) { return lp->Get(i, f); });
    }
    channels.push_back(std::move(c));
  }
  for (auto& ch : channels) {
    // Columns added now are filled with NaN for every row so far (AddColumn), then held.
    Hold(ch, &log, row_t);
  }
  nlohmann::json& meta = log.meta;
  meta["schema"] = "hexsim.log_meta/1";
  meta["source"] = name;
  meta["format"] = "px4-ulog";
  meta["ulog_version"] = u.version;
  meta["firmware"] = u.info.count("ver_sw") != 0 ? u.info.at("ver_sw") : "";
  meta["vehicle_type"] = "px4";
  meta["motor_count"] = motors;
  meta["motor_count_source"] = rotors_it != u.params.end() ? "CA_ROTOR_COUNT" : "default (4)";
  meta["rows"] = log.rows();
  meta["row_source"] = "vehicle_attitude";
  meta["time"] = {{"start_s", row_t.front()}, {"end_s", row_t.back()}, {"duration_s", row_t.back() - row_t.front()},
                  {"base", "seconds since autopilot boot"}};
  meta["attitude_source"] = "vehicle_attitude q: the autopilot's own attitude estimate";
  meta["compasses"] = compasses;
  meta["compass_units"] = "uT (PX4 logs gauss: x100)";
  meta["messages_text"] = u.messages;
  meta["bytes_skipped"] = u.bytes_skipped;
  meta["warnings"] = out.warnings;
  // The log's own strings (ver_sw, logged messages, warnings quoting names) are bytes, not always
  // UTF-8; JSON requires UTF-8, so invalid sequences become U+FFFD once, here, and every later
  // dump() of the meta succeeds (fuzz finding: an 0x80 byte in a logged message).
  meta = nlohmann::json::parse(meta.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
  return out;
}

}  // namespace hexsim::logs
