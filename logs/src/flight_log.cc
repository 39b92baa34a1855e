#include "hexsim/logs/flight_log.h"

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <filesystem>

#include <fmt/format.h>

#include "hexsim/common/atomic_file.h"

namespace hexsim::logs {

size_t FlightLog::AddColumn(const std::string& name) {
  auto it = index_.find(name);
  if (it != index_.end()) return it->second;
  const size_t idx = names_.size();
  names_.push_back(name);
  index_.emplace(name, idx);
  data_.emplace_back(rows_, kMissing);
  return idx;
}

int FlightLog::ColumnIndex(const std::string& name) const {
  auto it = index_.find(name);
  return it == index_.end() ? -1 : static_cast<int>(it->second);
}

void FlightLog::AppendRow() {
  for (auto& c : data_) c.push_back(kMissing);
  ++rows_;
}

void FlightLog::Reserve(size_t rows) {
  for (auto& c : data_) c.reserve(rows);
}

const std::vector<double>& FlightLog::Column(const std::string& name) const {
  const int idx = ColumnIndex(name);
  HEXSIM_CHECK(idx >= 0);
  return data_[static_cast<size_t>(idx)];
}

const FlightLog* FlightLog::Stream(const std::string& name) const {
  for (size_t i = 0; i < stream_names_.size(); ++i) {
    if (stream_names_[i] == name) return &streams_[i];
  }
  return nullptr;
}

void FlightLog::SetStream(const std::string& name, FlightLog stream) {
  stream.stream_names_.clear();
  stream.streams_.clear();
  for (size_t i = 0; i < stream_names_.size(); ++i) {
    if (stream_names_[i] == name) {
      streams_[i] = std::move(stream);
      return;
    }
  }
  stream_names_.push_back(name);
  streams_.push_back(std::move(stream));
}

namespace {
std::string CsvStem(const std::string& csv_path) {
  const std::string ext = ".csv";
  if (csv_path.size() >= ext.size() && csv_path.compare(csv_path.size() - ext.size(), ext.size(), ext) == 0) {
    return csv_path.substr(0, csv_path.size() - ext.size());
  }
  return csv_path;
}

std::string BaseName(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

// Median sample rate of a stream (1 / median Δt), NaN with fewer than two samples.
double MedianRate_hz(const FlightLog& s) {
  if (!s.Has("t_s") || s.rows() < 2) return std::numeric_limits<double>::quiet_NaN();
  const auto& t = s.Column("t_s");
  std::vector<double> dt;
  dt.reserve(t.size());
  for (size_t i = 1; i < t.size(); ++i) dt.push_back(t[i] - t[i - 1]);
  std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
  const double m = dt[dt.size() / 2];
  return m > 0 ? 1.0 / m : std::numeric_limits<double>::quiet_NaN();
}
}  // namespace

bool IsStreamName(const std::string& name) {
  constexpr size_t kMaxStreamName = 32;
  if (name.empty() || name.size() > kMaxStreamName) return false;
  return std::all_of(name.begin(), name.end(), [](char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_'; });
}

std::string StreamPathFor(const std::string& csv_path, const std::string& stream) {
  return CsvStem(csv_path) + "." + stream + ".csv";
}

std::string MetaPathFor(const std::string& csv_path) {
  const std::string ext = ".csv";
  if (csv_path.size() >= ext.size() && csv_path.compare(csv_path.size() - ext.size(), ext.size(), ext) == 0) {
    return csv_path.substr(0, csv_path.size() - ext.size()) + ".meta.json";
  }
  return csv_path + ".meta.json";
}

std::string FlightLogToCsv(const FlightLog& log) {
  std::string out;
  out.reserve(log.rows() * log.columns().size() * 10 + 256);
  for (size_t c = 0; c < log.columns().size(); ++c) {
    if (c) out += ',';
    out += log.columns()[c];
  }
  out += '\n';
  fmt::memory_buffer buf;
  for (size_t r = 0; r < log.rows(); ++r) {
    buf.clear();
    for (size_t c = 0; c < log.columns().size(); ++c) {
      if (c) buf.push_back(',');
      const double v = log.At(r, c);
      if (std::isfinite(v)) fmt::format_to(std::back_inserter(buf), "{}", v);
    }
    buf.push_back('\n');
    out.append(buf.data(), buf.size());
  }
  return out;
}

Status WriteFlightLog(const FlightLog& log, const std::string& path) {
  nlohmann::json meta = log.meta;
  if (!log.stream_names().empty()) {
    nlohmann::json listed = nlohmann::json::object();
    for (const std::string& name : log.stream_names()) {
      const FlightLog& s = *log.Stream(name);
      const std::string file = StreamPathFor(path, name);
      HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(file, FlightLogToCsv(s)));
      const double rate = MedianRate_hz(s);
      listed[name] = {{"file", BaseName(file)},
                      {"rows", s.rows()},
                      {"rate_hz", std::isfinite(rate) ? nlohmann::json(rate) : nlohmann::json(nullptr)},
                      {"columns", s.columns()}};
      if (s.meta.contains("source")) listed[name]["source"] = s.meta["source"];
    }
    meta["streams"] = listed;
  }
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(MetaPathFor(path), meta.dump(2) + "\n"));
  return WriteFileAtomic(path, FlightLogToCsv(log));
}

namespace {
std::vector<std::string_view> SplitLine(std::string_view line) {
  std::vector<std::string_view> cells;
  size_t start = 0;
  while (true) {
    const size_t comma = line.find(',', start);
    if (comma == std::string_view::npos) {
      cells.push_back(line.substr(start));
      break;
    }
    cells.push_back(line.substr(start, comma - start));
    start = comma + 1;
  }
  return cells;
}
}  // namespace

Result<FlightLog> ParseFlightLogCsv(const std::string& text, const std::string& name) {
  FlightLog log;
  size_t pos = 0;
  size_t line_no = 0;
  bool header = true;
  size_t ncols = 0;
  std::string cell;
  std::vector<size_t> row_lines;  // file line of each data row, for messages
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    std::string_view line(text.data() + pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.empty()) continue;
    const auto cells = SplitLine(line);
    if (header) {
      for (const auto& c : cells) {
        const std::string col(c);
        if (col.empty()) return Status::BadInput(fmt::format("{}:{}: header: empty column name", name, line_no));
        for (const char ch : col) {
          const auto byte = static_cast<unsigned char>(ch);
          if (byte < 0x20 || byte == 0x7f) {
            return Status::BadInput(fmt::format("{}:{}: header: column name has control character 0x{:02x}", name,
                                                line_no, static_cast<unsigned>(byte)));
          }
        }
        if (log.Has(col)) return Status::BadInput(fmt::format("{}:{}: {}: duplicate column", name, line_no, col));
        log.AddColumn(col);
      }
      ncols = cells.size();
      header = false;
      continue;
    }
    if (cells.size() != ncols) {
      return Status::BadInput(fmt::format("{}:{}: row: expected {} cells, found {}", name, line_no, ncols, cells.size()));
    }
    log.AppendRow();
    row_lines.push_back(line_no);
    for (size_t c = 0; c < ncols; ++c) {
      if (cells[c].empty()) continue;
      cell.assign(cells[c]);
      char* endp = nullptr;
      errno = 0;
      const double v = std::strtod(cell.c_str(), &endp);
      if (endp != cell.c_str() + cell.size() || !std::isfinite(v)) {
        return Status::BadInput(fmt::format("{}:{}: {}: not a finite number: '{}'", name, line_no,
                                            log.columns()[c], cell.substr(0, 40)));
      }
      log.Set(c, v);
    }
  }
  if (header) return Status::BadInput(name + ": empty file (no header row)");
  if (!log.Has("t_s")) return Status::BadInput(name + ":1: t_s: required column is missing");
  if (log.rows() == 0) return Status::BadInput(name + ": no data rows");
  const auto& t = log.Column("t_s");
  for (size_t r = 0; r < log.rows(); ++r) {
    if (!std::isfinite(t[r])) return Status::BadInput(fmt::format("{}:{}: t_s: missing time", name, row_lines[r]));
    if (r > 0 && t[r] < t[r - 1]) {
      return Status::BadInput(fmt::format("{}:{}: t_s: time goes backwards ({} after {})", name, row_lines[r], t[r],
                                          t[r - 1]));
    }
  }
  return log;
}

Result<FlightLog> ReadFlightLog(const std::string& path) {
  auto text = ReadFile(path);
  if (!text.ok()) return text.status();
  auto log = ParseFlightLogCsv(*text, path);
  if (!log.ok()) return log;
  const std::string meta_path = MetaPathFor(path);
  std::error_code ec;
  if (std::filesystem::is_regular_file(meta_path, ec)) {
    auto meta_text = ReadFile(meta_path);
    if (!meta_text.ok()) return meta_text.status();
    try {
      log->meta = nlohmann::json::parse(*meta_text);
    } catch (const nlohmann::json::exception& e) {
      return Status::BadInput(meta_path + ": JSON: " + e.what());
    }
  }
  const auto streams = log->meta.find("streams");
  if (streams != log->meta.end() && streams->is_object()) {
    for (const auto& [name, entry] : streams->items()) {
      if (!IsStreamName(name)) {
        return Status::BadInput(fmt::format("{}: streams: '{}': a stream name is 1-32 of [a-z0-9_]", meta_path, name));
      }
      if (!std::filesystem::is_regular_file(StreamPathFor(path, name), ec)) continue;
      auto s = ReadStream(path, name);
      if (!s.ok()) return s.status();
      if (entry.is_object() && entry.contains("source")) s->meta["source"] = entry["source"];
      log->SetStream(name, std::move(*s));
    }
  }
  return log;
}

Result<FlightLog> ReadStream(const std::string& csv_path, const std::string& stream) {
  const std::string file = StreamPathFor(csv_path, stream);
  auto text = ReadFile(file);
  if (!text.ok()) return text.status();
  return ParseFlightLogCsv(*text, file);
}

}  // namespace hexsim::logs
