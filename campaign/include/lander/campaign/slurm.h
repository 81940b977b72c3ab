// Spreading a campaign over a cluster. `--shard K/M` runs a deterministic subset (plan index
// % M == K), so any scheduler can run the shards; this writes the files for two of them:
// a Slurm job-array script (array index -> shard, several runs per array task, a `%`
// throttle) and a GNU parallel job list (one line per run).
#pragma once

#include <string>
#include <vector>

#include "lander/campaign/campaign.h"

namespace lander::campaign {

struct SlurmOptions {
  std::string out_dir;            ///< the campaign directory (shared by the nodes)
  int runs_per_task{4};           ///< runs per array task (short runs must not flood the scheduler)
  int throttle{0};                ///< at most this many array tasks at once (0: no throttle)
  int cpus_per_task{1};           ///< cores per task = worker processes per task
  std::string partition;          ///< optional --partition
  double time_limit_min{0};       ///< optional --time per task (min); 0: the cluster's default
  std::string lander_binary;      ///< absolute path of `lander` on the nodes (default: this one)
};

struct SlurmFiles {
  std::string sbatch_path;    ///< DIR/slurm/campaign.sbatch
  std::string joblist_path;   ///< DIR/slurm/joblist.txt
  int array_tasks{0};
};

// Writes DIR/slurm/campaign.sbatch and DIR/slurm/joblist.txt (and the campaign's plan.json).
// Throws ConfigError for options or paths the script cannot carry.
SlurmFiles write_slurm_files(const Campaign& c, const std::vector<PlannedRun>& plan,
                             const SlurmOptions& o);

}  // namespace lander::campaign
