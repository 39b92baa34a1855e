#include "hexsim/batch/pool.h"

#include <signal.h>  // NOLINT(modernize-deprecated-headers): POSIX header for kill(); <csignal> does not declare it
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <thread>

#include <fmt/format.h>

#include "hexsim/common/atomic_file.h"

namespace hexsim::batch {

using nlohmann::json;

namespace {

constexpr int kExitResultWritten = 0;
constexpr int kExitErrorWritten = 4;
constexpr int kExitNoResult = 5;
constexpr auto kPollInterval = std::chrono::milliseconds(5);

double NowS() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string RunDir(const PoolOptions& options, const RunPoint& point) {
  return options.run_dir ? options.run_dir(point) : options.out_dir + "/runs/" + point.RunId();
}

// The worker: runs one point, leaves summary.json or error.txt; returns its exit code.
int WorkerMain(const RunPoint& point, const RunFn& fn, const std::string& dir) {
  int code = kExitNoResult;
  try {
    Result<json> r = fn(point);
    if (r.ok()) {
      code = WriteFileAtomic(dir + "/summary.json", r->dump(2) + "\n").ok() ? kExitResultWritten : kExitNoResult;
    } else {
      code = WriteFileAtomic(dir + "/error.txt", r.status().message()).ok() ? kExitErrorWritten : kExitNoResult;
    }
  } catch (const std::exception& e) {
    code = WriteFileAtomic(dir + "/error.txt", std::string("exception: ") + e.what()).ok() ? kExitErrorWritten
                                                                                           : kExitNoResult;
  }
  return code;
}

struct Running {
  RunPoint point;
  std::string dir;
  double start_s = 0.0;
  bool timed_out = false;
};

// The summary.json a worker left, typed, or why it is unreadable.
Result<sim::RunSummary> ReadSummary(const std::string& dir) {
  const std::string path = dir + "/summary.json";
  auto text = ReadFile(path);
  if (!text.ok()) return text.status();
  try {
    return sim::RunSummaryFromJson(json::parse(*text), path);
  } catch (const json::exception& e) {
    return Status::BadInput(path + ": " + e.what());
  }
}

// The row for a reaped worker, and the result it left (none when it left none): its summary, and
// its log when `want_log`.
RunRow Collect(const Running& r, int wait_status, double wall_s, bool want_log, std::optional<RunResult>* result) {
  const std::string& dir = r.dir;
  if (r.timed_out) return FailedRow(r.point, "timeout", fmt::format("killed after {:.1f} s wall time", wall_s), wall_s);
  if (WIFSIGNALED(wait_status)) {
    const int sig = WTERMSIG(wait_status);
    return FailedRow(r.point, "crashed", fmt::format("worker killed by signal {} ({})", sig, strsignal(sig)), wall_s);
  }
  const int code = WIFEXITED(wait_status) ? WEXITSTATUS(wait_status) : -1;
  if (code == kExitResultWritten && std::filesystem::exists(dir + "/summary.json")) {
    auto summary = ReadSummary(dir);
    if (!summary.ok()) return FailedRow(r.point, "crashed", "unreadable summary.json: " + summary.status().message(), wall_s);
    RunResult out{std::move(*summary), std::nullopt};
    if (want_log) {
      auto log = logs::ReadFlightLog(dir + "/log.csv");
      if (!log.ok()) return FailedRow(r.point, "crashed", "unreadable log.csv: " + log.status().message(), wall_s);
      out.log = std::move(*log);
    }
    *result = std::move(out);
    return RowFromSummary(r.point, (*result)->summary, wall_s);
  }
  if (code == kExitErrorWritten) {
    auto text = ReadFile(dir + "/error.txt");
    if (text.ok()) return FailedRow(r.point, "failed", *text, wall_s);
  }
  return FailedRow(r.point, "crashed", fmt::format("worker exited with code {} and left no result", code), wall_s);
}

}  // namespace

Result<PoolStats> RunPool(const std::vector<RunPoint>& runs, const RunFn& fn, const PoolOptions& options,
                          ResultsDb* db) {
  return RunPool(runs, fn, options, [db](const RunRow& row, RunResult* /*result*/) { return db->Insert(row); });
}

Status ForkEach(size_t n, int jobs, double timeout_s, const std::function<Status(size_t)>& before_fork,
                const std::function<int(size_t)>& child, const ReapFn& reaped, const volatile std::sig_atomic_t* stop,
                const std::function<void(size_t index)>& killed) {
  if (jobs < 1) return Status::BadInput("--jobs: must be at least 1");
  struct Worker {
    size_t index = 0;
    double start_s = 0.0;
    bool timed_out = false;
    bool killed = false;
  };
  size_t next = 0;
  std::map<pid_t, Worker> running;
  Status error;
  const pid_t parent = getpid();
  auto stopping = [stop] { return stop != nullptr && *stop > 0; };
  while ((next < n && error.ok() && !stopping()) || !running.empty()) {
    if (stop != nullptr && *stop >= 2) {  // the second signal: kill what is running
      for (auto& [wpid, r] : running) {
        if (!r.killed) kill(wpid, SIGKILL);
        r.killed = true;
      }
    }
    while (error.ok() && !stopping() && next < n && static_cast<int>(running.size()) < jobs) {
      const size_t i = next++;
      error = before_fork(i);
      if (!error.ok()) break;
      std::fflush(nullptr);
      const double start = NowS();
      const pid_t pid = fork();
      if (pid < 0) {
        error = Status::Numerical(fmt::format("fork failed: {}", std::strerror(errno)));
        break;
      }
      if (pid == 0) {
        if (stop != nullptr) {
          // The parent handles interruption; the worker dies with it, never half-way on its own.
          std::signal(SIGINT, SIG_IGN);
          std::signal(SIGTERM, SIG_IGN);
          prctl(PR_SET_PDEATHSIG, SIGKILL);
          if (getppid() != parent) std::_Exit(kExitNoResult);  // the parent died before prctl
        }
        int code = kExitNoResult;
        try {
          code = child(i);
        } catch (...) {
          code = kExitNoResult;
        }
        std::_Exit(code);  // no atexit handlers, no flushing of the parent's buffers
      }
      running.emplace(pid, Worker{i, start, false});
    }
    if (running.empty()) break;
    int wait_status = 0;
    pid_t pid = 0;
    if (timeout_s > 0 || stop != nullptr) {  // poll: a timeout or a signal must not wait for a worker
      pid = waitpid(-1, &wait_status, WNOHANG);
      if (pid == 0) {
        const double now = NowS();
        for (auto& [wpid, r] : running) {
          if (timeout_s > 0 && !r.timed_out && now - r.start_s > timeout_s) {
            r.timed_out = true;
            kill(wpid, SIGKILL);
          }
        }
        std::this_thread::sleep_for(kPollInterval);
        continue;
      }
    } else {
      pid = waitpid(-1, &wait_status, 0);
    }
    if (pid < 0) {
      if (errno == EINTR) continue;
      error = Status::Numerical(fmt::format("waitpid failed: {}", std::strerror(errno)));
      break;
    }
    auto it = running.find(pid);
    if (it == running.end()) continue;  // not one of ours
    const Worker r = it->second;
    running.erase(it);
    if (r.killed) {
      if (killed) killed(r.index);
      continue;
    }
    const Status s = reaped(r.index, wait_status, NowS() - r.start_s, r.timed_out);
    if (!s.ok() && error.ok()) error = s;
  }
  return error;
}

Result<PoolStats> RunPool(const std::vector<RunPoint>& runs, const RunFn& fn, const PoolOptions& options,
                          const RecordFn& record) {
  if (options.jobs < 1) return Status::BadInput("--jobs: must be at least 1");
  PoolStats stats;
  const double start = NowS();
  const std::vector<std::string> varied = VariedParameters(runs);
  Progress progress(options.progress_stream, options.progress_tty, runs.size() + options.already_done,
                    options.already_done);
  std::vector<std::string> dirs(runs.size());
  auto before_fork = [&](size_t i) {
    dirs[i] = RunDir(options, runs[i]);
    const std::string& dir = dirs[i];
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    std::filesystem::remove(dir + "/summary.json", ec);  // a result left by a killed earlier attempt
    std::filesystem::remove(dir + "/error.txt", ec);
    if (options.return_log && options.return_log(runs[i])) {  // nor a log left by one
      std::filesystem::remove(dir + "/log.csv", ec);
      std::filesystem::remove(dir + "/log.meta.json", ec);
    }
    return Status::Ok();
  };
  auto child = [&](size_t i) { return WorkerMain(runs[i], fn, dirs[i]); };
  auto reaped = [&](size_t i, int wait_status, double wall_s, bool timed_out) {
    const bool want_log = options.return_log && options.return_log(runs[i]);
    std::optional<RunResult> result;
    const RunRow row = Collect(Running{runs[i], dirs[i], 0.0, timed_out}, wait_status, wall_s, want_log, &result);
    Status s = record(row, result ? &*result : nullptr);
    ++stats.finished;
    if (IsFailure(row.status)) ++stats.failed;
    progress.RunFinished(row, VariedText(runs[i], varied));
    return s;
  };
  auto killed = [&](size_t i) {  // interrupted twice: nothing of the run is kept
    std::error_code ec;
    std::filesystem::remove_all(dirs[i], ec);
  };
  const Status error =
      ForkEach(runs.size(), options.jobs, options.run_timeout_s, before_fork, child, reaped, options.stop, killed);
  progress.Finish();
  stats.interrupted = options.stop != nullptr && *options.stop > 0;
  stats.not_run = runs.size() - stats.finished;
  stats.wall_s = NowS() - start;
  if (!error.ok()) return error;
  return stats;
}

Result<std::vector<json>> RunForkedMap(size_t n, const std::function<Result<json>(size_t)>& fn, int jobs,
                                       const std::function<void(size_t done, size_t total)>& progress) {
  if (jobs < 1) return Status::BadInput("--jobs: must be at least 1");
  std::string tmpl = (std::filesystem::temp_directory_path() / "hexsim_forked_XXXXXX").string();
  if (!mkdtemp(tmpl.data())) return Status::Numerical(fmt::format("mkdtemp failed: {}", std::strerror(errno)));
  const std::string dir = tmpl;
  auto path = [&](size_t i, const char* ext) { return fmt::format("{}/{}.{}", dir, i, ext); };
  std::vector<json> out(n);
  std::vector<Status> failed(n);
  size_t done = 0;
  auto child = [&](size_t i) {
    Result<json> r = fn(i);
    if (r.ok()) return WriteFileAtomic(path(i, "json"), r->dump()).ok() ? kExitResultWritten : kExitNoResult;
    return WriteFileAtomic(path(i, "err"), r.status().message()).ok() ? kExitErrorWritten : kExitNoResult;
  };
  auto reaped = [&](size_t i, int wait_status, double /*wall_s*/, bool /*timed_out*/) {
    const int code = WIFEXITED(wait_status) ? WEXITSTATUS(wait_status) : -1;
    if (code == kExitResultWritten) {
      auto text = ReadFile(path(i, "json"));
      if (text.ok()) {
        try {
          out[i] = json::parse(*text);
        } catch (const json::exception& e) {
          failed[i] = Status::Numerical(fmt::format("task {}: unreadable result: {}", i, e.what()));
        }
      } else {
        failed[i] = text.status();
      }
    } else if (code == kExitErrorWritten) {
      auto text = ReadFile(path(i, "err"));
      failed[i] = Status::Numerical(text.ok() ? *text : fmt::format("task {} failed", i));
    } else if (WIFSIGNALED(wait_status)) {
      const int sig = WTERMSIG(wait_status);
      failed[i] = Status::Numerical(fmt::format("task {}: worker killed by signal {} ({})", i, sig, strsignal(sig)));
    } else {
      failed[i] = Status::Numerical(fmt::format("task {}: worker exited with code {} and left no result", i, code));
    }
    if (progress) progress(++done, n);
    return failed[i];
  };
  const Status s = ForkEach(n, jobs, 0.0, [](size_t) { return Status::Ok(); }, child, reaped);
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  for (const Status& f : failed) {
    if (!f.ok()) return f;  // the first failure in task order
  }
  if (!s.ok()) return s;
  return out;
}

Progress::Progress(std::FILE* out, bool tty, size_t total, size_t already_done)
    : out_(out), tty_(tty), total_(total), done_(already_done), start_s_(NowS()) {}

std::string Progress::FormatDuration(double seconds) {
  if (!(seconds >= 0) || seconds > 1e8) return "--:--";
  const long s = std::lround(seconds);
  if (s >= 3600) return fmt::format("{}:{:02d}:{:02d}", s / 3600, (s / 60) % 60, s % 60);
  return fmt::format("{}:{:02d}", s / 60, s % 60);
}

namespace {
// A point's parameters as flat key → value: world, estimator, duration_s, and each --set key.
std::map<std::string, json> FlatParams(const RunPoint& p) {
  std::map<std::string, json> out = {{"world", p.world}, {"estimator", p.estimator}, {"duration_s", p.duration_s}};
  for (const auto& [k, v] : p.sets) out[k] = v;
  return out;
}
}  // namespace

std::vector<std::string> VariedParameters(const std::vector<RunPoint>& runs) {
  std::vector<std::string> out;
  if (runs.empty()) return out;
  std::map<std::string, json> first = FlatParams(runs.front());
  std::set<std::string> varied;
  for (const auto& p : runs) {
    const auto flat = FlatParams(p);
    for (const auto& [k, v] : flat) {
      auto it = first.find(k);
      if (it == first.end() || it->second != v) varied.insert(k);
    }
    for (const auto& [k, v] : first) {
      if (!flat.count(k)) varied.insert(k);
    }
  }
  return {varied.begin(), varied.end()};
}

std::string VariedText(const RunPoint& point, const std::vector<std::string>& keys) {
  const auto flat = FlatParams(point);
  std::string out;
  for (const auto& k : keys) {
    const auto it = flat.find(k);
    if (it == flat.end()) continue;
    out += " " + k + "=" + (it->second.is_string() ? it->second.get<std::string>() : it->second.dump());
  }
  return out;
}

void Progress::RunFinished(const RunRow& row, const std::string& varied) {
  ++done_;
  ++done_here_;
  if (IsFailure(row.status)) ++failed_;
  if (!out_) return;
  const double elapsed = NowS() - start_s_;
  const double rate = elapsed > 0 ? static_cast<double>(done_here_) / elapsed : 0.0;
  const double left = rate > 0 ? static_cast<double>(total_ - done_) / rate : -1.0;
  if (tty_) {
    constexpr int kWidth = 30;
    const int filled = total_ ? static_cast<int>(kWidth * done_ / total_) : kWidth;
    std::string bar(static_cast<size_t>(filled), '#');
    bar.resize(kWidth, '.');
    std::fprintf(out_, "\r[%s] %zu/%zu runs  %.2f runs/s  %s left%s\x1b[K", bar.c_str(), done_, total_, rate,
                 FormatDuration(left).c_str(), failed_ ? fmt::format("  ({} failed)", failed_).c_str() : "");
  } else {
    std::fprintf(out_, "hexsim batch: [%zu/%zu] %s %s %s %s seed %llu%s: %s%s%s (%.2f s)\n", done_, total_,
                 row.run_id.c_str(), row.mission.c_str(), row.vehicle.c_str(), row.calibration.c_str(),
                 static_cast<unsigned long long>(row.seed), varied.c_str(), row.status.c_str(),
                 row.reason.empty() ? "" : ": ", row.reason.c_str(), row.wall_s);
  }
  std::fflush(out_);
}

void Progress::Finish() {
  if (out_ && tty_ && done_here_ > 0) {
    std::fprintf(out_, "\n");
    std::fflush(out_);
  }
}

}  // namespace hexsim::batch
