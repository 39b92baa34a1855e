#include "dataflash_streams.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include <fmt/format.h>

#include "hexsim/logs/dataflash_plausibility.h"

namespace hexsim::logs::internal {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kUTPerGauss = 100.0;  // 1 G = 100 µT
constexpr double kUTPerMilliGauss = 0.1;
constexpr double kThrottleScale = 1000.0;  // control_u: 0..1000
constexpr int kGps3dFix = 3;
constexpr size_t kMaxOutputs = 14;  // RCOU C1..C14

// One stream's samples before they become a table.
struct Samples {
  std::vector<std::string> columns;
  std::vector<double> t, v;  // v: row-major, columns.size() per sample

  void Add(double t_s, const std::vector<double>& values) {
    t.push_back(t_s);
    for (size_t i = 0; i < columns.size(); ++i) v.push_back(i < values.size() ? values[i] : kNaN);
  }
  // Removes the columns without a single number (ArduPilot's "not available" NaN in every sample).
  void DropUnmeasured() {
    const size_t w = columns.size();
    std::vector<size_t> keep;
    for (size_t c = 0; c < w; ++c) {
      for (size_t i = 0; i < t.size(); ++i) {
        if (std::isfinite(v[i * w + c])) {
          keep.push_back(c);
          break;
        }
      }
    }
    if (keep.size() == w) return;
    std::vector<std::string> nc;
    std::vector<double> nv;
    nc.reserve(keep.size());
    nv.reserve(keep.size() * t.size());
    for (size_t c : keep) nc.push_back(columns[c]);
    for (size_t i = 0; i < t.size(); ++i) {
      for (size_t c : keep) nv.push_back(v[i * w + c]);
    }
    columns.swap(nc);
    v.swap(nv);
  }
  // The table, dropping samples with damaged time (see DataFlashStreams).
  FlightLog Table(size_t* dropped) const {
    FlightLog out;
    const size_t t_col = out.AddColumn("t_s");
    std::vector<size_t> cols;
    for (const auto& c : columns) cols.push_back(out.AddColumn(c));
    out.Reserve(t.size());
    double last = -std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < t.size(); ++i) {
      const bool spike = i + 1 < t.size() && t[i] > t[i + 1] && (i + 2 >= t.size() || t[i] > t[i + 2]);
      if (!std::isfinite(t[i]) || spike || t[i] < last) {
        ++*dropped;
        continue;
      }
      last = t[i];
      out.AppendRow();
      out.Set(t_col, t[i]);
      for (size_t k = 0; k < cols.size(); ++k) {
        const double x = v[i * cols.size() + k];
        out.Set(cols[k], std::isfinite(x) ? x : kMissing);
      }
    }
    return out;
  }
};

bool NameIs(const std::string& name, const char* base) {
  const size_t n = std::char_traits<char>::length(base);
  return name.compare(0, n, base) == 0 && (name.size() == n || name.size() == n + 1);
}

std::string Instanced(const char* base, int instance) {
  return instance == 0 ? std::string(base) : fmt::format("{}{}", base, instance + 1);
}

}  // namespace

int InstanceOf(const DataFlashMessage& m, const std::string& base) {
  for (const char* col : {"I", "Inst", "Instance", "C"}) {
    if (m.Has(col)) return static_cast<int>(m.GetRawInt(col));
  }
  if (m.name() == base) return 0;
  const std::string suffix = m.name().substr(base.size());
  if (suffix.size() == 1 && suffix[0] >= '2' && suffix[0] <= '9') return suffix[0] - '1';
  return -1;
}

double MagToMicroTesla(const DataFlashMessage& m, const char* field) {
  const int i = m.format().FieldIndex(field);
  if (i < 0) return kNaN;
  const double v = m.GetIndex(static_cast<size_t>(i));
  const std::string& unit = m.format().units[static_cast<size_t>(i)];
  if (unit == "Gauss" || unit == "G") return v * kUTPerGauss;
  if (unit == "mGauss" || unit == "mG") return v * kUTPerMilliGauss;
  return v * kUTPerMilliGauss;  // older logs without units: milligauss counts
}

int RcouField(const DataFlashFormat& format, size_t channel) {
  for (const char* prefix : {"C", "Ch", "Chan"}) {
    const int i = format.FieldIndex(fmt::format("{}{}", prefix, channel));
    if (i >= 0) return i;
  }
  return -1;
}

double GpsBootTime_s(const DataFlashMessage& m) {
  if (m.Has("TimeUS")) return m.BootTime_s();
  if (m.Has("T")) return static_cast<double>(m.GetRawInt("T")) * 1e-3;  // 3.3: TimeMS is GPS time of week
  if (m.Has("Week")) return kNaN;                                      // no boot time at all
  return m.BootTime_s();
}

std::vector<std::pair<std::string, FlightLog>> DataFlashStreams(std::string_view bytes, const MotorMapping& motors,
                                                                 size_t* dropped) {
  std::map<std::string, Samples> s;
  auto stream = [&](const std::string& name, std::initializer_list<const char*> cols) -> Samples& {
    Samples& x = s[name];
    if (x.columns.empty()) x.columns.assign(cols.begin(), cols.end());
    return x;
  };
  std::vector<size_t> rcou_fields;  // field index of each output channel present, in order
  DataFlashReader reader(bytes);
  DataFlashMessage m;
  RecordPlausibility plausibility;  // the same records as the table drops (dataflash_plausibility.h)
  while (reader.Next(&m)) {
    if (!plausibility.Accept(m)) continue;
    const std::string& name = m.name();
    if (NameIs(name, "IMU")) {
      const int inst = InstanceOf(m, "IMU");
      if (inst < 0 || inst > 2) continue;
      stream(Instanced("imu", inst), {"gyro_x_radps", "gyro_y_radps", "gyro_z_radps", "accel_x_mps2", "accel_y_mps2",
                                      "accel_z_mps2", "imu_temp_C"})
          .Add(m.BootTime_s(), {m.Get("GyrX"), m.Get("GyrY"), m.Get("GyrZ"), m.Get("AccX"), m.Get("AccY"),
                                m.Get("AccZ"), m.Has("Temp") ? m.Get("Temp") : m.Get("T")});
    } else if (NameIs(name, "MAG")) {
      const int inst = InstanceOf(m, "MAG");
      if (inst < 0 || inst > 2) continue;
      const std::string pre = Instanced("mag", inst);
      Samples& x = s[pre];
      if (x.columns.empty()) x.columns = {pre + "_x_uT", pre + "_y_uT", pre + "_z_uT"};
      x.Add(m.BootTime_s(), {MagToMicroTesla(m, "MagX"), MagToMicroTesla(m, "MagY"), MagToMicroTesla(m, "MagZ")});
    } else if (name == "CURR" || name == "BAT" || name == "BATT") {
      if (name != "CURR" && InstanceOf(m, name) > 0) continue;
      stream("batt", {"current_A", "voltage_V"}).Add(m.BootTime_s(), {m.Get("Curr"), m.Get("Volt")});
    } else if (name == "RCOU") {
      if (rcou_fields.empty()) {
        for (size_t i = 1; i <= kMaxOutputs; ++i) {
          const int f = RcouField(m.format(), i);
          if (f >= 0) rcou_fields.push_back(static_cast<size_t>(f));
        }
        if (rcou_fields.empty()) continue;
        Samples& x = s["rcou"];
        const size_t n = motors.motors > 0 ? std::min(motors.motors, rcou_fields.size()) : rcou_fields.size();
        for (size_t i = 0; i < n; ++i) x.columns.push_back(fmt::format("motor_{}_u", i + 1));
        for (size_t i = 0; i < rcou_fields.size(); ++i) x.columns.push_back(fmt::format("pwm_{}_us", i + 1));
      }
      Samples& x = s["rcou"];
      const size_t n_u = x.columns.size() - rcou_fields.size();
      std::vector<double> v(x.columns.size(), kNaN);
      for (size_t i = 0; i < rcou_fields.size(); ++i) {
        double pwm = m.GetIndex(rcou_fields[i]);
        if (!IsPlausiblePwm_us(pwm)) pwm = kNaN;  // an unused channel's garbage: absent
        v[n_u + i] = pwm;
        if (i < n_u && std::isfinite(pwm)) {
          v[i] = std::clamp((pwm - motors.pwm_min_us) / (motors.pwm_max_us - motors.pwm_min_us), 0.0, 1.0);
        }
      }
      x.Add(m.BootTime_s(), v);
    } else if (name == "BARO") {
      if (m.Has("I") && m.GetRawInt("I") != 0) continue;
      stream("baro", {"baro_alt_m"}).Add(m.BootTime_s(), {m.Get("Alt")});
    } else if (name == "GPS") {
      if ((m.Has("I") && m.GetRawInt("I") != 0) || m.GetRawInt("Status") < kGps3dFix) continue;
      const double lat = m.Get("Lat"), lon = m.Get("Lng");
      if (!(std::fabs(lat) <= 90) || !(std::fabs(lon) <= 180) || (lat == 0 && lon == 0)) continue;
      const double spd = m.Get("Spd"), crs = m.Get("GCrs") * M_PI / 180.0;
      stream("gps", {"lat_deg", "lon_deg", "alt_m", "gps_vel_N_mps", "gps_vel_E_mps", "gps_vel_D_mps"})
          .Add(GpsBootTime_s(m), {lat, lon, m.Get("Alt"), spd * std::cos(crs), spd * std::sin(crs), m.Get("VZ")});
    } else if (name == "XKF1" || name == "NKF1" || name == "EKF1") {
      if (m.Has("C") && m.GetRawInt("C") != 0) continue;
      stream(name, {"pos_N_m", "pos_E_m", "pos_D_m", "vel_N_mps", "vel_E_mps", "vel_D_mps"})
          .Add(m.BootTime_s(), {m.Get("PN"), m.Get("PE"), m.Get("PD"), m.Get("VN"), m.Get("VE"), m.Get("VD")});
    } else if (name == "CTUN") {
      const double u = m.Has("ThrOut") ? m.Get("ThrOut") : m.Get("ThO") * kThrottleScale;  // 3.x 0..1000; 3.4+ 0..1
      stream("ctun", {"control_u"}).Add(m.BootTime_s(), {u});
    }
  }
  // The EKF stream from the newest estimator the log has.
  for (const char* e : {"XKF1", "NKF1", "EKF1"}) {
    auto it = s.find(e);
    if (it == s.end()) continue;
    if (!s.count("ekf")) s["ekf"] = it->second;
  }
  if (auto it = s.find("batt"); it != s.end()) it->second.DropUnmeasured();  // a current never measured
  std::vector<std::pair<std::string, FlightLog>> out;
  for (const char* name : {"imu", "imu2", "imu3", "rcou", "batt", "baro", "gps", "mag", "mag2", "mag3", "ekf", "ctun"}) {
    auto it = s.find(name);
    if (it == s.end() || it->second.t.empty()) continue;
    FlightLog table = it->second.Table(dropped);
    if (table.rows() > 0) out.emplace_back(name, std::move(table));
  }
  return out;
}

}  // namespace hexsim::logs::internal
