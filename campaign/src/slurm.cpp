#include "lander/campaign/slurm.h"

#include <filesystem>
#include <sstream>

#include <fmt/format.h>

#include "lander/campaign/merge.h"
#include "lander/campaign/runner.h"
#include "lander/core/params_io.h"
#include "lander/sim/util/output_files.h"
#include "lander/sim/util/process.h"

namespace lander::campaign {

namespace fs = std::filesystem;

SlurmFiles write_slurm_files(const Campaign& c, const std::vector<PlannedRun>& plan,
                             const SlurmOptions& o) {
  if (o.runs_per_task < 1) throw ConfigError("--runs-per-task must be >= 1");
  if (o.cpus_per_task < 1) throw ConfigError("--cpus-per-task must be >= 1");
  if (o.throttle < 0) throw ConfigError("--throttle must be >= 0");
  const std::string dir = fs::absolute(o.out_dir).lexically_normal().string();
  const std::string campaign = fs::absolute(c.file).lexically_normal().string();
  const std::string lander = o.lander_binary.empty() ? sim::self_executable() : o.lander_binary;
  // #SBATCH lines are not shell words: a path there cannot be quoted.
  if (dir.find_first_of(" \t\n\r'\"%\\$`") != std::string::npos) {
    throw ConfigError("--out " + dir + ": a Slurm #SBATCH --output path cannot hold spaces, quotes, "
                      "'%', '$', '`' or '\\'; choose a plain directory name");
  }
  write_plan(c, plan, dir);
  const std::string sdir = dir + "/slurm";
  fs::create_directories(sdir);
  const int n = static_cast<int>(plan.size());
  const int tasks = (n + o.runs_per_task - 1) / o.runs_per_task;
  std::ostringstream s;
  s << "#!/bin/bash\n"
    << "# Campaign '" << c.name << "': " << n << " runs in " << tasks << " array tasks of about "
    << o.runs_per_task << " runs (task i runs shard i/" << tasks << ").\n"
    << "# Written by `lander campaign slurm`. Submit: sbatch " << sdir << "/campaign.sbatch\n"
    << "# When the array has ended: lander campaign report " << dir << "\n"
    << "# A task that was cut short is completed by submitting again (finished runs are kept).\n"
    << "#SBATCH --job-name=lander-" << c.name << "\n"
    << "#SBATCH --array=0-" << tasks - 1;
  if (o.throttle > 0) s << "%" << o.throttle;
  s << "\n#SBATCH --cpus-per-task=" << o.cpus_per_task << "\n"
    << "#SBATCH --ntasks=1\n"
    << "#SBATCH --output=" << sdir << "/task-%A_%a.out\n";
  if (!o.partition.empty()) s << "#SBATCH --partition=" << o.partition << "\n";
  if (o.time_limit_min > 0) s << "#SBATCH --time=" << static_cast<long>(o.time_limit_min) << "\n";
  s << "set -euo pipefail\n"
    << "exec " << shell_quote(lander) << " campaign run " << shell_quote(campaign) << " --out "
    << shell_quote(dir) << " --shard \"${SLURM_ARRAY_TASK_ID}/" << tasks << "\" --jobs "
    << o.cpus_per_task << " --no-report\n";
  SlurmFiles f;
  f.sbatch_path = sdir + "/campaign.sbatch";
  f.joblist_path = sdir + "/joblist.txt";
  f.array_tasks = tasks;
  sim::write_file_atomic(f.sbatch_path, s.str());
  fs::permissions(f.sbatch_path, fs::perms::owner_exec | fs::perms::group_exec, fs::perm_options::add);
  std::ostringstream jl;
  for (const PlannedRun& r : plan) {
    jl << shell_quote(lander) << " campaign run " << shell_quote(campaign) << " --out "
       << shell_quote(dir) << " --only " << shell_quote(r.id) << " --jobs 1 --no-report\n";
  }
  sim::write_file_atomic(f.joblist_path, jl.str());
  return f;
}

}  // namespace lander::campaign
