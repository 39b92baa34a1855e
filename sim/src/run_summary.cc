#include "hexsim/sim/run_summary.h"

namespace hexsim::sim {

using nlohmann::json;

const char* RunStatusName(RunStatus status) {
  switch (status) {
    case RunStatus::kCompleted: return "completed";
    case RunStatus::kNotCompleted: return "not_completed";
    case RunStatus::kDiverged: return "diverged";
  }
  return "not_completed";
}

json ToJson(const RunSummary& s) {
  json j;
  j["schema"] = "hexsim.summary/1";
  j["status"] = RunStatusName(s.status);
  j["reason"] = s.reason;
  j["mission"] = s.mission;
  j["vehicle"] = s.vehicle;
  j["world"] = s.world;
  j["calibration"] = s.calibration;
  j["estimator"] = s.estimator;
  j["seed"] = s.seed;
  j["duration_s"] = s.duration_s;
  j["distance_m"] = s.distance_m;
  j["cross_track_m"] = {{"max", s.cross_track_m.max}, {"rms", s.cross_track_m.rms}};
  j["yaw_error_deg"] = {{"max", s.yaw_error_deg.max}, {"rms", s.yaw_error_deg.rms}};
  j["yaw_error_all_deg"] = {{"max", s.yaw_error_all_deg.max}, {"rms", s.yaw_error_all_deg.rms}};
  j["energy_Wh"] = s.energy_Wh;
  j["current_A"] = {{"max", s.current_max_A}, {"mean", s.current_mean_A}};
  j["current_limited_s"] = {{"esc", s.current_limited_esc_s}, {"battery", s.current_limited_battery_s}};
  j["mission_time_s"] = s.mission_time_s ? json(*s.mission_time_s) : json(nullptr);
  j["waypoints"] = json::array();
  for (const auto& w : s.waypoints) {
    j["waypoints"].push_back(
        {{"index", w.index}, {"arrival_error_m", w.arrival_error_m}, {"arrival_time_s", w.arrival_time_s}});
  }
  j["wall_s"] = s.wall_s;
  j["version"] = s.version;
  return j;
}

namespace {

// Reads document[/pointer] into *out; the first problem found is kept in *error.
class Reader {
 public:
  Reader(const json& doc, std::string source) : doc_(doc), source_(std::move(source)) {}

  template <class T>
  void Get(const char* pointer, T* out) {
    if (!error_.ok()) return;
    const json::json_pointer ptr(pointer);
    if (!doc_.contains(ptr)) {
      error_ = Status::BadInput(source_ + ": " + (pointer + 1) + ": missing");
      return;
    }
    try {
      *out = doc_.at(ptr).get<T>();
    } catch (const json::exception&) {
      error_ = Status::BadInput(source_ + ": " + (pointer + 1) + ": wrong type");
    }
  }
  void GetOptional(const char* pointer, std::optional<double>* out) {
    const json::json_pointer ptr(pointer);
    if (error_.ok() && doc_.contains(ptr) && doc_.at(ptr).is_null()) {
      out->reset();
      return;
    }
    double v = 0.0;
    Get(pointer, &v);
    *out = v;
  }
  void Fail(const std::string& what) {
    if (error_.ok()) error_ = Status::BadInput(source_ + ": " + what);
  }
  const Status& error() const { return error_; }

 private:
  const json& doc_;
  std::string source_;
  Status error_;
};

}  // namespace

Result<RunSummary> RunSummaryFromJson(const json& doc, const std::string& source) {
  if (!doc.is_object()) return Status::BadInput(source + ": not a JSON object");
  RunSummary s;
  Reader r(doc, source);
  std::string status;
  r.Get("/status", &status);
  if (status == "completed") {
    s.status = RunStatus::kCompleted;
  } else if (status == "not_completed") {
    s.status = RunStatus::kNotCompleted;
  } else if (status == "diverged") {
    s.status = RunStatus::kDiverged;
  } else {
    r.Fail("status: '" + status + "' is none of completed, not_completed, diverged");
  }
  r.Get("/reason", &s.reason);
  r.Get("/mission", &s.mission);
  r.Get("/vehicle", &s.vehicle);
  r.Get("/world", &s.world);
  r.Get("/calibration", &s.calibration);
  r.Get("/estimator", &s.estimator);
  r.Get("/seed", &s.seed);
  r.Get("/duration_s", &s.duration_s);
  r.Get("/distance_m", &s.distance_m);
  r.Get("/cross_track_m/max", &s.cross_track_m.max);
  r.Get("/cross_track_m/rms", &s.cross_track_m.rms);
  r.Get("/yaw_error_deg/max", &s.yaw_error_deg.max);
  r.Get("/yaw_error_deg/rms", &s.yaw_error_deg.rms);
  r.Get("/yaw_error_all_deg/max", &s.yaw_error_all_deg.max);
  r.Get("/yaw_error_all_deg/rms", &s.yaw_error_all_deg.rms);
  r.Get("/energy_Wh", &s.energy_Wh);
  r.Get("/current_A/max", &s.current_max_A);
  r.Get("/current_A/mean", &s.current_mean_A);
  r.GetOptional("/mission_time_s", &s.mission_time_s);
  if (doc.contains("current_limited_s")) {  // absent from summaries written before the limits
    r.Get("/current_limited_s/esc", &s.current_limited_esc_s);
    r.Get("/current_limited_s/battery", &s.current_limited_battery_s);
  }
  r.Get("/wall_s", &s.wall_s);
  r.Get("/version", &s.version);
  if (!r.error().ok()) return r.error();
  const json* wps = doc.contains("waypoints") ? &doc["waypoints"] : nullptr;
  if (!wps || !wps->is_array()) return Status::BadInput(source + ": waypoints: missing or not a list");
  for (size_t i = 0; i < wps->size(); ++i) {
    WaypointArrival w;
    Reader wr((*wps)[i], source + ": waypoints[" + std::to_string(i) + "]");
    wr.Get("/index", &w.index);
    wr.Get("/arrival_error_m", &w.arrival_error_m);
    wr.Get("/arrival_time_s", &w.arrival_time_s);
    if (!wr.error().ok()) return wr.error();
    s.waypoints.push_back(w);
  }
  return s;
}

}  // namespace hexsim::sim
