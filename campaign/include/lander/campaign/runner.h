// Executes a campaign's runs: a local pool of worker processes, one `lander run` process per
// run, each completing atomically into DIR/runs/<id>/.
//
// A run is prepared in DIR/runs/<id>.partial-<pid>/ (its scenario, the run's outputs, its
// stdout/stderr, and run.json: the campaign's record of it) and renamed to DIR/runs/<id>/ once
// run.json is written, so a run directory is either whole or absent. Running the same command
// again resumes: runs with a directory are kept, leftovers of interrupted runs are removed and
// redone. Child processes die with the runner (PR_SET_PDEATHSIG), so a runner killed with
// SIGKILL leaves no orphan writing into the campaign.
//
// What the simulator did and what the vehicle did are kept apart: `status` is `ok` when the
// run process ended normally with a summary (whatever the landing outcome), else `crashed`
// (killed by a signal), `error` (threw, or ended without a summary), `hung` (past the run's
// limit by hang_reason(): killed) or `diverged` (the simulation's state went non-finite).
#pragma once

#include <sys/types.h>

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lander/campaign/campaign.h"

namespace lander::campaign {

struct RunnerOptions {
  std::string out_dir;
  int jobs{1};                 ///< worker processes at once
  int shard_index{0};          ///< this shard K of `shard_count` M: runs with plan_index % M == K
  int shard_count{1};
  std::vector<std::string> only;  ///< run ids to run (empty: every run of the shard)
  double timeout_s{0.0};       ///< per-run wall-clock limit (s); 0: campaign's, else 120 + 20 x duration
  bool retry_failed{false};    ///< redo runs whose status was a simulator failure
  bool progress{true};         ///< progress on stderr
  std::string lander_binary;   ///< the `lander` executable (default: this process's own)
};

struct RunnerResult {
  int started{0};
  int completed{0};        ///< runs that got a directory in this invocation
  int skipped{0};          ///< already complete before
  int simulator_failures{0};  ///< of those completed now
  bool interrupted{false};    ///< SIGINT / SIGTERM stopped it
};

// Writes DIR/plan.json (or checks that an existing one is the same plan: a different campaign
// in the same directory is refused with ConfigError) and DIR/campaign.yaml (a copy).
void write_plan(const Campaign& c, const std::vector<PlannedRun>& plan, const std::string& out_dir);

// CPU time (user + system, all threads) process `pid` has used, from /proc/<pid>/stat;
// nullopt when it cannot be read (the process is gone, or there is no /proc).
std::optional<double> process_cpu_s(pid_t pid);

// The runner's hang rule. `limit_s` is the run's limit; `recent_cpu_share` is the CPU the run
// used over the last hang_window_s(limit_s) of wall time, as a share of one core (nullopt
// until that much has been watched). A run is hung when
//  - it has used more CPU time than its limit (a busy loop), or
//  - it is past the limit in wall time and its recent CPU share is below kIdleCpuShare
//    (asleep or deadlocked: a process sleeping in a loop, with a renderer's idle threads,
//    still gathers a clock tick now and then, so "no CPU at all" is not the test), or
//  - it is past kHardWallFactor x the limit in wall time, whatever it does: a campaign never
//    waits on one run for ever.
// A run that is only starved (a campaign at nice 19 beside other work) still gets some CPU
// and is not hung until the hard limit. Returns why, or nullopt.
constexpr double kIdleCpuShare = 0.002;  // 0.2 % of a core: 12 clock ticks a minute
constexpr double kHardWallFactor = 10.0;
double hang_window_s(double limit_s);
std::optional<std::string> hang_reason(double cpu_s, std::optional<double> recent_cpu_share,
                                       double wall_s, double limit_s);

// Runs what is missing of this shard. Throws ConfigError for bad options.
RunnerResult run_campaign(const Campaign& c, const std::vector<PlannedRun>& plan,
                          const RunnerOptions& o);

// The run record a finished run leaves as run.json (also used by tests).
nlohmann::ordered_json read_run_record(const std::string& run_dir);

}  // namespace lander::campaign
