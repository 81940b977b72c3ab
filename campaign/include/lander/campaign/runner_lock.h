// One runner per campaign directory and selection of runs: `lander campaign run` takes this
// lock before it writes anything into the directory, so that a second runner started on the
// same directory stops at once instead of doing (and deleting) the first one's runs.
//
// The locks are flock(2) locks on files in the campaign directory, opened with O_CLOEXEC (the
// run processes the runner starts do not inherit them), released by the kernel when the
// runner ends however it ends: a crashed runner never leaves a lock held. Each file also
// records its holder (pid, host) for the message a refused runner prints; a record whose
// runner is gone (no such pid on this host) is taken over with a note.
//
//   DIR/runner.lock                 the whole campaign: held exclusively by a runner of every
//                                   run, shared by the runners of shards (--shard, --only)
//   DIR/runner.shard-K-of-M.lock    shard K of M, exclusive (with --only: runner.only-...)
//
// So two runners of the whole campaign, or of the same shard, exclude each other, a whole
// runner and a shard runner exclude each other, and runners of different shards (Slurm array
// tasks, GNU parallel's --only lines) run side by side. Shards of different M (0/2 and 0/3)
// are not told apart: they share runs, which the runner already tolerates (the first to
// finish a run keeps it). Shard runners started at the same instant (a Slurm array's tasks)
// wait for each other's moment of exclusive hold (up to 5 s) instead of refusing.
#pragma once

#include <string>
#include <vector>

#include "lander/core/params_io.h"

namespace lander::campaign {

struct RunnerOptions;

// Another runner holds the lock: the message names its pid, host and the lock file.
struct RunnerBusyError : ConfigError {
  using ConfigError::ConfigError;
};

class RunnerLock {
 public:
  // Takes the locks of the runs `o` selects (o.out_dir, o.shard_index / o.shard_count,
  // o.only), creating o.out_dir if needed and nothing else. Throws RunnerBusyError when
  // another runner holds one.
  static RunnerLock acquire(const RunnerOptions& o);

  RunnerLock(RunnerLock&& other) noexcept;
  RunnerLock& operator=(RunnerLock&&) = delete;
  RunnerLock(const RunnerLock&) = delete;
  // Clears the holder records it wrote and releases the locks.
  ~RunnerLock();

  // What was taken over on the way ("" when nothing): a record of a runner that is gone.
  const std::string& note() const { return note_; }
  // The lock file holding this runner's record (DIR/runner.lock or the shard's file).
  const std::string& path() const { return record_path_; }

 private:
  RunnerLock() = default;
  int dir_fd_{-1};        ///< DIR/runner.lock
  int selection_fd_{-1};  ///< the shard's file; -1 for a whole-campaign runner
  int record_fd_{-1};     ///< the one of the two that holds this runner's record
  std::string record_path_;
  std::string note_;
};

// The lock file of a selection of runs, relative to the campaign directory: "runner.lock"
// for every run, else "runner.shard-K-of-M.lock" (with "-only-<ids>" for --only; a hash of
// the ids when they are many).
std::string runner_lock_name(int shard_index, int shard_count, const std::vector<std::string>& only);

}  // namespace lander::campaign
