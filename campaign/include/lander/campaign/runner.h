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

// The runner's hang rule: a run is hung when it has used more CPU time than its limit (a busy
// loop), or when it is past the limit in wall time and its CPU time has not grown for
// min(60 s, limit) (asleep or deadlocked). A run that is only starved (a campaign at low
// priority beside other work) still gets some CPU and is not hung. Returns why, or nullopt.
std::optional<std::string> hang_reason(double cpu_s, double cpu_idle_s, double wall_s,
                                       double limit_s);

// Runs what is missing of this shard. Throws ConfigError for bad options.
RunnerResult run_campaign(const Campaign& c, const std::vector<PlannedRun>& plan,
                          const RunnerOptions& o);

// The run record a finished run leaves as run.json (also used by tests).
nlohmann::ordered_json read_run_record(const std::string& run_dir);

}  // namespace lander::campaign
