#include "hexsim/logs/ulog_import.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>

#include <fmt/format.h>

#include "hexsim/logs/current_check.h"
#include "hexsim/logs/dataflash_import.h"
#include "hexsim/logs/ulog.h"
#include "ulog_mag_cal.h"

namespace hexsim::logs {
namespace {

using internal::MagFrame;

constexpr double kRadToDeg = 57.29577951308232;
constexpr double kMicroteslaPerGauss = 100.0;
constexpr double kGps3dFix = 3;  // vehicle_gps_position fix_type: 3 = 3-D fix
constexpr double kCurrentUnknown_A = -1.0;  // battery_status.current_a: "-1 if unknown"

// vehicle_gps_position: PX4 1.14 on logs latitude_deg/longitude_deg/altitude_msl_m; before, lat/lon in
// 1e-7 deg and alt in mm.
double GpsLatDeg(const ULogTopic& g, size_t i) {
  return g.Has("latitude_deg") ? g.Get(i, "latitude_deg") : 1e-7 * g.Get(i, "lat");
}
double GpsLonDeg(const ULogTopic& g, size_t i) {
  return g.Has("longitude_deg") ? g.Get(i, "longitude_deg") : 1e-7 * g.Get(i, "lon");
}
double GpsAltM(const ULogTopic& g, size_t i) {
  return g.Has("altitude_msl_m") ? g.Get(i, "altitude_msl_m") : 1e-3 * g.Get(i, "alt");
}

struct Column {
  std::string name;
  std::function<double(size_t)> value;  // of record i
  bool in_table = true;                 // false: the native-rate stream only
};

// One topic as a sample-and-hold channel of the table (`<stream>_t_s` + columns) and as the
// native-rate stream `stream`.
struct Channel {
  const ULogTopic* topic = nullptr;
  std::string stream;  // "": table columns only, no `_t_s` and no stream
  std::vector<Column> columns;
  std::function<bool(size_t)> keep;  // records to use (null: all)
  // Time records by when they were sampled (ULogTopic::SampleTimeS), not published: the compasses,
  // whose latency against the attitude the diagnosis measures.
  bool by_sample_time = false;
};

double RecordTime(const Channel& ch, size_t i) {
  return ch.by_sample_time ? ch.topic->SampleTimeS(i) : ch.topic->TimeS(i);
}

// The records to use, in file order: a finite time not earlier than the last kept one, and kept
// by the channel. Others are counted in `dropped` (damaged or out-of-order time only).
std::vector<size_t> Usable(const Channel& ch, size_t* dropped) {
  std::vector<size_t> out;
  double last = -INFINITY;
  for (size_t i = 0; i < ch.topic->records.size(); ++i) {
    const double t = RecordTime(ch, i);
    if (!std::isfinite(t) || t < last) {
      ++*dropped;
      continue;
    }
    if (ch.keep && !ch.keep(i)) continue;
    last = t;
    out.push_back(i);
  }
  return out;
}

// The table's columns: each row holds the latest record at or before its time, never interpolated.
void Hold(const Channel& ch, const std::vector<size_t>& recs, FlightLog* log, const std::vector<double>& row_t) {
  const size_t tc = ch.stream.empty() ? 0 : log->AddColumn(ch.stream + "_t_s");
  std::vector<std::pair<size_t, const Column*>> cols;
  for (const auto& c : ch.columns) {
    if (c.in_table) cols.emplace_back(log->AddColumn(c.name), &c);
  }
  size_t next = 0;
  long held = -1;
  for (size_t r = 0; r < row_t.size(); ++r) {
    while (next < recs.size() && RecordTime(ch, recs[next]) <= row_t[r]) held = static_cast<long>(next++);
    if (held < 0) continue;
    const size_t i = recs[static_cast<size_t>(held)];
    if (!ch.stream.empty()) log->MutableColumn(tc)[r] = RecordTime(ch, i);
    for (const auto& [col, c] : cols) log->MutableColumn(col)[r] = c->value(i);
  }
}

// The native-rate stream: one row per usable record, t_s first.
FlightLog StreamOf(const Channel& ch, const std::vector<size_t>& recs) {
  FlightLog s;
  const size_t tc = s.AddColumn("t_s");
  std::vector<size_t> cols;
  for (const auto& c : ch.columns) cols.push_back(s.AddColumn(c.name));
  s.Reserve(recs.size());
  for (size_t i : recs) {
    s.AppendRow();
    s.Set(tc, RecordTime(ch, i));
    for (size_t k = 0; k < cols.size(); ++k) {
      const double v = ch.columns[k].value(i);
      s.Set(cols[k], std::isfinite(v) ? v : kMissing);
    }
  }
  return s;
}

// Three columns `prefix_{x,y,z}suffix` from fields `f0..f2` scaled by `scale`.
void Vec3(Channel* ch, const std::string& prefix, const std::string& suffix, const std::array<std::string, 3>& f,
          double scale) {
  const char* ax[3] = {"x", "y", "z"};
  const ULogTopic* t = ch->topic;
  for (size_t k = 0; k < 3; ++k) {
    const std::string& field = f[k];
    std::string name = prefix;
    name += "_";
    name += ax[k];
    name += suffix;
    ch->columns.push_back({name, [t, field, scale](size_t i) { return t->Get(i, field) * scale; }});
  }
}

// Euler angle `which` (0 roll, 1 pitch, 2 yaw; degrees) of the Hamilton quaternion q[0..3] (FRD → NED).
double EulerDeg(const ULogTopic* t, size_t i, int which) {
  const double w = t->Get(i, "q[0]"), x = t->Get(i, "q[1]"), y = t->Get(i, "q[2]"), z = t->Get(i, "q[3]");
  if (which == 0) return kRadToDeg * std::atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y));
  if (which == 1) return kRadToDeg * std::asin(std::clamp(2 * (w * y - z * x), -1.0, 1.0));
  return kRadToDeg * std::atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
}

Channel Attitude(const ULogTopic* att) {
  Channel c{att, "att", {}, nullptr};
  for (int k = 0; k < 4; ++k) {
    const std::string f = fmt::format("q[{}]", k);
    c.columns.push_back({std::string("q_") + "wxyz"[k], [att, f](size_t i) { return att->Get(i, f); }});
  }
  const char* names[4] = {"roll_deg", "pitch_deg", "yaw_deg", "yaw_true_deg"};
  for (int k = 0; k < 4; ++k) {
    const int which = std::min(k, 2);
    c.columns.push_back({names[k], [att, which](size_t i) { return EulerDeg(att, i, which); }});
  }
  return c;
}

// The armed state over time, from actuator_armed.armed (the outputs' own state), else vehicle_status
// arming_state (2 = ARMED in every PX4 release; older releases' 3, ARMED_ERROR, is rare and taken as
// disarmed). Before the first record the state is the first record's: PX4's logger writes each
// topic's current value when it starts.
struct ArmedState {
  std::vector<double> t_s;
  std::vector<double> armed;  // 0/1
  std::string source;
  double At(double t) const {
    if (t_s.empty()) return kMissing;
    const size_t k = static_cast<size_t>(std::upper_bound(t_s.begin(), t_s.end(), t) - t_s.begin());
    return armed[k == 0 ? 0 : k - 1];
  }
};

ArmedState ArmedOf(const ULog& u) {
  ArmedState s;
  const ULogTopic* aa = u.Find("actuator_armed");
  const ULogTopic* vs = u.Find("vehicle_status");
  const bool use_aa = aa != nullptr && aa->Has("armed") && !aa->records.empty();
  const ULogTopic* t = use_aa ? aa : vs;
  if (t == nullptr || (!use_aa && !t->Has("arming_state"))) return s;
  constexpr double kArmingStateArmed = 2;  // vehicle_status ARMING_STATE_ARMED
  s.source = use_aa ? "actuator_armed.armed" : "vehicle_status.arming_state (2 = armed)";
  for (size_t i = 0; i < t->records.size(); ++i) {
    const double ti = t->TimeS(i);
    const double v = use_aa ? t->Get(i, "armed") : t->Get(i, "arming_state");
    if (!std::isfinite(ti) || !std::isfinite(v) || (!s.t_s.empty() && ti < s.t_s.back())) continue;
    s.t_s.push_back(ti);
    s.armed.push_back(use_aa ? (v != 0 ? 1.0 : 0.0) : (v == kArmingStateArmed ? 1.0 : 0.0));
  }
  return s;
}

// Records of `t` in the flight: while armed where the log tells the armed state, else all of them.
size_t FlightRecords(const ULogTopic& t, const ArmedState& armed) {
  size_t n = 0;
  for (size_t i = 0; i < t.records.size(); ++i) {
    const double ti = t.TimeS(i);
    if (std::isfinite(ti) && (armed.t_s.empty() || armed.At(ti) > 0.5)) ++n;
  }
  return n;
}

const ULogTopic* MagTopic(const ULog& u, const char* topic, int k, const char* field) {
  const ULogTopic* m = u.Find(topic, k);
  return m != nullptr && m->Has(field) && !m->records.empty() ? m : nullptr;
}

double DeviceId(const ULogTopic* m) { return m != nullptr && m->Has("device_id") ? m->Get(0, "device_id") : 0.0; }

// The vehicle_magnetometer instance of the same sensor as sensor_mag `sm` (instance k): the one
// with the same device_id where both log one, else instance k.
const ULogTopic* CalibratedTwin(const ULog& u, const ULogTopic* sm, int k) {
  constexpr int kMaxInstances = 4;  // PX4's MAG_COUNT_MAX
  const double id = DeviceId(sm);
  for (int i = 0; i < kMaxInstances && id > 0; ++i) {
    const ULogTopic* vm = MagTopic(u, "vehicle_magnetometer", i, "magnetometer_ga[0]");
    if (vm != nullptr && DeviceId(vm) == id) return vm;
  }
  const ULogTopic* vm = MagTopic(u, "vehicle_magnetometer", k, "magnetometer_ga[0]");
  return vm != nullptr && (id <= 0 || DeviceId(vm) <= 0) ? vm : nullptr;
}

// Whether a compass is external: sensor_mag's own is_external (PX4 1.10/1.11), else its calibration
// slot's CAL_MAGn_ROT (PX4 forces −1 on an internal sensor; ≥ 0 is an external one's rotation);
// null when neither is in the log.
nlohmann::json ExternalOf(const ULogTopic* sm, const nlohmann::json& cal, std::string* source) {
  if (sm != nullptr && sm->Has("is_external")) {
    *source = "sensor_mag.is_external";
    return sm->Get(0, "is_external") != 0;
  }
  if (!cal.is_null() && cal.contains("rotation") && cal["rotation"].is_number()) {
    const double rot = cal["rotation"].get<double>();
    *source = fmt::format("CAL_MAG{}_ROT = {:g} (PX4: -1 internal, else an external sensor's rotation)",
                          cal["index"].get<int>(), rot);
    return rot >= 0;
  }
  *source = "not in the log";
  return nullptr;
}

// The magnetometers. Per compass two topics may hold it: sensor_mag (raw from PX4 1.11 on,
// driver-calibrated before) and vehicle_magnetometer (calibrated by PX4's sensors module: the field
// in the FRD body frame, msg/VehicleMagnetometer.msg). The logger may log them at different rates
// (SDLOG_PROFILE; 1 Hz sensor_mag beside 2 Hz vehicle_magnetometer in one public log), so each
// compass takes the topic with more records in the flight (while armed, where the log tells it),
// the calibrated one at equal counts; the meta's `source` and `source_choice` say which and why.
// Old logs: sensor_combined magnetometer_ga (calibrated).
void Magnetometers(const ULog& u, const std::string& name, const ArmedState& armed, std::vector<Channel>* channels,
                   nlohmann::json* compasses, std::vector<std::string>* warnings) {
  const char* prefixes[3] = {"mag", "mag2", "mag3"};
  auto add = [&](const ULogTopic* m, const ULogTopic* sm, int k, const std::array<std::string, 3>& fields,
                 MagFrame frame, const std::string& choice) {
    Channel c{m, prefixes[k], {}, nullptr, true};
    Vec3(&c, prefixes[k], "_uT", fields, kMicroteslaPerGauss);
    channels->push_back(std::move(c));
    const double device_id = DeviceId(m);
    nlohmann::json j = {{"column", prefixes[k]},
                        {"instance", k},
                        {"source", m->name},
                        {"source_choice", choice},
                        {"time", m->Has("timestamp_sample") ? "timestamp_sample" : "timestamp"},
                        {"calibrated", frame != MagFrame::kRaw},
                        {"frame", frame == MagFrame::kRaw               ? "raw"
                                  : frame == MagFrame::kDriverCalibrated ? "driver-calibrated"
                                                                          : "calibrated"}};
    if (device_id > 0) j["device_id"] = device_id;
    const nlohmann::json cal = internal::Px4MagCalibration(u, device_id, k, frame);
    if (!cal.is_null()) j["px4_calibration"] = cal;
    std::string external_source;
    j["external"] = ExternalOf(sm, cal, &external_source);
    j["external_source"] = external_source;
    if (frame != MagFrame::kRaw) {
      const bool rebuilt = !cal.is_null() && cal["rotation_known"].get<bool>();
      warnings->push_back(fmt::format(
          "{}: {}: {} holds the field PX4 has already calibrated{}", name, prefixes[k], m->name,
          rebuilt ? fmt::format(": calibrate rebuilds the raw field from CAL_MAG{}_* (matched by {})",
                                cal["index"].get<int>(), cal["matched_by"].get<std::string>())
                  : " and the log lacks what undoes it: a calibration from it is relative to the one in force"));
    }
    compasses->push_back(std::move(j));
  };
  const char* span = armed.t_s.empty() ? "in the log (no armed state)" : "while armed";
  for (int k = 0; k < 3; ++k) {
    const ULogTopic* sm = MagTopic(u, "sensor_mag", k, "x");
    const ULogTopic* vm = sm != nullptr ? CalibratedTwin(u, sm, k) : MagTopic(u, "vehicle_magnetometer", k, "magnetometer_ga[0]");
    if (sm == nullptr && vm == nullptr) continue;
    const size_t n_sm = sm != nullptr ? FlightRecords(*sm, armed) : 0, n_vm = vm != nullptr ? FlightRecords(*vm, armed) : 0;
    const bool use_vm = vm != nullptr && (sm == nullptr || n_vm >= n_sm);
    const std::string choice =
        sm == nullptr || vm == nullptr
            ? fmt::format("{}: the only topic of this compass ({} records {})", use_vm ? vm->name : sm->name,
                          use_vm ? n_vm : n_sm, span)
            : fmt::format("{}: {} records {} against {}'s {}{}", use_vm ? vm->name : sm->name, use_vm ? n_vm : n_sm,
                          span, use_vm ? sm->name : vm->name, use_vm ? n_sm : n_vm,
                          n_sm == n_vm ? " (equal: the calibrated topic)" : "");
    if (use_vm) {
      add(vm, sm, k, {"magnetometer_ga[0]", "magnetometer_ga[1]", "magnetometer_ga[2]"}, MagFrame::kCalibrated, choice);
    } else {
      add(sm, sm, k, {"x", "y", "z"},
          sm->Has("x_raw") || sm->Has("scaling") ? MagFrame::kDriverCalibrated : MagFrame::kRaw, choice);
    }
  }
  if (!compasses->empty()) return;
  const ULogTopic* old = MagTopic(u, "sensor_combined", 0, "magnetometer_ga[0]");
  if (old != nullptr) {
    add(old, nullptr, 0, {"magnetometer_ga[0]", "magnetometer_ga[1]", "magnetometer_ga[2]"}, MagFrame::kCalibrated,
        "sensor_combined: the log's only magnetometer topic");
  }
}

// PX4's power signal P of the magnetometer power compensation (CAL_MAG_COMP_TYP; VehicleMagnetometer
// UpdatePowerCompensation): 1 throttle, only while armed (actuator_controls_0 control[3], or
// |vehicle_thrust_setpoint xyz| in releases without actuator_controls), 2 and 3 the current of
// battery_status instance 0 and 1 in kA (current_a / 1000). Null topic: no power signal.
Channel PowerSignal(const ULog& u, int comp_type, const ArmedState& armed, std::string* source) {
  constexpr double kAmperesPerKiloampere = 1000.0;
  if (comp_type == 2 || comp_type == 3) {
    const ULogTopic* b = u.Find("battery_status", comp_type - 2);
    if (b == nullptr || !b->Has("current_a")) return {};
    *source = fmt::format("battery_status instance {} current_a / 1000 (kA)", comp_type - 2);
    return {b, "", {{"px4_mag_power", [b](size_t i) { return b->Get(i, "current_a") / kAmperesPerKiloampere; }}}, nullptr};
  }
  if (comp_type != 1) return {};
  const ULogTopic* ac = u.Find("actuator_controls_0");
  const ULogTopic* th = u.Find("vehicle_thrust_setpoint");
  const bool use_ac = ac != nullptr && ac->Has("control[3]") && !ac->records.empty();
  const ULogTopic* t = use_ac ? ac : th;
  if (t == nullptr || (!use_ac && !t->Has("xyz[2]"))) return {};
  *source = use_ac ? "actuator_controls_0 control[3] (throttle) while armed"
                   : "|vehicle_thrust_setpoint xyz| (throttle) while armed";
  return {t, "", {{"px4_mag_power", [t, use_ac, &armed](size_t i) {
                     if (!(armed.At(t->TimeS(i)) > 0.5)) return 0.0;
                     if (use_ac) return t->Get(i, "control[3]");
                     return std::hypot(t->Get(i, "xyz[0]"), t->Get(i, "xyz[1]"), t->Get(i, "xyz[2]"));
                   }}}, nullptr};
}

// The table's rows, one per usable vehicle_attitude sample time (the first of equal times), with
// the attitude's columns, and the attitude's native-rate stream. Returns the rows' times.
Result<std::vector<double>> AttitudeRows(const ULogTopic* att, const std::string& name, FlightLog* log, size_t* dropped) {
  const Channel att_ch = Attitude(att);
  std::vector<size_t> att_recs;
  std::vector<double> row_t;
  for (size_t i : Usable(att_ch, dropped)) {
    if (!row_t.empty() && att->TimeS(i) == row_t.back()) continue;  // one row per time
    att_recs.push_back(i);
    row_t.push_back(att->TimeS(i));
  }
  if (row_t.empty()) {
    return Status::BadInput(name + ": vehicle_attitude: no attitude sample has a usable timestamp");
  }
  const size_t t_col = log->AddColumn("t_s");
  std::vector<size_t> att_cols;
  for (const auto& c : att_ch.columns) att_cols.push_back(log->AddColumn(c.name));
  log->Reserve(row_t.size());
  for (size_t r = 0; r < row_t.size(); ++r) {
    log->AppendRow();
    log->Set(t_col, row_t[r]);
    for (size_t k = 0; k < att_cols.size(); ++k) log->Set(att_cols[k], att_ch.columns[k].value(att_recs[r]));
  }
  log->SetStream("att", StreamOf(att_ch, att_recs));
  return row_t;
}

// PX4's magnetometer power compensation as the log has it: CAL_MAG_COMP_TYP, and the source of the
// power signal its channel carries ("" : none).
struct PowerCompensation {
  int type = 0;
  std::string source;
};

// Adds the power signal's channel when a compensation is in force (a non-zero CAL_MAGn_COMP on some
// compass and CAL_MAG_COMP_TYP set; ulog_mag_cal.h), or a warning when the log lacks the signal.
// `armed` must outlive the channel.
PowerCompensation AddPowerChannel(const ULog& u, const std::string& name, const nlohmann::json& compasses,
                                  const ArmedState& armed, std::vector<Channel>* channels, std::vector<std::string>* warnings) {
  PowerCompensation pc;
  const auto comp_it = u.params.find("CAL_MAG_COMP_TYP");
  pc.type = comp_it != u.params.end() ? static_cast<int>(comp_it->second) : 0;
  bool comp_nonzero = false;
  for (const auto& c : compasses) {
    if (!c.contains("px4_calibration")) continue;
    for (const auto& v : c["px4_calibration"]["power_compensation"]) comp_nonzero = comp_nonzero || v.get<double>() != 0.0;
  }
  if (comp_nonzero && pc.type != 0) {
    Channel p = PowerSignal(u, pc.type, armed, &pc.source);
    if (p.topic != nullptr) channels->push_back(std::move(p));
    else warnings->push_back(fmt::format("{}: CAL_MAG_COMP_TYP {}: the log lacks the power signal it needs", name, pc.type));
  }
  return pc;
}

// The rotor count: CA_ROTOR_COUNT where it holds 1..12, else 4.
int MotorCount(const ULog& u) {
  const auto rotors_it = u.params.find("CA_ROTOR_COUNT");
  return rotors_it != u.params.end() && rotors_it->second >= 1 && rotors_it->second <= 12 ? static_cast<int>(rotors_it->second) : 4;
}

// The motors' outputs (0..1): actuator_motors' controls, or actuator_outputs' PWM over the
// PWM_MAIN_MIN..MAX range (the PWM itself in the stream only). Null topic: neither is logged.
// No PWM pulse for an ESC or servo is longer than 2.5 ms (PX4's PWM_MAIN_MAX tops out at 2150 us).
constexpr double kMaxPwm_us = 2500.0;
// UAVCAN's esc.RawCommand full scale: PX4 1.9-1.13's uavcan driver logs the motors as 0..8191.
constexpr double kUavcanRawCommandMax = 8191.0;

double MaxOutput(const ULogTopic& t, int motors) {
  double m = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < motors; ++k) {
    const std::string f = fmt::format("output[{}]", k);
    if (!t.Has(f)) continue;
    for (size_t i = 0; i < t.records.size(); ++i) {
      const double v = t.Get(i, f);
      if (std::isfinite(v)) m = std::max(m, v);
    }
  }
  return m;
}

// The actuator_outputs instance that carries the motors: the one whose first `motors` outputs move
// most over the log (the sum of their standard deviations; records without them count nothing). PX4
// publishes one instance per output driver (PWM main, IO, UAVCAN, DShot), so the motors are not
// always on instance 0: a PX4 1.13 log with UAVCAN ESCs has an empty instance 0 and its motors on
// instance 1. A tie keeps the lower instance.
const ULogTopic* MotorOutputsInstance(const ULog& u, int motors) {
  const ULogTopic* best = nullptr;
  double best_spread = -1.0;
  for (const ULogTopic& t : u.topics) {
    if (t.name != "actuator_outputs" || t.records.empty()) continue;
    double spread = 0.0;
    for (int k = 0; k < motors; ++k) {
      const std::string f = fmt::format("output[{}]", k);
      if (!t.Has(f)) continue;
      double sum = 0.0, sum2 = 0.0;
      size_t n = 0;
      for (size_t i = 0; i < t.records.size(); ++i) {
        const double v = t.Get(i, f);
        if (!std::isfinite(v)) continue;
        sum += v;
        sum2 += v * v;
        ++n;
      }
      if (n > 1) spread += std::sqrt(std::max(0.0, sum2 / static_cast<double>(n) - (sum / static_cast<double>(n)) * (sum / static_cast<double>(n))));
    }
    if (spread > best_spread || (spread == best_spread && best != nullptr && t.multi_id < best->multi_id)) {
      best = &t;
      best_spread = spread;
    }
  }
  return best;
}

Channel MotorOutputs(const ULog& u, int motors) {
  const ULogTopic* am = u.Find("actuator_motors");
  const ULogTopic* ao = MotorOutputsInstance(u, motors);
  if (am == nullptr && ao == nullptr) return {};
  const auto pmin = u.params.find("PWM_MAIN_MIN"), pmax = u.params.find("PWM_MAIN_MAX");
  double lo = pmin != u.params.end() ? pmin->second : 1000.0, hi = pmax != u.params.end() ? pmax->second : 2000.0;
  if (am == nullptr && MaxOutput(*ao, motors) > kMaxPwm_us) {
    // Beyond any PWM pulse: UAVCAN's raw ESC command (PX4's uavcan driver publishes 0..8191).
    lo = 0.0;
    hi = kUavcanRawCommandMax;
  }
  const ULogTopic* t = am != nullptr ? am : ao;
  Channel c{t, "rcou", {}, nullptr};
  const bool pwm = am == nullptr;
  for (int k = 0; k < motors; ++k) {
    const std::string f = fmt::format(pwm ? "output[{}]" : "control[{}]", k);
    c.columns.push_back({fmt::format("motor_{}_u", k + 1), [t, f, pwm, lo, hi](size_t i) {
                           const double v = t->Get(i, f);
                           return std::clamp(pwm ? (v - lo) / (hi - lo) : v, 0.0, 1.0);
                         }});
  }
  for (int k = 0; k < motors && pwm; ++k) {
    const std::string f = fmt::format("output[{}]", k);
    c.columns.push_back({fmt::format("pwm_{}_us", k + 1), [t, f](size_t i) { return t->Get(i, f); }, false});
  }
  return c;
}

// The power side: battery current and voltage, the motors' outputs, the collective thrust (control_u).
void AddPowerChannels(const ULog& u, int motors, std::vector<Channel>* channels) {
  if (const ULogTopic* b = u.Find("battery_status"); b != nullptr) {
    // PX4's battery_status: current_a is -1 where the monitor has no current ("-1 if unknown")
    channels->push_back({b, "batt", {{"current_A", [b](size_t i) {
                                        const double a = b->Get(i, "current_a");
                                        return a == kCurrentUnknown_A ? std::numeric_limits<double>::quiet_NaN() : a;
                                      }},
                                     {"voltage_V", [b](size_t i) { return b->Get(i, "voltage_v"); }}}, nullptr});
  }
  if (Channel c = MotorOutputs(u, motors); c.topic != nullptr) channels->push_back(std::move(c));
  if (const ULogTopic* th = u.Find("vehicle_thrust_setpoint"); th != nullptr && th->Has("xyz[2]")) {
    channels->push_back({th, "ctun", {{"control_u", [th](size_t i) { return -1000.0 * th->Get(i, "xyz[2]"); }}}, nullptr});
  } else if (const ULogTopic* ac = u.Find("actuator_controls_0"); ac != nullptr && ac->Has("control[3]")) {
    channels->push_back({ac, "ctun", {{"control_u", [ac](size_t i) { return 1000.0 * ac->Get(i, "control[3]"); }}}, nullptr});
  }
}

// The navigation side: the estimator's local position and velocity, the barometric altitude, and
// the GPS (3-D fixes only).
void AddNavigationChannels(const ULog& u, std::vector<Channel>* channels) {
  if (const ULogTopic* lp = u.Find("vehicle_local_position"); lp != nullptr) {
    Channel c{lp, "ekf", {}, nullptr};
    const std::pair<const char*, const char*> m[6] = {{"N_m", "x"},   {"E_m", "y"},   {"D_m", "z"},
                                                      {"N_mps", "vx"}, {"E_mps", "vy"}, {"D_mps", "vz"}};
    for (const auto& [suffix, field] : m) {
      const std::string f = field, kind = std::string(suffix).find("mps") != std::string::npos ? "vel_" : "pos_";
      c.columns.push_back({kind + suffix, [lp, f](size_t i) { return lp->Get(i, f); }});
      c.columns.push_back({"est_" + kind + suffix, [lp, f](size_t i) { return lp->Get(i, f); }});
    }
    channels->push_back(std::move(c));
  }
  const ULogTopic* air = u.Find("vehicle_air_data");
  if (air == nullptr || !air->Has("baro_alt_meter")) air = u.Find("sensor_combined");
  if (air != nullptr && air->Has("baro_alt_meter")) {
    channels->push_back({air, "baro", {{"baro_alt_m", [air](size_t i) { return air->Get(i, "baro_alt_meter"); }}}, nullptr});
  }
  if (const ULogTopic* g = u.Find("vehicle_gps_position"); g != nullptr && g->Has("vel_n_m_s")) {
    Channel c{g, "gps", {}, [g](size_t i) { return g->Get(i, "fix_type") >= kGps3dFix; }};
    c.columns.push_back({"lat_deg", [g](size_t i) { return GpsLatDeg(*g, i); }, false});
    c.columns.push_back({"lon_deg", [g](size_t i) { return GpsLonDeg(*g, i); }, false});
    c.columns.push_back({"alt_m", [g](size_t i) { return GpsAltM(*g, i); }, false});
    for (const char* axis : {"N", "E", "D"}) {
      const std::string f = fmt::format("vel_{}_m_s", static_cast<char>(std::tolower(axis[0])));
      c.columns.push_back({fmt::format("gps_vel_{}_mps", axis), [g, f](size_t i) { return g->Get(i, f); }});
    }
    channels->push_back(std::move(c));
  }
}

// Place and date for the Earth-field model (gap diagnose): the first 3-D fix, as for DataFlash.
void WriteLocation(const ULog& u, nlohmann::json* meta) {
  const ULogTopic* g = u.Find("vehicle_gps_position");
  if (g == nullptr || !g->Has("fix_type")) return;
  for (size_t i = 0; i < g->records.size(); ++i) {
    if (!(g->Get(i, "fix_type") >= kGps3dFix)) continue;
    const double lat = GpsLatDeg(*g, i), lon = GpsLonDeg(*g, i), alt = GpsAltM(*g, i);
    if (!(std::fabs(lat) <= 90) || !(std::fabs(lon) <= 180) || (lat == 0 && lon == 0)) continue;
    (*meta)["location"] = {{"lat_deg", lat}, {"lon_deg", lon}, {"alt_m", alt}, {"source", "first GPS 3-D fix (vehicle_gps_position)"}};
    const double utc_s = g->Has("time_utc_usec") ? 1e-6 * g->Get(i, "time_utc_usec") : 0.0;
    if (utc_s > 1.0e9) {  // after 2001: a real UTC time, not an unset 0
      (*meta)["date_decimal_year"] = DecimalYearFromUnix(utc_s);
      (*meta)["date_utc"] = IsoUtcFromUnix(utc_s);
    }
    return;
  }
}

// What the import found besides the table, for the meta.
struct ImportFacts {
  const std::vector<double>* row_t = nullptr;
  int motors = 4;
  const ArmedState* armed = nullptr;
  PowerCompensation compensation;
  nlohmann::json compasses;
  size_t dropped = 0;
};

// The log's meta (hexsim.log_meta/1): source, firmware, rotors, the parameters identification
// reads, time span, compasses, armed state, power compensation, text messages, damage, warnings.
void WriteMeta(const ULog& u, const std::string& name, const ImportFacts& f, ULogImport* out) {
  FlightLog& log = out->log;
  nlohmann::json& meta = log.meta;
  WriteLocation(u, &meta);
  meta["schema"] = "hexsim.log_meta/1";
  meta["source"] = name;
  meta["format"] = "px4-ulog";
  meta["ulog_version"] = u.version;
  meta["firmware"] = u.info.count("ver_sw") != 0 ? u.info.at("ver_sw") : "";
  meta["vehicle_type"] = "px4";
  meta["motor_count"] = f.motors;
  meta["motor_count_source"] = u.params.count("CA_ROTOR_COUNT") != 0 ? "CA_ROTOR_COUNT" : "default (4)";
  // The parameters identification reads: the control allocator's rotor geometry (CA_ROTORn_PX/PY/KM,
  // KM > 0 for a counter-clockwise rotor), the airframe, the PWM range and the thrust model factor.
  nlohmann::json params = nlohmann::json::object();
  for (const auto& [k, v] : u.params) {
    for (const char* prefix : {"CA_ROTOR", "CA_AIRFRAME", "SYS_AUTOSTART", "PWM_MAIN_MIN", "PWM_MAIN_MAX", "THR_MDL_FAC",
                               "BAT_N_CELLS", "BAT1_N_CELLS"}) {
      if (k.rfind(prefix, 0) == 0) params[k] = v;
    }
  }
  meta["params"] = params;
  meta["rows"] = log.rows();
  meta["row_source"] = "vehicle_attitude";
  const std::vector<double>& row_t = *f.row_t;
  meta["time"] = {{"start_s", row_t.front()}, {"end_s", row_t.back()}, {"duration_s", row_t.back() - row_t.front()},
                  {"base", "seconds since autopilot boot"}};
  meta["attitude_source"] = "vehicle_attitude q: the autopilot's own attitude estimate";
  meta["compasses"] = f.compasses;
  meta["armed_source"] = f.armed->t_s.empty() ? "none (no actuator_armed or vehicle_status)" : f.armed->source;
  if (f.compensation.type != 0) {
    meta["px4_mag_power_compensation"] = {{"type", f.compensation.type},
                                          {"column", f.compensation.source.empty() ? "" : "px4_mag_power"},
                                          {"source", f.compensation.source}};
  }
  meta["compass_units"] = "uT (PX4 logs gauss: x100)";
  meta["messages_text"] = u.messages;
  meta["bytes_skipped"] = u.bytes_skipped;
  meta["bytes_damaged"] = u.bytes_damaged;
  if (u.bytes_damaged > 0) {
    out->warnings.push_back(fmt::format("{}: damaged: {} bytes in {} places hold no readable message ({:.2g} % of the "
                                        "file); each was skipped to the next sync message, its records are lost",
                                        name, u.bytes_damaged, u.damaged_runs,
                                        100.0 * static_cast<double>(u.bytes_damaged) / static_cast<double>(u.file_bytes)));
  }
  meta["stream_samples_dropped"] = f.dropped;
  if (u.bytes_skipped > 0) {
    out->warnings.push_back(fmt::format("{}: truncated: the file ends inside a record ({} bytes of it); everything before "
                                        "that imported",
                                        name, u.bytes_skipped));
  }
  meta["warnings"] = out->warnings;
  WriteCurrentCheck(CheckCurrentSensor(log), &meta);
  // The log's own strings (ver_sw, logged messages, warnings quoting names) are bytes, not always
  // UTF-8; JSON requires UTF-8, so invalid sequences become U+FFFD once, here, and every later
  // dump() of the meta succeeds (fuzz finding: an 0x80 byte in a logged message).
  meta = nlohmann::json::parse(meta.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
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
  ImportFacts facts;
  auto row_t = AttitudeRows(att, name, &log, &facts.dropped);
  if (!row_t.ok()) return row_t.status();
  facts.row_t = &*row_t;
  facts.compasses = nlohmann::json::array();
  std::vector<Channel> channels;
  if (const ULogTopic* imu = u.Find("sensor_combined"); imu != nullptr && imu->Has("gyro_rad[0]")) {
    Channel c{imu, "imu", {}, nullptr};
    Vec3(&c, "gyro", "_radps", {"gyro_rad[0]", "gyro_rad[1]", "gyro_rad[2]"}, 1.0);
    Vec3(&c, "accel", "_mps2", {"accelerometer_m_s2[0]", "accelerometer_m_s2[1]", "accelerometer_m_s2[2]"}, 1.0);
    channels.push_back(std::move(c));
  }
  const ArmedState armed = ArmedOf(u);  // outlives `channels` (the power signal reads it)
  facts.armed = &armed;
  Magnetometers(u, name, armed, &channels, &facts.compasses, &out.warnings);
  facts.compensation = AddPowerChannel(u, name, facts.compasses, armed, &channels, &out.warnings);
  facts.motors = MotorCount(u);
  AddPowerChannels(u, facts.motors, &channels);
  AddNavigationChannels(u, &channels);
  for (const auto& ch : channels) {
    // Columns added now are filled with NaN for every row so far (AddColumn), then held.
    const std::vector<size_t> recs = Usable(ch, &facts.dropped);
    if (recs.empty()) continue;
    Hold(ch, recs, &log, *row_t);
    if (!ch.stream.empty()) log.SetStream(ch.stream, StreamOf(ch, recs));
  }
  if (!armed.t_s.empty()) {
    const size_t col = log.AddColumn("armed");
    for (size_t r = 0; r < row_t->size(); ++r) log.MutableColumn(col)[r] = armed.At((*row_t)[r]);
  }
  WriteMeta(u, name, facts, &out);
  return out;
}

}  // namespace hexsim::logs
