// hexsim serve-px4 [--vehicle V] [--world W] [--calibration C] [--port 4560] [--realtime] --out DIR
#include <atomic>
#include <csignal>
#include <cstdio>
#include <memory>
#include <string>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/bridge/server.h"
#include "hexsim/bridge/sim_messages.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/experiments/ground_calibration.h"
#include "hexsim/experiments/point_runner.h"
#include "hexsim/sim/run_config.h"

namespace hexsim::app {

namespace {

std::atomic<bool> g_stop{false};
volatile std::sig_atomic_t g_stop_signal = 0;
extern "C" void OnStopSignal(int sig) {
  g_stop_signal = sig;
  g_stop.store(true);
}

struct ServeArgs {
  sim::RunRequest request;
  std::string calibration = "none";
  bridge::ServeOptions options;
  std::string out;
};

Status ServeCommand(ServeArgs& args, int* exit_code) {
  args.request.mission = "square";  // only to load the files; the client flies, no mission runs
  if (args.request.estimator.empty()) args.request.estimator = "truth";
  auto setup = sim::LoadRunSetup(args.request);
  if (!setup.ok()) return setup.status();
  setup->mission = control::Mission{};
  setup->mission.name = "px4";
  setup->mission.resolved = true;
  setup->mission_name = "px4";
  HEXSIM_RETURN_IF_ERROR(experiments::AttachCalibration(args.calibration, &*setup));
  OutputDirectory out;
  HEXSIM_RETURN_IF_ERROR(out.Open(args.out));
  std::signal(SIGPIPE, SIG_IGN);  // a client that vanishes mid-send is an ended flight, not a death
  std::signal(SIGINT, OnStopSignal);
  std::signal(SIGTERM, OnStopSignal);
  args.options.stop = &g_stop;
  args.options.log = [](const std::string& line) { std::fprintf(stderr, "hexsim serve-px4: %s\n", line.c_str()); };
  auto served = bridge::ServePx4(*setup, args.options);
  if (!served.ok() && g_stop.load()) {
    // Nothing flown, nothing written (the output directory is removed uncommitted).
    std::fprintf(stderr, "hexsim serve-px4: interrupted (%s) before a client connected: nothing written\n",
                 g_stop_signal == SIGTERM ? "SIGTERM" : "SIGINT");
    *exit_code = kExitInterrupted;
    return Status::Ok();
  }
  if (!served.ok()) return served.status();
  sim::RunOutput& run = served->run;
  run.log.meta["bridge"] = {{"protocol", "PX4 Simulator MAVLink API (MAVLink 2)"},
                            {"end_reason", served->end_reason},
                            {"lockstep", !args.options.realtime},
                            {"time_usec_offset", bridge::kTimeOffsetUsec},
                            {"sensor_messages", served->stats.sensor_messages},
                            {"actuator_messages", served->stats.actuator_messages},
                            {"stale_actuator_messages", served->stats.stale_actuator_messages},
                            {"paced_sensor_messages", served->stats.paced_sensor_messages},
                            {"refused_clients", served->stats.refused_clients},
                            {"bad_crc", served->stats.parser.bad_crc},
                            {"unknown_id", served->stats.parser.unknown_id},
                            {"incompatible", served->stats.parser.incompatible},
                            {"skipped_bytes", served->stats.parser.skipped_bytes},
                            {"lost_frames", served->stats.parser.lost_frames}};
  HEXSIM_RETURN_IF_ERROR(experiments::WriteRunLog(run, out.path()));
  HEXSIM_RETURN_IF_ERROR(experiments::WriteRunSummary(run, out.path()));
  out.Commit();
  std::fprintf(stdout, "px4 flight: %s after %.2f s, %llu sensor steps, %llu actuator messages -> %s\n",
               served->end_reason.c_str(), run.summary.duration_s,
               static_cast<unsigned long long>(served->stats.sensor_messages),
               static_cast<unsigned long long>(served->stats.actuator_messages), args.out.c_str());
  if (served->interrupted || g_stop.load()) {
    // The flight log is complete up to the signal (closed and renamed into place above); the user
    // ended it, so the exit code says interrupted (CONTRACTS: 130), also for a signal while writing.
    std::fprintf(stderr, "hexsim serve-px4: interrupted (%s): flight log closed cleanly at %.2f s in %s\n",
                 g_stop_signal == SIGTERM ? "SIGTERM" : "SIGINT", run.summary.duration_s, args.out.c_str());
    *exit_code = kExitInterrupted;
    return Status::Ok();
  }
  *exit_code = run.status.ok() ? 0 : Report(run.status);
  return Status::Ok();
}

}  // namespace

void AddServePx4Command(CLI::App& app, int* exit_code) {
  auto args = std::make_shared<ServeArgs>();
  CLI::App* cmd = app.add_subcommand(
      "serve-px4", "Fly PX4 (or any client of PX4's Simulator MAVLink API) on hexsim: a lockstep TCP server; "
                   "writes log.csv, log.meta.json, summary.json when the client leaves");
  cmd->add_option("--vehicle", args->request.vehicle, "Vehicle name or YAML path (quad-X or hex-X)")->capture_default_str();
  cmd->add_option("--world", args->request.world, "Environment name or YAML path")->capture_default_str();
  cmd->add_option("--calibration", args->calibration,
                  "Compass compensation for hexsim's own logged estimate (with --estimator eskf); PX4 gets the raw compass")
      ->capture_default_str();
  cmd->add_option("--estimator", args->request.estimator, "hexsim's logged estimate beside PX4: truth (default)|eskf|complementary");
  cmd->add_option("--seed", args->request.seed, "Random seed (sensor noise)")->capture_default_str();
  cmd->add_option("--set", args->request.sets, "Override a parameter, e.g. world.wind.mean_N_mps=[2,0,0]");
  cmd->add_option("--port", args->options.port, "TCP port (0: any free port, printed on stderr)")->capture_default_str();
  cmd->add_option("--bind", args->options.bind_address, "Address to listen on")->capture_default_str();
  cmd->add_flag("--realtime", args->options.realtime, "Pace at wall-clock rate instead of lockstep");
  cmd->add_option("--duration", args->request.duration_s, "End the flight at this simulated time (0: when the client leaves)");
  cmd->add_option("--accept-timeout", args->options.accept_timeout_s, "Give up when no client connects within S s (0: wait)");
  cmd->add_option("--idle-timeout", args->options.idle_timeout_s, "Lockstep: end the flight when the client is silent S s")
      ->capture_default_str();
  cmd->add_option("--battery-udp", args->options.battery_udp,
                  "Also send BATTERY_STATUS to HOST:PORT, PX4's MAVLink port (SITL: 127.0.0.1:14580)");
  cmd->add_option("--out", args->out, "Output directory")->required();
  cmd->callback([args, exit_code] {
    const Status s = ServeCommand(*args, exit_code);
    if (!s.ok()) *exit_code = Report(s);
  });
}

}  // namespace hexsim::app
