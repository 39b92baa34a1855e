#include "hexsim/experiments/compare.h"

#include <cstdio>
#include <map>
#include <set>

#include <fmt/format.h>

#include "hexsim/batch/pool.h"
#include "hexsim/control/sequencer.h"
#include "hexsim/experiments/ground_calibration.h"
#include "hexsim/experiments/point_runner.h"
#include "hexsim/sim/turntable.h"

namespace hexsim::experiments {

using nlohmann::json;

namespace {
constexpr int kMaxSeeds = 1000;
}  // namespace

Status CompareOptions::IsValid() const {
  if (seeds < 1 || seeds > kMaxSeeds) return Status::BadInput(fmt::format("--seeds: must be in 1..1000 (got {})", seeds));
  if (calibrations.empty()) return Status::BadInput("--calibrations: at least one");
  std::set<std::string> seen;
  for (const auto& c : calibrations) {
    if (!seen.insert(c).second) return Status::BadInput("--calibrations: '" + c + "' listed twice");
    if (!IsCalibrationMethod(c) && c.find(".yaml") == std::string::npos) {
      return Status::BadInput("--calibrations: unknown calibration '" + c + "'");
    }
  }
  if (jobs < 1) return Status::BadInput("--jobs: must be at least 1");
  return Status::Ok();
}

namespace {

std::string RunDir(const std::string& calibration, uint64_t seed) {
  return fmt::format("{}/seed_{}", calibration, seed);
}

// The planned path from the first flight's start (the vehicle at rest), as the report draws it.
std::optional<std::vector<Eigen::Vector3d>> PlannedPath(const sim::RunSetup& setup, const logs::FlightLog& log) {
  if (!log.Has("pos_N_m") || !log.Has("pos_D_m") || log.rows() == 0) return std::nullopt;
  const Eigen::Vector3d start(log.Column("pos_N_m")[0], log.Column("pos_E_m")[0], log.Column("pos_D_m")[0]);
  if (!start.allFinite()) return std::nullopt;
  return control::PlannedPath(setup.mission, start, start.z());
}

}  // namespace

Result<CompareResult> RunComparison(const CompareOptions& o, const std::string& out_dir) {
  HEXSIM_RETURN_IF_ERROR(o.IsValid());
  auto base = sim::LoadRunSetup(o.request);
  if (!base.ok()) return base.status();
  // The first seed's ground session: every calibration of Table 1 is learnt from it, as the first
  // seed's flights learn theirs (each worker runs its own seed's session: GroundSessionSeed).
  auto ground = RunGroundSession(base->vehicle, base->world, o.request.seed);
  if (!ground.ok()) return ground.status();
  std::vector<GroundCalibration> cals;
  // Each run is filed, grouped and shown under its calibration's name (a calib.yaml's stem).
  std::map<std::string, std::string> name_of;
  for (const auto& c : o.calibrations) {
    auto cal = MakeCalibration(c, *ground);
    if (!cal.ok()) return cal.status();
    cal->requested = c;
    for (const auto& [other, name] : name_of) {
      if (name == cal->name && other != c) {
        return Status::BadInput(fmt::format("--calibrations: '{}' and '{}' are both named '{}'", other, c, name));
      }
    }
    name_of[c] = cal->name;
    cals.push_back(std::move(*cal));
  }

  std::vector<batch::RunPoint> points;
  for (const auto& c : o.calibrations) {
    for (int s = 0; s < o.seeds; ++s) {
      batch::RunPoint p;
      p.mission = base->mission_name;
      p.vehicle = base->vehicle_name;
      p.world = base->world_name;
      p.calibration = c;
      p.seed = o.request.seed + static_cast<uint64_t>(s);
      points.push_back(p);
    }
  }
  batch::PoolOptions pool;
  pool.jobs = o.jobs;
  pool.out_dir = out_dir;
  pool.progress_stream = nullptr;  // one line per run below instead
  pool.run_dir = [&out_dir, &name_of](const batch::RunPoint& p) {
    return out_dir + "/" + RunDir(name_of.at(p.calibration), p.seed);
  };
  // Each flight runs in a forked worker (batch/pool.h: a crash or a runaway stays in its process):
  // the pool hands its summary back typed and, for the figures, each calibration's first-seed flight.
  pool.return_log = [&o](const batch::RunPoint& p) { return o.evidence && p.seed == o.request.seed; };
  const batch::RunFn fly = [&o, &pool](const batch::RunPoint& p) -> Result<json> {
    sim::RunRequest req = o.request;
    req.seed = p.seed;
    auto setup = sim::LoadRunSetup(req);
    if (!setup.ok()) return setup.status();
    auto run = FlyPoint(std::move(*setup), p.calibration);
    if (!run.ok()) return run.status();
    HEXSIM_RETURN_IF_ERROR(WriteRunLog(*run, pool.run_dir(p)));
    return sim::ToJson(run->summary);
  };
  // Keyed by run id: a row's calibration is the summary's name for it (a calib.yaml path becomes
  // its stem), not necessarily the point's.
  std::map<std::string, sim::RunSummary> summaries;
  std::map<std::string, logs::FlightLog> flights;
  std::vector<std::string> failures;
  const batch::RecordFn record = [&](const batch::RunRow& row, batch::RunResult* r) {
    if (batch::IsFailure(row.status) && row.status != "diverged") {
      failures.push_back(fmt::format("{} seed {}: {}: {}", row.calibration, row.seed, row.status, row.reason));
      return Status::Ok();
    }
    if (r == nullptr) {
      failures.push_back(fmt::format("{} seed {}: no summary", row.calibration, row.seed));
      return Status::Ok();
    }
    const sim::RunSummary& s = r->summary;
    std::fprintf(stderr, "compare: %-17s seed %-4llu %-13s yaw max %6.2f deg  cross-track rms %5.2f m\n",
                 row.calibration.c_str(), static_cast<unsigned long long>(row.seed), sim::RunStatusName(s.status),
                 s.yaw_error_deg.max, s.cross_track_m.rms);
    summaries[row.run_id] = s;
    if (r->log) flights[row.run_id] = std::move(*r->log);
    return Status::Ok();
  };
  auto stats = batch::RunPool(points, fly, pool, record);
  if (!stats.ok()) return stats.status();
  if (!failures.empty()) return Status::Numerical("compare: " + failures.front());

  CompareResult out;
  Comparison& cmp = out.comparison;
  cmp.mission = base->mission_name;
  cmp.vehicle = base->vehicle_name;
  cmp.world = base->world_name;
  cmp.estimator = base->options.estimator;
  for (const auto& p : points) {
    const auto it = summaries.find(p.RunId());
    if (it == summaries.end()) return Status::Numerical(fmt::format("compare: {} seed {}: no result", p.calibration, p.seed));
    const std::string& name = name_of.at(p.calibration);
    cmp.runs.push_back({name, p.seed, it->second, RunDir(name, p.seed)});
  }
  for (const auto& c : o.calibrations) {
    std::vector<sim::RunSummary> sums;
    for (const auto& r : cmp.runs) {
      if (r.calibration == name_of.at(c)) sums.push_back(r.summary);
    }
    cmp.groups.push_back({name_of.at(c), sums.size(), GroupMetrics(sums)});
  }
  // Table 1 on an independent level turn.
  const std::vector<double> control_u = sim::TurntableOptions{}.control_u;
  auto turn = RunTable1Turn(base->vehicle, base->world, control_u);
  if (!turn.ok()) return turn.status();
  auto table1 = EvaluateTable1(cals, control_u, *turn);
  if (!table1.ok()) return table1.status();
  cmp.heading_error = std::move(table1->table);
  if (!o.evidence) return out;

  CompareEvidence& ev = out.evidence;
  auto fits = FitGroundSession(*ground);
  if (!fits.ok()) return fits.status().WithContext("report");
  ev.ground_fits = std::move(*fits);
  ev.heading = std::move(table1->curves);
  for (size_t k = 0; k < o.calibrations.size(); ++k) {
    const batch::RunPoint& first = points[k * static_cast<size_t>(o.seeds)];
    const auto it = flights.find(first.RunId());
    if (it == flights.end()) return Status::Numerical(fmt::format("compare: {} seed {}: no flight", first.calibration, first.seed));
    ev.first_flights.push_back({name_of.at(first.calibration), first.seed, std::move(it->second)});
  }
  if (!ev.first_flights.empty()) ev.planned_path_N_m = PlannedPath(*base, ev.first_flights.front().log);
  return out;
}

}  // namespace hexsim::experiments
