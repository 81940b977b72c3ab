#include "lander/campaign/runner.h"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include <fmt/format.h>

#include "lander/core/params_io.h"
#include "lander/flight/flight_plugin.h"
#include "lander/sim/util/output_files.h"
#include "lander/sim/util/process.h"
#include "yaml_json.h"

namespace lander::campaign {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace {

volatile sig_atomic_t g_stop = 0;
void on_stop_signal(int) { g_stop = 1; }

// SIGINT / SIGTERM set a flag for the pool loop while the runner is active.
class StopSignals {
 public:
  StopSignals() {
    g_stop = 0;
    struct sigaction sa {};
    sa.sa_handler = on_stop_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, &old_int_);
    sigaction(SIGTERM, &sa, &old_term_);
  }
  ~StopSignals() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }

 private:
  struct sigaction old_int_ {}, old_term_ {};
};

// The last `max_bytes` of a file, cut at a line start where possible.
std::string file_tail(const std::string& path, std::size_t max_bytes) {
  std::string s = sim::read_file_text(path, true);
  if (s.size() <= max_bytes) return s;
  s = s.substr(s.size() - max_bytes);
  const auto nl = s.find('\n');
  return nl != std::string::npos && nl + 1 < s.size() ? s.substr(nl + 1) : s;
}

json plan_json(const Campaign& c, const std::vector<PlannedRun>& plan) {
  json j;
  j["schema_version"] = 1;
  j["name"] = c.name;
  j["master_seed"] = c.seed;
  j["campaign_file"] = fs::absolute(c.file).lexically_normal().string();
  j["offset_limit_m"] = c.offset_limit_m;
  // The flight software, when a plugin flies every run: a different file (or the same file
  // rebuilt) is a different campaign, refused in the same directory.
  j["flight_plugin"] = c.flight_plugin.empty()
                           ? json(nullptr)
                           : json{{"path", c.flight_plugin}, {"sha256", flight::file_sha256(c.flight_plugin)}};
  std::set<std::string> keys;
  for (const PlannedRun& r : plan) {
    for (const auto& kv : r.sampled) keys.insert(kv.first);
  }
  j["dispersion_keys"] = json(std::vector<std::string>(keys.begin(), keys.end()));
  json runs = json::array();
  for (const PlannedRun& r : plan) {
    json x;
    x["id"] = r.id;
    x["scenario"] = r.scenario;
    x["scenario_file"] = r.scenario_file;
    x["index"] = r.index;
    x["seed"] = r.seed;
    json sampled = json::object();
    for (const auto& [k, v] : r.sampled) sampled[k] = yaml_to_json(v);
    x["sampled"] = sampled;
    runs.push_back(x);
  }
  j["runs"] = runs;
  return j;
}

struct Active {
  const PlannedRun* run;
  std::string partial;
  std::unique_ptr<sim::ChildProcess> child;
  std::chrono::steady_clock::time_point start;
  bool timed_out{false};
  // Samples of the run's CPU time (s) against wall time, covering the last hang window.
  std::deque<std::pair<std::chrono::steady_clock::time_point, double>> cpu_samples;
  double cpu_s{0.0};
  std::string hang_detail;
};

bool is_hung(Active& a, double limit_s, double wall_s) {
  const auto now = std::chrono::steady_clock::now();
  const double window_s = hang_window_s(limit_s);
  const double sample_every_s = std::min(1.0, limit_s / 4.0);
  using sec = std::chrono::duration<double>;
  if (a.cpu_samples.empty() || sec(now - a.cpu_samples.back().first).count() >= sample_every_s) {
    if (const std::optional<double> cpu = process_cpu_s(a.child->pid())) {
      a.cpu_s = std::max(a.cpu_s, *cpu);
      a.cpu_samples.emplace_back(now, a.cpu_s);
    }
    // Keep one sample at or before the window's start, so the window is covered whole.
    while (a.cpu_samples.size() > 2 && sec(now - a.cpu_samples[1].first).count() >= window_s) {
      a.cpu_samples.pop_front();
    }
  }
  std::optional<double> share;
  if (a.cpu_samples.size() >= 2) {
    const double span_s = sec(a.cpu_samples.back().first - a.cpu_samples.front().first).count();
    if (span_s >= window_s) share = (a.cpu_samples.back().second - a.cpu_samples.front().second) / span_s;
  }
  const std::optional<std::string> why = hang_reason(a.cpu_s, share, wall_s, limit_s);
  if (why) a.hang_detail = *why;
  return why.has_value();
}

std::string fmt_duration(double s) {
  if (!std::isfinite(s) || s < 0) return "?";
  const long t = std::lround(s);
  if (t >= 3600) return fmt::format("{}h{:02d}m", t / 3600, (t % 3600) / 60);
  if (t >= 60) return fmt::format("{}m{:02d}s", t / 60, t % 60);
  return fmt::format("{}s", t);
}

// Classifies a finished run from its exit status and summary.json, and writes run.json.
json finish_record(const Active& a, const sim::ExitStatus& st, double wall_s) {
  json rec;
  rec["id"] = a.run->id;
  rec["scenario"] = a.run->scenario;
  rec["seed"] = a.run->seed;
  json sampled = json::object();
  for (const auto& [k, v] : a.run->sampled) sampled[k] = yaml_to_json(v);
  rec["sampled"] = sampled;
  std::string status = "ok", outcome, detail;
  bool landed = false;
  json summary;
  const std::string summary_path = a.partial + "/summary.json";
  bool have_summary = false;
  if (fs::exists(summary_path)) {
    try {
      summary = json::parse(sim::read_file_text(summary_path, true));
      have_summary = summary.is_object() && summary.contains("outcome") &&
                     summary["outcome"].is_string();
    } catch (const json::exception& e) {
      detail = std::string("summary.json unreadable: ") + e.what();
    }
  }
  if (a.timed_out) {
    status = "hung";
    detail = fmt::format("no end: {}; killed after {:.0f} s", a.hang_detail, wall_s);
  } else if (st.signaled) {
    status = "crashed";
    detail = "the run process was " + st.describe();
  } else if (!have_summary) {
    status = "error";
    if (detail.empty()) detail = "the run process ended (" + st.describe() + ") without a summary.json";
  } else {
    outcome = summary["outcome"].get<std::string>();
    if (summary.contains("outcome_detail") && summary["outcome_detail"].is_string()) {
      detail = summary["outcome_detail"].get<std::string>();
    }
    landed = summary.contains("landed") && summary["landed"].is_boolean() && summary["landed"].get<bool>();
    if (outcome == "error" || outcome == "diverged") status = outcome;
    // A run must exit 0 (landed) or 1 (did not land / failed at run time).
    if (status == "ok" && st.code != 0 && st.code != 1) {
      status = "error";
      detail = "the run process ended with " + st.describe() + "; " + detail;
    }
  }
  if (status != "ok") {
    outcome = status;
    landed = false;
  }
  rec["status"] = status;
  rec["outcome"] = outcome;
  rec["landed"] = landed;
  rec["detail"] = detail;
  rec["exit"] = st.describe();
  rec["wall_s"] = wall_s;
  rec["stderr_tail"] = file_tail(a.partial + "/stderr.log", 2000);
  // Who flew (the run's flight_software.json: name, version, builtin or plugin file + sha256).
  rec["flight_software"] = nullptr;
  try {
    if (fs::exists(a.partial + "/flight_software.json")) {
      rec["flight_software"] = json::parse(sim::read_file_text(a.partial + "/flight_software.json", true));
    }
  } catch (const json::exception&) {
    // Left null: the record says nothing it cannot read.
  }
  return rec;
}

}  // namespace

json read_run_record(const std::string& run_dir) {
  return json::parse(sim::read_file_text(run_dir + "/run.json", true));
}

void write_plan(const Campaign& c, const std::vector<PlannedRun>& plan, const std::string& out_dir) {
  fs::create_directories(out_dir + "/runs");
  const json j = plan_json(c, plan);
  const std::string path = out_dir + "/plan.json";
  if (fs::exists(path)) {
    json old;
    try {
      old = json::parse(sim::read_file_text(path, true));
    } catch (const json::exception& e) {
      throw ConfigError(path + ": unreadable (" + e.what() + "); remove it or use another --out");
    }
    if (old.value("master_seed", json()) != j["master_seed"] || old.value("runs", json()) != j["runs"]) {
      throw ConfigError(out_dir + " holds a different campaign (plan.json differs: other seed, "
                        "scenarios, runs or dispersions); use another --out to start a new one");
    }
    return;
  }
  sim::write_json_file(path, j);
  // A record of the campaign file as given. Its scenario paths are relative to the original's
  // directory, not to this copy's: the first line names that file (JSON-quoted, so that a
  // path with a newline or invalid UTF-8 stays one comment line).
  const std::string origin =
      json(std::filesystem::absolute(c.file).lexically_normal().string())
          .dump(-1, ' ', false, json::error_handler_t::replace);
  sim::write_file_atomic(out_dir + "/campaign.yaml",
                         "# copy of " + origin +
                             " (its scenario paths are relative to that file's directory)\n" +
                             sim::read_file_text(c.file, true));
}

std::optional<double> process_cpu_s(pid_t pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(f, line)) return std::nullopt;
  const std::size_t rp = line.rfind(')');  // the command name may hold spaces and ')'
  if (rp == std::string::npos || rp + 2 > line.size()) return std::nullopt;
  std::istringstream is(line.substr(rp + 2));
  std::string field;
  // After the name: state, ppid, pgrp, session, tty_nr, tpgid, flags, minflt, cminflt,
  // majflt, cmajflt (11 fields), then utime and stime in clock ticks (proc(5)).
  for (int i = 0; i < 11 && (is >> field); ++i) {
  }
  long long utime = 0, stime = 0;
  if (!(is >> utime >> stime)) return std::nullopt;
  const long ticks = sysconf(_SC_CLK_TCK);
  if (ticks <= 0) return std::nullopt;
  return static_cast<double>(utime + stime) / static_cast<double>(ticks);
}

double hang_window_s(double limit_s) { return std::min(60.0, limit_s); }

std::optional<std::string> hang_reason(double cpu_s, std::optional<double> recent_cpu_share,
                                       double wall_s, double limit_s) {
  if (cpu_s > limit_s) {
    return fmt::format("{:.0f} s of CPU time, beyond the run's limit of {:.0f} s", cpu_s, limit_s);
  }
  if (wall_s > limit_s && recent_cpu_share && *recent_cpu_share < kIdleCpuShare) {
    return fmt::format("past the run's limit of {:.0f} s and {:.2f} % of a core used in the last "
                       "{:.0f} s ({:.1f} s of CPU in all)",
                       limit_s, 100.0 * *recent_cpu_share, hang_window_s(limit_s), cpu_s);
  }
  if (wall_s > kHardWallFactor * limit_s) {
    return fmt::format("{:.0f} s of wall time, {:.0f} x the run's limit of {:.0f} s ({:.1f} s of "
                       "CPU in all)",
                       wall_s, kHardWallFactor, limit_s, cpu_s);
  }
  return std::nullopt;
}

namespace {

// The --only ids as a set, each checked against the plan; the shard and --jobs checked.
std::set<std::string> check_options(const std::vector<PlannedRun>& plan, const RunnerOptions& o) {
  if (o.jobs < 1) throw ConfigError("--jobs must be >= 1");
  if (o.shard_count < 1 || o.shard_index < 0 || o.shard_index >= o.shard_count) {
    throw ConfigError(fmt::format("--shard {}/{}: K must be in [0, M)", o.shard_index, o.shard_count));
  }
  std::set<std::string> only(o.only.begin(), o.only.end());
  for (const std::string& id : only) {
    if (std::none_of(plan.begin(), plan.end(), [&](const PlannedRun& r) { return r.id == id; })) {
      throw ConfigError("--only: no run '" + id + "' in the campaign");
    }
  }
  return only;
}

// A complete run to do again: with --retry-failed, one whose status was a simulator failure.
bool redo_complete_run(const std::string& dir, const RunnerOptions& o) {
  if (!o.retry_failed) return false;
  try {
    return read_run_record(dir).value("status", "ok") != "ok";
  } catch (const std::exception&) {
    return true;
  }
}

// Select: this invocation's runs (its shard, --only) that are not complete; what is complete
// counts as skipped. Run directories to redo and leftovers of interrupted runs of these runs
// are removed.
std::vector<const PlannedRun*> select_runs(const std::vector<PlannedRun>& plan, const RunnerOptions& o,
                                           const std::set<std::string>& only,
                                           const std::string& runs_dir, RunnerResult& res) {
  std::vector<const PlannedRun*> todo;
  std::set<std::string> mine;
  for (const PlannedRun& r : plan) {
    if (r.plan_index % o.shard_count != o.shard_index) continue;
    if (!only.empty() && !only.count(r.id)) continue;
    mine.insert(r.id);
    const std::string dir = runs_dir + "/" + r.id;
    if (fs::exists(dir + "/run.json") && !redo_complete_run(dir, o)) {
      ++res.skipped;
      continue;
    }
    if (fs::exists(dir)) fs::remove_all(dir);  // a failed run to redo, or not ours
    todo.push_back(&r);
  }
  for (const auto& e : fs::directory_iterator(runs_dir)) {
    const std::string name = e.path().filename().string();
    const auto pos = name.find(".partial-");
    if (pos != std::string::npos && mine.count(name.substr(0, pos))) fs::remove_all(e.path());
  }
  return todo;
}

// The run processes' environment: they die with the runner, and each worker gets its share
// of the cores for the renderer's and OpenCV's threads.
std::vector<std::string> worker_env(int jobs) {
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const unsigned threads = std::max(1u, cores / static_cast<unsigned>(jobs));
  return {"LANDER_DIE_WITH_PARENT=" + std::to_string(getpid()),
          "LP_NUM_THREADS=" + std::to_string(threads),
          "OPENCV_FOR_THREADS_NUM=" + std::to_string(threads), "OMP_NUM_THREADS=1"};
}

// The progress line on stderr: rewritten in place on a terminal, else one line per run.
class Progress {
 public:
  Progress(const Campaign& c, const RunnerOptions& o, const RunnerResult& res, int total)
      : c_(c), o_(o), res_(res), total_(total), tty_(isatty(STDERR_FILENO)),
        t0_(std::chrono::steady_clock::now()) {
    if (!o.progress) return;
    std::cerr << fmt::format("campaign {}: {} runs to do in this shard ({} already complete), {} "
                             "workers\n",
                             c.name, total, res.skipped, o.jobs);
  }
  ~Progress() {
    if (o_.progress && tty_) std::cerr << "\n";
  }
  void operator()(const std::string& line) const {
    if (!o_.progress) return;
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
    const double rate = el > 0 ? res_.completed / el * 60.0 : 0.0;
    const double eta = res_.completed > 0 ? (total_ - res_.completed) / (res_.completed / el) : NAN;
    const std::string status = fmt::format(
        "campaign {}: {}/{} runs done, {} simulator failures, {:.1f} runs/min, ETA {}", c_.name,
        res_.completed, total_, res_.simulator_failures, rate, fmt_duration(eta));
    if (tty_) {
      std::cerr << "\r\033[K" << (line.empty() ? "" : line + "\n") << status << std::flush;
    } else if (!line.empty()) {
      std::cerr << line << "  [" << status << "]\n";
    }
  }

 private:
  const Campaign& c_;
  const RunnerOptions& o_;
  const RunnerResult& res_;
  const int total_;
  const bool tty_;
  const std::chrono::steady_clock::time_point t0_;
};

// Spawn: a run's partial directory with its scenario, and its `lander run` process.
Active spawn_run(const PlannedRun& r, const std::string& runs_dir, const std::string& lander,
                 const std::vector<std::string>& env) {
  Active a;
  a.run = &r;
  a.partial = runs_dir + "/" + r.id + ".partial-" + std::to_string(getpid());
  fs::create_directories(a.partial);
  sim::write_file_atomic(a.partial + "/scenario.input.yaml", run_scenario_yaml(r));
  sim::SpawnOptions so;
  so.stdout_path = a.partial + "/stdout.log";
  so.stderr_path = a.partial + "/stderr.log";
  so.own_process_group = true;
  so.env = env;
  a.start = std::chrono::steady_clock::now();
  a.child = std::make_unique<sim::ChildProcess>(sim::ChildProcess::spawn(
      {lander, "run", a.partial + "/scenario.input.yaml", "--out", a.partial, "--quiet"}, so));
  return a;
}

// A run's wall-clock limit (s): --timeout-s, else the campaign's, else 120 s + 20 x duration.
double run_limit_s(const Campaign& c, const RunnerOptions& o, const PlannedRun& r) {
  return o.timeout_s > 0 ? o.timeout_s : c.run_timeout_s > 0 ? c.run_timeout_s : 120.0 + 20.0 * r.duration_s;
}

// The run's exit status once it has ended, or once it is hung (then killed); nullopt while
// it runs.
std::optional<sim::ExitStatus> poll_run(Active& a, double limit_s, double wall_s) {
  std::optional<sim::ExitStatus> st = a.child->poll();
  if (st || !is_hung(a, limit_s, wall_s)) return st;
  a.timed_out = true;
  st = a.child->kill_and_reap();
  if (!st) {
    // Not ended after SIGKILL (stuck in the kernel, e.g. dumping core to a stalled
    // handler): recorded, and left to init to reap when we exit.
    a.hang_detail += fmt::format("; still not ended {:.0f} s after SIGKILL, left behind",
                                 sim::ChildProcess::kKillWait_s);
    st = sim::ExitStatus{};
  }
  return st;
}

// Complete a run: its record into run.json, the partial directory renamed into place; the
// progress line.
void complete_run(const Active& a, const sim::ExitStatus& st, double wall_s,
                         const std::string& runs_dir, const Progress& progress, RunnerResult& res) {
  const json rec = finish_record(a, st, wall_s);
  sim::write_json_file(a.partial + "/run.json", rec);
  std::error_code ec;
  fs::rename(a.partial, runs_dir + "/" + a.run->id, ec);
  if (ec) {
    // Another worker (an overlapping shard) finished it first: keep theirs.
    fs::remove_all(a.partial);
  }
  ++res.completed;
  const std::string status = rec["status"].get<std::string>();
  if (status != "ok") ++res.simulator_failures;
  std::string line = fmt::format("  {} {}", a.run->id, rec["outcome"].get<std::string>());
  if (status != "ok") line += " (simulator failure: " + rec["detail"].get<std::string>() + ")";
  progress(line);
}

// Reap: every run that has ended (or was found hung) is completed and leaves the pool.
// Returns whether any did.
bool reap_runs(std::vector<Active>& active, const Campaign& c, const RunnerOptions& o,
               const std::string& runs_dir, const Progress& progress, RunnerResult& res) {
  bool any = false;
  for (auto it = active.begin(); it != active.end();) {
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - it->start).count();
    const std::optional<sim::ExitStatus> st = poll_run(*it, run_limit_s(c, o, *it->run), el);
    if (!st) {
      ++it;
      continue;
    }
    any = true;
    complete_run(*it, *st, el, runs_dir, progress, res);
    it = active.erase(it);
  }
  return any;
}

// Interrupted: the runs in flight are killed and their partial directories removed.
void stop_runs(std::vector<Active>& active) {
  for (Active& a : active) {
    a.child->kill_and_reap();
    fs::remove_all(a.partial);
  }
  active.clear();
}

}  // namespace

RunnerResult run_campaign(const Campaign& c, const std::vector<PlannedRun>& plan,
                          const RunnerOptions& o) {
  const std::set<std::string> only = check_options(plan, o);
  const std::string runs_dir = o.out_dir + "/runs";
  fs::create_directories(runs_dir);
  RunnerResult res;
  // This invocation's runs, what is complete, and leftovers of interrupted runs.
  const std::vector<const PlannedRun*> todo = select_runs(plan, o, only, runs_dir, res);
  const std::string lander = o.lander_binary.empty() ? sim::self_executable() : o.lander_binary;
  const std::vector<std::string> env = worker_env(o.jobs);
  StopSignals signals;
  const Progress progress(c, o, res, static_cast<int>(todo.size()));
  std::vector<Active> active;
  std::size_t next = 0;
  // The pool: spawn up to --jobs runs, reap the ended ones, until all are done or a signal
  // stops it.
  while (next < todo.size() || !active.empty()) {
    if (g_stop) {
      stop_runs(active);
      res.interrupted = true;
      break;
    }
    while (active.size() < static_cast<std::size_t>(o.jobs) && next < todo.size()) {
      active.push_back(spawn_run(*todo[next++], runs_dir, lander, env));
      ++res.started;
    }
    if (!reap_runs(active, c, o, runs_dir, progress, res)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
  return res;
}

}  // namespace lander::campaign
