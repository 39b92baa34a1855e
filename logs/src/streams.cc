// StreamAtOwnRate: a stream at its native rate from the log's streams or, failing that, from the
// distinct samples of the single table (see flight_log.h).
#include <cmath>

#include "hexsim/logs/flight_log.h"

namespace hexsim::logs {
namespace {

// The table's time column and value columns of a known stream; false for an unknown stream.
bool TableColumnsOf(const FlightLog& log, const std::string& stream, std::string* t_col, std::vector<std::string>* cols) {
  auto prefixed = [&](const std::string& pre, std::initializer_list<const char*> names) {
    for (const char* n : names) cols->push_back(pre + n);
  };
  if (stream == "imu") {
    *t_col = "imu_t_s";
    prefixed("", {"gyro_x_radps", "gyro_y_radps", "gyro_z_radps", "accel_x_mps2", "accel_y_mps2", "accel_z_mps2",
                  "imu_temp_C"});
  } else if (stream == "rcou") {
    *t_col = "rcou_t_s";
    for (const auto& c : log.columns()) {
      if (c.rfind("motor_", 0) == 0 && c.size() > 8 && c.compare(c.size() - 2, 2, "_u") == 0) cols->push_back(c);
    }
  } else if (stream == "batt") {
    *t_col = "batt_t_s";
    prefixed("", {"current_A", "voltage_V"});
  } else if (stream == "baro") {
    *t_col = "baro_t_s";
    prefixed("", {"baro_alt_m"});
  } else if (stream == "gps") {
    *t_col = "gps_t_s";
    prefixed("gps_", {"N_m", "E_m", "D_m", "vel_N_mps", "vel_E_mps", "vel_D_mps"});
  } else if (stream == "mag" || stream == "mag2" || stream == "mag3") {
    *t_col = stream + "_t_s";
    prefixed(stream, {"_x_uT", "_y_uT", "_z_uT"});
  } else if (stream == "ekf") {
    *t_col = "ekf_t_s";
    prefixed("", {"pos_N_m", "pos_E_m", "pos_D_m", "vel_N_mps", "vel_E_mps", "vel_D_mps"});
  } else if (stream == "ctun") {
    *t_col = "ctun_t_s";
    prefixed("", {"control_u"});
  } else {
    return false;
  }
  return true;
}

}  // namespace

FlightLog StreamAtOwnRate(const FlightLog& log, const std::string& stream, bool* from_table) {
  if (from_table) *from_table = false;
  if (const FlightLog* s = log.Stream(stream)) return *s;
  FlightLog out;
  std::string t_col;
  std::vector<std::string> cols;
  if (!TableColumnsOf(log, stream, &t_col, &cols) || !log.Has("t_s")) return out;
  std::vector<size_t> in, dst;
  const size_t t_out = out.AddColumn("t_s");
  for (const auto& c : cols) {
    if (!log.Has(c)) continue;
    in.push_back(static_cast<size_t>(log.ColumnIndex(c)));
    dst.push_back(out.AddColumn(c));
  }
  if (in.empty()) return out;
  if (from_table) *from_table = true;
  const std::vector<double>* ts = log.Has(t_col) ? &log.Column(t_col) : nullptr;
  const auto& t_row = log.Column("t_s");
  double last = -INFINITY;
  for (size_t r = 0; r < log.rows(); ++r) {
    const double t = ts ? (*ts)[r] : t_row[r];
    if (!std::isfinite(t) || t <= last) continue;  // the same held sample again, or none yet
    last = t;
    out.AppendRow();
    out.Set(t_out, t);
    for (size_t k = 0; k < in.size(); ++k) out.Set(dst[k], log.At(r, in[k]));
  }
  return out;
}

}  // namespace hexsim::logs
