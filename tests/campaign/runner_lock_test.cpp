// The runner lock (campaign/runner_lock.h), in process: flock(2) locks of two open files
// conflict even within one process, so a second acquire() here stands for a second runner.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "lander/campaign/runner.h"
#include "lander/campaign/runner_lock.h"
#include "lander/sim/util/output_files.h"
#include "lander/sim/util/process.h"

namespace lander::campaign {
namespace {

namespace fs = std::filesystem;

std::string fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() /
                     ("lander_runner_lock_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(d);
  return d.string();
}

std::string host() {
  char buf[256] = {0};
  gethostname(buf, sizeof buf - 1);
  return buf;
}

RunnerOptions shard(const std::string& dir, int k, int m) {
  RunnerOptions o;
  o.out_dir = dir;
  o.shard_index = k;
  o.shard_count = m;
  return o;
}

// The RunnerBusyError message acquire(o) throws ("" when it takes the lock).
std::string refusal(const RunnerOptions& o) {
  try {
    RunnerLock l = RunnerLock::acquire(o);
  } catch (const RunnerBusyError& e) {
    return e.what();
  }
  return "";
}

TEST(RunnerLock, SecondRunnerOfTheSameRunsIsRefusedWithPidHostAndFile) {
  const std::string d = fresh_dir("same");
  const RunnerLock first = RunnerLock::acquire(shard(d, 0, 1));
  EXPECT_EQ(first.path(), d + "/runner.lock");
  EXPECT_TRUE(first.note().empty()) << first.note();
  const std::string msg = refusal(shard(d, 0, 1));
  EXPECT_NE(msg.find("pid " + std::to_string(getpid()) + " on host " + host()), std::string::npos) << msg;
  EXPECT_NE(msg.find(d + "/runner.lock"), std::string::npos) << msg;
  // The lock file records the holder for that message; nothing else is written.
  std::size_t files = 0;
  for (const auto& e : fs::directory_iterator(d)) files += e.is_regular_file() || e.is_directory();
  EXPECT_EQ(files, 1u);
}

TEST(RunnerLock, OtherShardsRunBesideEachOtherNotBesideAWholeRunner) {
  const std::string d = fresh_dir("shards");
  {
    const RunnerLock s0 = RunnerLock::acquire(shard(d, 0, 2));
    EXPECT_EQ(s0.path(), d + "/runner.shard-0-of-2.lock");
    const RunnerLock s1 = RunnerLock::acquire(shard(d, 1, 2));  // another shard: allowed
    const std::string again = refusal(shard(d, 0, 2));
    EXPECT_NE(again.find("runner.shard-0-of-2.lock"), std::string::npos) << again;
    EXPECT_NE(again.find("pid " + std::to_string(getpid())), std::string::npos) << again;
    // A runner of every run would do the shards' runs: refused, naming them.
    const std::string whole = refusal(shard(d, 0, 1));
    EXPECT_NE(whole.find("runner.shard-0-of-2.lock"), std::string::npos) << whole;
    EXPECT_NE(whole.find("runner.shard-1-of-2.lock"), std::string::npos) << whole;
  }
  {
    // And the other way round.
    const RunnerLock whole = RunnerLock::acquire(shard(d, 0, 1));
    EXPECT_NE(refusal(shard(d, 1, 2)).find(d + "/runner.lock"), std::string::npos);
  }
  // --only lists are selections of their own.
  RunnerOptions a = shard(d, 0, 1), b = shard(d, 0, 1);
  a.only = {"tiny-0001"};
  b.only = {"tiny-0002", "tiny-0000"};
  const RunnerLock la = RunnerLock::acquire(a), lb = RunnerLock::acquire(b);
  EXPECT_EQ(lb.path(), d + "/runner.shard-0-of-1-only-tiny-0000+tiny-0002.lock");
  EXPECT_FALSE(refusal(a).empty());
}

TEST(RunnerLock, ReleasedWhenTheRunnerEndsAndNotHeldByItsChildren) {
  const std::string d = fresh_dir("release");
  std::optional<sim::ChildProcess> child;
  {
    const RunnerLock l = RunnerLock::acquire(shard(d, 0, 1));
    // A run process started while the lock is held does not inherit it (O_CLOEXEC).
    child.emplace(sim::ChildProcess::spawn({"sleep", "30"}));
  }
  const RunnerLock again = RunnerLock::acquire(shard(d, 0, 1));
  EXPECT_TRUE(again.note().empty()) << again.note();  // a clean end leaves no record
  child->kill(SIGKILL);
  child->wait();
}

TEST(RunnerLock, RecordOfARunnerThatIsGoneIsTakenOverWithANote) {
  const std::string d = fresh_dir("stale");
  fs::create_directories(d);
  // A runner that died without clearing its record (SIGKILL): a pid that no longer exists.
  sim::ChildProcess gone = sim::ChildProcess::spawn({"true"});
  const pid_t pid = gone.pid();
  gone.wait();
  std::ofstream(d + "/runner.shard-1-of-3.lock")
      << "{\"pid\": " << pid << ", \"host\": \"" << host() << "\", \"runs\": \"shard 1/3\"}\n";
  const RunnerLock l = RunnerLock::acquire(shard(d, 1, 3));
  EXPECT_NE(l.note().find("pid " + std::to_string(pid) + " on host " + host()), std::string::npos) << l.note();
  EXPECT_NE(l.note().find("gone; lock taken over"), std::string::npos) << l.note();
  // Its own record replaced the old one.
  const std::string text = sim::read_file_text(d + "/runner.shard-1-of-3.lock", false);
  EXPECT_NE(text.find("\"pid\":" + std::to_string(getpid())), std::string::npos) << text;
}

// A Slurm array starts its tasks at the same instant: a shard runner that finds another shard
// runner in its moment of exclusive hold (clearing a stale record) waits for it, where it
// used to refuse (CI of stop 65: task 0 of 2 refused, its runs missing).
TEST(RunnerLock, ShardRunnerWaitsForAnotherShardRunnersMomentOfExclusiveHold) {
  const std::string d = fresh_dir("moment");
  fs::create_directories(d);
  // Another shard runner's moment: runner.lock held exclusively with an empty record.
  const int other = open((d + "/runner.lock").c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  ASSERT_GE(other, 0);
  ASSERT_EQ(flock(other, LOCK_EX | LOCK_NB), 0);
  constexpr auto kHold = std::chrono::milliseconds(300);
  std::thread release([&] {
    std::this_thread::sleep_for(kHold);
    flock(other, LOCK_SH);  // what the other runner does next: keeps a shared hold
  });
  const auto t0 = std::chrono::steady_clock::now();
  std::string msg;
  {
    std::optional<RunnerLock> l;
    try {
      l.emplace(RunnerLock::acquire(shard(d, 1, 2)));
    } catch (const RunnerBusyError& e) {
      msg = e.what();
    }
    release.join();
    EXPECT_TRUE(msg.empty()) << msg;
    ASSERT_TRUE(l.has_value());
    EXPECT_EQ(l->path(), d + "/runner.shard-1-of-2.lock");
    // It waited for the moment (less 50 ms: the thread's start and the clock's grain).
    EXPECT_GE(std::chrono::steady_clock::now() - t0, kHold - std::chrono::milliseconds(50));
  }
  close(other);
}

// Many shard runners of one campaign started together: every one takes its lock.
TEST(RunnerLock, ShardRunnersStartedTogetherAllTakeTheirLocks) {
  constexpr int kShards = 8;
  constexpr int kRounds = 25;
  for (int round = 0; round < kRounds; ++round) {
    const std::string d = fresh_dir("together_" + std::to_string(round));
    std::atomic<int> ready{0};
    std::atomic<int> taken{0};
    std::vector<std::string> refusals(kShards);
    std::vector<std::thread> runners;
    for (int k = 0; k < kShards; ++k) {
      runners.emplace_back([&, k] {
        ++ready;
        while (ready < kShards) std::this_thread::yield();  // all start at the same instant
        try {
          const RunnerLock l = RunnerLock::acquire(shard(d, k, kShards));
          ++taken;
          while (taken < kShards) std::this_thread::yield();  // held while the others take theirs
        } catch (const RunnerBusyError& e) {
          refusals[static_cast<std::size_t>(k)] = e.what();
          ++taken;  // so that the others stop waiting; counted as a failure below
        }
      });
    }
    for (std::thread& t : runners) t.join();
    for (int k = 0; k < kShards; ++k) {
      EXPECT_TRUE(refusals[static_cast<std::size_t>(k)].empty())
          << "round " << round << " shard " << k << ": " << refusals[static_cast<std::size_t>(k)];
    }
    fs::remove_all(d);
  }
}

}  // namespace
}  // namespace lander::campaign
