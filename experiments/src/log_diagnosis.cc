#include "hexsim/experiments/log_diagnosis.h"

#include <algorithm>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "hexsim/common/paths.h"
#include "hexsim/gap/json.h"
#include "hexsim/identify/identify.h"
#include "hexsim/logs/mag_input.h"

namespace hexsim::experiments {
namespace {

// The number of motors the log drives: the import's motor_count, a hexsim log's rotors; 0 when unknown.
int LogMotorCount(const logs::FlightLog& log, std::string* source) {
  for (const char* key : {"motor_count", "rotors"}) {
    if (log.meta.is_object() && log.meta.contains(key) && log.meta[key].is_number_integer() && log.meta[key].get<int>() > 0) {
      *source = log.meta.value("motor_count_source", std::string(key));
      return log.meta[key].get<int>();
    }
  }
  return 0;
}

// Fills the vehicle part of `d`: as given (compared with the one identified from the whole log), or
// identified on the even blocks with d->log reduced to the odd (held-out) blocks.
Status ChooseVehicle(const LogDiagnosisOptions& o, logs::FlightLog* log, LogDiagnosis* d) {
  auto base = identify::ChooseBaseVehicle(*log, o.vehicle, "auto", o.log_name, "give --sim VEHICLE");
  if (!base.ok()) return base.status();
  // A --sim vehicle of another rotor count: its wiring, motor lags and mixer are per rotor while the
  // log drives its own motors, so the replay would compare another airframe (identify refuses such a
  // base the same way).
  std::string motors_from;
  const int motors = LogMotorCount(*log, &motors_from);
  if (!o.vehicle.empty() && motors > 0 && static_cast<size_t>(motors) != base->params.rotors.size()) {
    std::string frame_source;
    const std::string like = identify::DefaultBaseFor(identify::FrameOfLog(*log, &frame_source));
    return Status::BadInput(fmt::format("{}: --sim: '{}' has {} rotors, the log drives {} motors ({}): give a vehicle "
                                        "with {} rotors{}",
                                        o.log_name, base->params.name, base->params.rotors.size(), motors, motors_from,
                                        motors, like.empty() ? "" : " (e.g. " + like + ")"));
  }
  // Without --sim the base's wiring is hexsim's airframe's, not this one's: each compass is compared
  // with no modelled current field, so its gap is the log's whole current field (= the absolute term).
  if (o.vehicle.empty()) HEXSIM_RETURN_IF_ERROR(identify::DropWiring(&base->params, &base->yaml));
  d->vehicle = base->params;
  d->vehicle_yaml = base->yaml;
  d->stem = FileStem(base->path);
  if (!o.vehicle.empty()) {
    auto r = identify::Identify(*log, base->params);
    d->vehicle_source["mode"] = "given (--sim)";
    d->vehicle_source["distance_from_identified"] =
        r.ok() ? identify::DistanceFromVehicle(*r, base->params, &d->lines)
               : nlohmann::json("not computed: " + r.status().message());
    return Status::Ok();
  }
  d->lines.push_back("frame " + base->frame + " (" + base->frame_source + "): base " + base->params.name);
  d->vehicle_source["wiring"] = "none: the base's wiring layout is not this airframe's; the compasses are compared "
                                "with no modelled current field";
  d->lines.push_back("no --sim: " + base->params.name + "'s wiring is not this airframe's: the compasses are compared "
                     "with no modelled current field (the log's current field is reported whole)");
  identify::IdentifyOptions io;
  for (int b = 0; b < io.blocks; b += 2) io.fit_blocks.push_back(b);
  auto r = identify::Identify(*log, base->params, io);
  if (!r.ok() && r.status().code() == StatusCode::kBadInput) {
    // A log too short (or without the streams) for identification is not bad input for the diagnosis
    // (CONTRACTS: diagnose what can be diagnosed): the whole log against the base vehicle, said so.
    d->vehicle_source["mode"] = "base (identification not possible)";
    d->vehicle_source["why"] = r.status().message();
    d->lines.push_back("no --sim, and the vehicle could not be identified from this log (" + r.status().message() +
                       "): diagnosed against the shipped " + base->params.name + " on the whole log");
    return Status::Ok();
  }
  if (!r.ok()) return r.status().WithContext("gap diagnose without --sim identifies the vehicle first");
  if (!r->improves_on_base) {
    // An identification that improves nothing is not used: the whole log against the base, said so.
    d->vehicle_source["mode"] = "base (identification improves nothing)";
    d->vehicle_source["why"] = identify::ImprovementLine(*r);
    d->vehicle_source["identify"] = identify::ToJson(*r);
    d->lines.push_back("no --sim: the identification " + identify::ImprovementLine(*r) +
                       "; diagnosed against the shipped " + base->params.name + " on the whole log");
    return Status::Ok();
  }
  d->vehicle = identify::ApplyIdentified(base->params, *r);
  auto yaml = identify::IdentifiedVehicleYaml(base->yaml, base->params, *r);
  if (!yaml.ok()) return yaml.status();
  d->vehicle_yaml = *yaml;
  d->stem = "identified";
  d->identified = true;
  *log = identify::HeldOutLog(*log, *r);
  d->vehicle_source["mode"] = "identified (no --sim)";
  d->vehicle_source["how"] = "vehicle identified from this log (base " + base->params.name +
                             ") on the even time blocks of its flight windows; gyro, accel and dynamics diagnosed on the "
                             "odd (held-out) blocks only, the compasses on every block (their replay uses the log's "
                             "attitude, current and motor outputs and the compasses' configuration, nothing identified)";
  d->vehicle_source["identify"] = identify::ToJson(*r);
  d->lines.push_back("no --sim: the vehicle was identified from this log (base " + base->params.name +
                     ") on the even time blocks; the gyro, accel and dynamics channels use the odd (held-out) blocks "
                     "only, the compasses every block (their replay uses nothing the identification fits)");
  return Status::Ok();
}

// The channels each part of an identified-vehicle diagnosis reads. The vehicle is identified on the
// even blocks, so a channel whose replay uses what was identified (thrust, drag, motor lags, battery:
// the dynamics; the IMU channels share its windows) is diagnosed on the odd blocks only. A compass's
// replay uses the log's attitude, current and motor outputs and the compass's own configuration,
// none of it identified: it is diagnosed on every block, twice the data the held-out half gives (a
// current field resolved on the whole flight and not on its half was left undecided).
const std::vector<std::string> kHeldOutChannels = {"gyro", "accel", "dynamics"};
// The log's compass channels: the prefixes of its "<prefix>_x_uT" columns that name a compass.
std::vector<std::string> CompassChannels(const logs::FlightLog& log) {
  const std::string suffix = "_x_uT";
  std::vector<std::string> names;
  for (const std::string& col : log.columns()) {
    if (col.size() <= suffix.size() || col.compare(col.size() - suffix.size(), suffix.size(), suffix) != 0) continue;
    const std::string prefix = col.substr(0, col.size() - suffix.size());
    if (logs::CompassIndex(prefix) >= 0) names.push_back(prefix);
  }
  return names;
}

// The whole log's compass channels with the held-out diagnosis's gyro, accel and dynamics.
gap::GapReport MergeHeldOut(gap::GapReport whole, gap::GapReport held_out) {
  for (gap::ChannelResult& c : whole.channels) {
    if (c.absolute_terms) {
      c.absolute_terms->held_out = "absolute terms and candidates fitted on every flight block (as hexsim calibrate; the "
                                   "compass replay uses nothing the identification fits); the vehicle was identified on "
                                   "the even blocks, and gyro, accel and dynamics are diagnosed on the odd ones only";
    }
  }
  for (gap::ChannelResult& c : held_out.channels) whole.channels.push_back(std::move(c));
  for (auto& nd : held_out.not_diagnosed) whole.not_diagnosed.push_back(std::move(nd));
  for (std::string& e : held_out.effects_not_built) {
    if (std::find(whole.effects_not_built.begin(), whole.effects_not_built.end(), e) == whole.effects_not_built.end()) {
      whole.effects_not_built.push_back(std::move(e));
    }
  }
  return whole;
}

}  // namespace

Result<LogDiagnosis> DiagnoseLog(const logs::FlightLog& log, const LogDiagnosisOptions& o) {
  if (log.rows() == 0) return Status::BadInput(o.log_name + ": no data rows");
  LogDiagnosis d;
  logs::FlightLog diagnosed = log;
  HEXSIM_RETURN_IF_ERROR(ChooseVehicle(o, &diagnosed, &d));
  gap::DiagnoseOptions opt;
  opt.seed = o.seed;
  opt.threads = o.threads;
  opt.compass_model_log = &log;
  if (o.from_s != 0.0 || o.to_s != 0.0) {
    if (!(o.to_s > o.from_s)) return Status::BadInput("--from/--to: --to must be after --from");
    opt.from_s = o.from_s;
    opt.to_s = o.to_s;
  }
  if (d.identified) opt.channels = kHeldOutChannels;
  auto report = gap::Diagnose(diagnosed, d.vehicle, opt);
  if (!report.ok()) return report.status().WithContext(o.log_name);
  d.report = std::move(report).value();
  const std::vector<std::string> compasses = d.identified ? CompassChannels(log) : std::vector<std::string>{};
  if (!compasses.empty()) {  // (an empty list would mean every channel)
    gap::DiagnoseOptions whole_opt = opt;
    whole_opt.channels = compasses;
    whole_opt.compass_model_log = nullptr;
    auto whole = gap::Diagnose(log, d.vehicle, whole_opt);
    if (!whole.ok()) return whole.status().WithContext(o.log_name);
    d.report = MergeHeldOut(std::move(whole).value(), std::move(d.report));
  }
  d.report.log_name = o.log_name;
  auto updated = gap::UpdatedVehicleYaml(d.vehicle_yaml, d.vehicle, d.report);
  if (!updated.ok()) return updated.status();
  d.updated_yaml = *updated;
  return d;
}

nlohmann::json LogDiagnosisJson(const LogDiagnosis& d) {
  nlohmann::json j = gap::ToJson(d.report);
  j["vehicle_source"] = d.vehicle_source;
  return j;
}

}  // namespace hexsim::experiments
