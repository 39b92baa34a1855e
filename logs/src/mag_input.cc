#include "hexsim/logs/mag_input.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <optional>

#include <Eigen/LU>
#include <fmt/format.h>

#include "hexsim/common/atomic_file.h"
#include "hexsim/logs/dataflash_import.h"
#include "hexsim/logs/dataflash_text.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/logs/ulog.h"
#include "hexsim/logs/ulog_import.h"

namespace hexsim::logs {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

bool ParseNumber(const std::string& s, double* v) {
  if (s.empty()) return false;
  char* end = nullptr;
  *v = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && std::isfinite(*v);
}

std::string Trim(const std::string& s) {
  size_t a = 0, b = s.size();
  while (a < b && std::isspace(static_cast<unsigned char>(s[a])) != 0) ++a;
  while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1])) != 0) --b;
  return s.substr(a, b - a);
}

std::vector<std::string> SplitFields(const std::string& line, char delim) {
  std::vector<std::string> out;
  if (delim == ' ') {
    size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i])) != 0) ++i;
      size_t j = i;
      while (j < line.size() && std::isspace(static_cast<unsigned char>(line[j])) == 0) ++j;
      if (j > i) out.push_back(line.substr(i, j - i));
      i = j;
    }
    return out;
  }
  size_t start = 0;
  for (size_t i = 0; i <= line.size(); ++i) {
    if (i == line.size() || line[i] == delim) {
      out.push_back(Trim(line.substr(start, i - start)));
      start = i + 1;
    }
  }
  return out;
}

// Lower-case letters and digits only: "Mag_X (uT)" → "magxut".
std::string Normalised(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (std::isalnum(static_cast<unsigned char>(c)) != 0) o += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  }
  return o;
}

// Whether a plain header name names axis `a` ("x", "mag_x", "mx", "magX", "x_raw", "Bx_uT", ...).
bool NamesAxis(const std::string& header, char a) {
  std::string n = Normalised(header);
  for (const char* suffix : {"ut", "mg", "nt", "gauss", "raw", "counts"}) {
    const std::string s(suffix);
    if (n.size() > s.size() && n.compare(n.size() - s.size(), s.size(), s) == 0) {
      n.resize(n.size() - s.size());
      break;
    }
  }
  for (const char* prefix : {"magnetometer", "compass", "magraw", "rawmag", "mag", "raw", "m", "b", "h"}) {
    const std::string p(prefix);
    if (n.size() == p.size() + 1 && n.compare(0, p.size(), p) == 0) {
      n = n.substr(p.size());
      break;
    }
  }
  return n.size() == 1 && n[0] == a;
}

struct Table {
  std::vector<std::string> header;  // empty: no header
  std::vector<std::vector<std::string>> rows;
  std::vector<size_t> line_of_row;
};

Result<Table> SplitTable(const std::string& text, const std::string& name) {
  Table t;
  char delim = 0;
  size_t line_no = 0, pos = 0;
  while (pos <= text.size()) {
    size_t nl = text.find('\n', pos);
    if (nl == std::string::npos) nl = text.size();
    std::string line = text.substr(pos, nl - pos);
    pos = nl + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::string trimmed = Trim(line);
    if (trimmed.empty() || trimmed[0] == '#') {
      if (nl == text.size()) break;
      continue;
    }
    if (delim == 0) delim = line.find(',') != std::string::npos ? ',' : line.find('\t') != std::string::npos ? '\t' : ' ';
    auto f = SplitFields(trimmed, delim);
    if (t.header.empty() && t.rows.empty()) {
      double v = 0.0;
      const bool numeric = std::all_of(f.begin(), f.end(), [&](const std::string& s) { return ParseNumber(s, &v); });
      if (!numeric) {
        t.header = f;
        continue;
      }
    }
    t.rows.push_back(std::move(f));
    t.line_of_row.push_back(line_no);
    if (nl == text.size()) break;
  }
  if (t.rows.empty()) return Status::BadInput(name + ": no data rows");
  return t;
}

int Find(const std::vector<std::string>& h, const std::string& col) {
  const auto it = std::find(h.begin(), h.end(), col);
  return it == h.end() ? -1 : static_cast<int>(it - h.begin());
}

// Undoes ArduPilot's corrections of compass `compass` when the meta describes them.
void UndoArduPilot(const nlohmann::json& meta, const std::string& compass, const std::vector<Vector3d>& mot_uT,
                   MagInput* in) {
  if (!meta.is_object() || meta.value("format", "") != "ardupilot-dataflash" || !meta.contains("compasses")) return;
  for (const auto& c : meta["compasses"]) {
    if (c.value("column", "") != compass) continue;
    auto vec = [&](const char* key, const Vector3d& fallback) {
      if (!c.contains(key) || !c[key].is_array() || c[key].size() != 3) return fallback;
      return Vector3d(c[key][0].get<double>(), c[key][1].get<double>(), c[key][2].get<double>());
    };
    const Vector3d ofs_uT = vec("offsets_mG", Vector3d::Zero()) / 10.0;  // 1 µT = 10 mG
    Vector3d dia = vec("diagonals", Vector3d::Ones());
    const Vector3d odi = vec("offdiagonals", Vector3d::Zero());
    if (dia.isZero()) dia.setOnes();  // ArduPilot treats all-zero diagonals as identity
    Matrix3d M;
    M << dia(0), odi(0), odi(1), odi(0), dia(1), odi(2), odi(1), odi(2), dia(2);
    double scale = c.contains("scale") && c["scale"].is_number() ? c["scale"].get<double>() : 1.0;
    if (!(scale > 0.0)) scale = 1.0;
    const Matrix3d Minv = (M * scale).inverse();
    in->body_from_raw = M * scale;
    in->soft_iron_in_force = M;
    for (size_t i = 0; i < in->field.size(); ++i) {
      const Vector3d mot = i < mot_uT.size() ? mot_uT[i] : Vector3d::Zero();
      in->field[i] = Minv * (in->field[i] - mot) - ofs_uT;
    }
    in->prior_offset = -ofs_uT;
    in->notes.push_back(fmt::format(
        "ArduPilot log: raw field rebuilt from the logged one (COMPASS_OFS {:.1f},{:.1f},{:.1f} mG, DIA/ODI {}, motor "
        "offsets {}): the calibration is absolute",
        10 * ofs_uT(0), 10 * ofs_uT(1), 10 * ofs_uT(2), c["diagonals"].is_array() ? "inverted" : "not set (identity)",
        mot_uT.empty() ? "all zero" : "per sample"));
  }
}

// Brings compass `compass` of a PX4 log (meta as ulog_import.h writes it) to the reading PX4's
// CAL_MAGn offsets and scales act on: calibrated = R·S·(raw + P·comp − off) (ulog_mag_cal.h), so
//   u = raw + P·comp = S⁻¹·Rᵀ·calibrated + off     for a calibrated topic,
//   u = raw + P·comp                              for raw sensor_mag, P from the px4_mag_power column.
// PX4 keeps applying P·comp (CAL_MAG_COMP_TYP, CAL_MAGn_X/Y/ZCOMP; calibrate never writes them), so
// a fit of u gives parameters that are right with that compensation in force; a fit of raw alone
// would take the motors' field, which the compensation already removes, into the offset. With P = 0
// (disarmed on the ground, or no compensation) u is the raw reading. Either way the autopilot's slot
// and offset become the parameters' index and the prior.
void UndoPx4(const nlohmann::json& meta, const std::string& compass, const std::vector<double>& power, MagInput* in) {
  if (!meta.is_object() || meta.value("format", "") != "px4-ulog" || !meta.contains("compasses")) return;
  for (const auto& c : meta["compasses"]) {
    if (c.value("column", "") != compass || !c.contains("px4_calibration")) continue;
    const auto& p = c["px4_calibration"];
    auto vec = [&](const char* key) { return Vector3d(p[key][0].get<double>(), p[key][1].get<double>(), p[key][2].get<double>()); };
    const Vector3d off_uT = 100.0 * vec("offsets_G"), dia = vec("scales"), odi = vec("offdiagonals");
    const Vector3d comp_uT = 100.0 * vec("power_compensation");  // µT per unit of P
    const int comp_type = static_cast<int>(p.value("power_compensation_type", 0.0));
    Matrix3d S;
    S << dia(0), odi(0), odi(1), odi(0), dia(1), odi(2), odi(1), odi(2), dia(2);
    Matrix3d R;
    for (int k = 0; k < 9; ++k) R(k / 3, k % 3) = p["rotation_matrix"][static_cast<size_t>(k)].get<double>();
    const int slot = p["index"].get<int>();
    in->px4_index = slot;
    in->px4_comp_type = comp_type;
    in->px4_comp_G = comp_uT / 100.0;
    in->body_from_raw = R * S;
    in->soft_iron_in_force = S;
    in->prior_offset = off_uT;
    const bool comp_on = comp_type != 0 && !comp_uT.isZero();
    std::string comp_note;
    if (comp_on) {
      double p_max = 0.0;
      for (const double v : power) p_max = std::isfinite(v) ? std::max(p_max, std::fabs(v)) : p_max;
      comp_note = fmt::format(
          "; PX4 power compensation in force (CAL_MAG_COMP_TYP {}, CAL_MAG{}_X/Y/ZCOMP {:.4g},{:.4g},{:.4g} G, largest P "
          "{:.3g}{}): the fit is of raw + P·comp, what PX4's offsets act on, so keep those parameters",
          comp_type, slot, comp_uT(0) / 100, comp_uT(1) / 100, comp_uT(2) / 100, p_max,
          power.empty() ? ", no power signal in the log: P taken as 0" : "");
    }
    if (!c.value("calibrated", false)) {
      if (comp_on && power.size() == in->field.size()) {
        for (size_t i = 0; i < in->field.size(); ++i) {
          if (std::isfinite(power[i])) in->field[i] += power[i] * comp_uT;
        }
      }
      in->notes.push_back(fmt::format("PX4 log: raw sensor_mag, calibration slot CAL_MAG{} (matched by {}){}", slot,
                                      p["matched_by"].get<std::string>(), comp_note));
      continue;
    }
    if (!p["rotation_known"].get<bool>() || std::abs(S.determinant()) < 1e-6) continue;  // warned at import
    const Matrix3d undo = S.inverse() * R.transpose();
    for (auto& b : in->field) b = undo * b + off_uT;
    in->notes.push_back(fmt::format(
        "PX4 log: raw field rebuilt from the calibrated one with CAL_MAG{}_* (matched by {}; offsets {:.4f},{:.4f},{:.4f} G, "
        "rotation {}): the calibration is absolute{}",
        slot, p["matched_by"].get<std::string>(), off_uT(0) / 100, off_uT(1) / 100, off_uT(2) / 100,
        p["rotation"].get<double>(), comp_note));
  }
}

// A header table: the compass's FlightLog columns, or plain axis names.
Result<MagInput> FromHeaderTable(const Table& t, const std::string& name, const std::string& compass,
                                 const nlohmann::json& meta) {
  MagInput in;
  const auto& h = t.header;
  int ix = Find(h, compass + "_x_uT"), iy = Find(h, compass + "_y_uT"), iz = Find(h, compass + "_z_uT");
  const bool flightlog = ix >= 0 && iy >= 0 && iz >= 0;
  if (flightlog) {
    in.format = "flightlog";
    in.units = "uT";
  } else {
    in.format = "xyz";
    ix = iy = iz = -1;
    for (size_t k = 0; k < h.size(); ++k) {
      if (ix < 0 && NamesAxis(h[k], 'x')) ix = static_cast<int>(k);
      if (iy < 0 && NamesAxis(h[k], 'y')) iy = static_cast<int>(k);
      if (iz < 0 && NamesAxis(h[k], 'z')) iz = static_cast<int>(k);
    }
    if (ix < 0 || iy < 0 || iz < 0) {
      return Status::BadInput(fmt::format("{}:1: header: no {}_x_uT/{}_y_uT/{}_z_uT columns and no x, y, z column names",
                                          name, compass, compass, compass));
    }
  }
  const int iq[4] = {Find(h, "q_w"), Find(h, "q_x"), Find(h, "q_y"), Find(h, "q_z")};
  const bool has_q = flightlog && iq[0] >= 0 && iq[1] >= 0 && iq[2] >= 0 && iq[3] >= 0;
  const int irow_t = flightlog ? Find(h, "t_s") : -1;
  bool q_complete = has_q;
  const int it = Find(h, compass + "_t_s"), ic = Find(h, "control_u"), ii = Find(h, "current_A"),
            ia = Find(h, "angle_deg"), ip = Find(h, "plane"), ipw = Find(h, "px4_mag_power");
  const int im[3] = {Find(h, compass + "_mot_x_uT"), Find(h, compass + "_mot_y_uT"), Find(h, compass + "_mot_z_uT")};
  const bool has_mot = im[0] >= 0 && im[1] >= 0 && im[2] >= 0;
  std::vector<Vector3d> mot;
  std::vector<double> power;  // PX4's magnetometer power signal P, when the log has it
  double last_t = std::nan("");
  for (size_t r = 0; r < t.rows.size(); ++r) {
    const auto& f = t.rows[r];
    const size_t line = t.line_of_row[r];
    if (f.size() != h.size()) {
      return Status::BadInput(fmt::format("{}:{}: row: expected {} cells, found {}", name, line, h.size(), f.size()));
    }
    auto num = [&](int col, double* v) -> Status {
      if (!ParseNumber(f[static_cast<size_t>(col)], v)) {
        return Status::BadInput(fmt::format("{}:{}: {}: not a finite number: '{}'", name, line, h[static_cast<size_t>(col)],
                                            f[static_cast<size_t>(col)]));
      }
      return Status::Ok();
    };
    // A FlightLog row before the compass's first sample has empty cells; later rows repeat a held sample.
    if (flightlog && f[static_cast<size_t>(ix)].empty()) continue;
    double sample_t = std::nan("");
    if (it >= 0) {
      double ts = 0.0;
      if (!ParseNumber(f[static_cast<size_t>(it)], &ts)) continue;
      if (ts == last_t) continue;
      last_t = ts;
      sample_t = ts;
    } else if (irow_t >= 0) {
      ParseNumber(f[static_cast<size_t>(irow_t)], &sample_t);
    }
    if (has_q) {
      Eigen::Vector4d q(std::nan(""), 0, 0, 0);
      for (int k = 0; k < 4; ++k) {
        if (!ParseNumber(f[static_cast<size_t>(iq[k])], &q(k))) q(k) = std::nan("");
      }
      q_complete = q_complete && q.allFinite() && q.norm() > 0.5;
      in.q_wxyz.push_back(q);
    }
    if (std::isfinite(sample_t)) in.t_s.push_back(sample_t);
    Vector3d b;
    HEXSIM_RETURN_IF_ERROR(num(ix, &b(0)));
    HEXSIM_RETURN_IF_ERROR(num(iy, &b(1)));
    HEXSIM_RETURN_IF_ERROR(num(iz, &b(2)));
    in.field.push_back(b);
    auto opt = [&](int col, std::vector<double>* v) -> Status {
      if (col < 0) return Status::Ok();
      double x = 0.0;
      if (f[static_cast<size_t>(col)].empty()) x = std::nan("");
      else HEXSIM_RETURN_IF_ERROR(num(col, &x));
      v->push_back(x);
      return Status::Ok();
    };
    HEXSIM_RETURN_IF_ERROR(opt(ic, &in.control_u));
    HEXSIM_RETURN_IF_ERROR(opt(ii, &in.current_A));
    HEXSIM_RETURN_IF_ERROR(opt(ia, &in.angle_deg));
    HEXSIM_RETURN_IF_ERROR(opt(ipw, &power));
    if (ip >= 0) in.plane.push_back(f[static_cast<size_t>(ip)]);
    if (has_mot) {
      Vector3d m = Vector3d::Zero();
      for (int k = 0; k < 3; ++k) {
        if (!f[static_cast<size_t>(im[k])].empty()) HEXSIM_RETURN_IF_ERROR(num(im[k], &m(k)));
      }
      mot.push_back(m);
    }
  }
  if (in.field.empty()) return Status::BadInput(fmt::format("{}: {}: no samples (the column is empty)", name, compass + "_x_uT"));
  if (!q_complete) in.q_wxyz.clear();
  if (in.t_s.size() != in.field.size()) in.t_s.clear();
  if (meta.is_object() && meta.contains("location") && meta["location"].is_object() && meta.contains("date_decimal_year") &&
      meta["date_decimal_year"].is_number()) {
    const auto& loc = meta["location"];
    if (loc.contains("lat_deg") && loc["lat_deg"].is_number() && loc.contains("lon_deg") && loc["lon_deg"].is_number()) {
      in.has_place = true;
      in.lat_deg = loc["lat_deg"].get<double>();
      in.lon_deg = loc["lon_deg"].get<double>();
      in.alt_m = loc.contains("alt_m") && loc["alt_m"].is_number() ? loc["alt_m"].get<double>() : 0.0;
      in.decimal_year = meta["date_decimal_year"].get<double>();
    }
  }
  in.notes.push_back(fmt::format("{}: {} {} samples ({}{})", name, in.field.size(), flightlog ? compass : "x,y,z",
                                 flightlog ? "FlightLog CSV" : "plain columns with a header",
                                 it >= 0 ? ", one per new " + compass + "_t_s" : ""));
  UndoArduPilot(meta, compass, mot, &in);
  UndoPx4(meta, compass, power, &in);
  return in;
}

Result<MagInput> FromPlain(const Table& t, const std::string& name) {
  MagInput in;
  in.format = "xyz";
  for (size_t r = 0; r < t.rows.size(); ++r) {
    const auto& f = t.rows[r];
    if (f.size() != 3) {
      return Status::BadInput(fmt::format("{}:{}: row: expected 3 numbers x y z, found {} (give a header naming x, y, z)",
                                          name, t.line_of_row[r], f.size()));
    }
    Vector3d b;
    for (int k = 0; k < 3; ++k) ParseNumber(f[static_cast<size_t>(k)], &b(k));  // numeric: checked by SplitTable
    in.field.push_back(b);
  }
  in.notes.push_back(fmt::format("{}: {} plain x,y,z samples, no header", name, in.field.size()));
  return in;
}

// A compass the log has no columns of: why, where the import left it out (meta "compasses_absent").
Status NoSuchCompass(const FlightLog& log, const std::string& name, const std::string& compass) {
  if (log.meta.contains("compasses_absent") && log.meta["compasses_absent"].is_array()) {
    for (const auto& a : log.meta["compasses_absent"]) {
      if (a.is_object() && a.value("column", std::string()) == compass) {
        return Status::BadInput(fmt::format("{}: {}: {}", name, compass, a.value("why", std::string("absent"))));
      }
    }
  }
  return Status::BadInput(fmt::format("{}: {}: the log has no such compass", name, compass));
}

Result<MagInput> FromFlightLog(const FlightLog& log, const std::string& name, const std::string& compass) {
  // Re-use the header-table path on the log's own columns (cells as shortest round-trip text).
  // Only the columns FromHeaderTable reads (a log holds ~60; formatting them all dominated the time).
  Table t;
  std::vector<size_t> cols;
  for (size_t c = 0; c < log.columns().size(); ++c) {
    const std::string& h = log.columns()[c];
    const bool wanted = h.rfind(compass + "_", 0) == 0 || h == "t_s" || h == "q_w" || h == "q_x" || h == "q_y" ||
                        h == "q_z" || h == "control_u" || h == "current_A" || h == "angle_deg" || h == "plane" ||
                        h == "px4_mag_power";
    if (!wanted) continue;
    cols.push_back(c);
    t.header.push_back(h);
  }
  for (size_t r = 0; r < log.rows(); ++r) {
    std::vector<std::string> row;
    row.reserve(t.header.size());
    for (size_t c : cols) {
      const double v = log.At(r, c);
      row.push_back(std::isfinite(v) ? fmt::format("{}", v) : "");
    }
    t.rows.push_back(std::move(row));
    t.line_of_row.push_back(r + 2);
  }
  if (!log.Has(compass + "_x_uT")) return NoSuchCompass(log, name, compass);
  return FromHeaderTable(t, name, compass, log.meta);
}

// A binary log is read through its import: its first note says so instead of "FlightLog CSV".
void NameTheFormat(const std::string& format, MagInput* in) {
  if (in->notes.empty()) return;
  const std::string from = "(FlightLog CSV";
  const size_t at = in->notes.front().find(from);
  if (at != std::string::npos) in->notes.front().replace(at, from.size(), "(" + format);
}

}  // namespace

Result<MagInput> MagInputFromFlightLog(const FlightLog& log, const std::string& name, const std::string& compass) {
  if (CompassIndex(compass) < 0) return Status::BadInput(fmt::format("--compass: '{}': must be mag, mag2 or mag3", compass));
  return FromFlightLog(log, name, compass);
}

int CompassIndex(const std::string& compass) {
  if (compass == "mag") return 0;
  if (compass.size() == 4 && compass.compare(0, 3, "mag") == 0 && compass[3] >= '2' && compass[3] <= '9') {
    return compass[3] - '1';
  }
  return -1;
}

Result<MagInput> ParseMagInput(const std::string& bytes, const std::string& name, const std::string& compass,
                               const nlohmann::json& meta) {
  if (CompassIndex(compass) < 0) return Status::BadInput(fmt::format("--compass: '{}': must be mag, mag2 or mag3", compass));
  if (bytes.empty()) return Status::BadInput(name + ": empty file");
  if (IsDataFlashText(bytes)) {
    auto bin = DataFlashTextToBinary(bytes, name);
    if (!bin.ok()) return bin.status();
    return ParseMagInput(*bin, name, compass, meta);
  }
  if (bytes.size() >= 2 && static_cast<unsigned char>(bytes[0]) == 0xA3 && static_cast<unsigned char>(bytes[1]) == 0x95) {
    auto imp = ImportDataFlash(bytes, name);
    if (!imp.ok()) return imp.status();
    auto in = FromFlightLog(imp->log, name, compass);
    if (!in.ok()) return in.status();
    in->format = "dataflash";
    NameTheFormat("ArduPilot DataFlash log, imported", &*in);
    in->log = std::make_shared<const FlightLog>(std::move(imp->log));
    return in;
  }
  if (IsULog(bytes)) {
    auto imp = ImportULog(bytes, name);
    if (!imp.ok()) return imp.status();
    auto in = FromFlightLog(imp->log, name, compass);
    if (!in.ok()) return in.status();
    in->format = "ulog";
    NameTheFormat("PX4 ULog, imported", &*in);
    for (const auto& w : imp->warnings) in->notes.push_back("warning: " + w);
    in->log = std::make_shared<const FlightLog>(std::move(imp->log));
    return in;
  }
  if (bytes.find('\0') != std::string::npos) {
    return Status::BadInput(name + ": format: binary, but neither ArduPilot DataFlash nor PX4 ULog");
  }
  auto t = SplitTable(bytes, name);
  if (!t.ok()) return t.status();
  return t->header.empty() ? FromPlain(*t, name) : FromHeaderTable(*t, name, compass, meta);
}

Result<MagInput> ReadMagInput(const std::string& path, const std::string& compass) {
  // A FlightLog CSV is read once, as a FlightLog, and kept (the flight path needs its rows).
  if (path.size() > 4 && path.compare(path.size() - 4, 4, ".csv") == 0 && CompassIndex(compass) >= 0) {
    auto log = ReadFlightLog(path);
    if (log.ok() && log->Has("t_s") && !log->Has(compass + "_x_uT") &&
        (log->Has("mag_x_uT") || log->meta.contains("compasses_absent"))) {
      return NoSuchCompass(*log, path, compass);
    }
    if (log.ok() && log->Has(compass + "_x_uT") && log->Has("t_s")) {
      auto in = FromFlightLog(*log, path, compass);
      if (!in.ok()) return in.status();
      in->log = std::make_shared<const FlightLog>(std::move(*log));
      return in;
    }
  }
  auto bytes = ReadFile(path);
  if (!bytes.ok()) return bytes.status();
  nlohmann::json meta = nullptr;
  auto meta_text = ReadFile(MetaPathFor(path));
  if (meta_text.ok() && path.size() > 4 && path.compare(path.size() - 4, 4, ".csv") == 0) {
    meta = nlohmann::json::parse(*meta_text, nullptr, /*allow_exceptions=*/false);
    if (meta.is_discarded()) return Status::BadInput(MetaPathFor(path) + ": JSON: not valid");
  }
  return ParseMagInput(*bytes, path, compass, meta);
}

}  // namespace hexsim::logs
