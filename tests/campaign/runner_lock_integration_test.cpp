// One runner per campaign directory and shard, as a user meets it: a second `lander campaign
// run` on a directory a runner is working in stops at once (exit 2) naming the first one's
// pid, host and lock file, and writes nothing; another shard runs beside it; after the first
// runner is killed (SIGKILL) its lock is free and its record is taken over with a note.
// The first runner holds the lock on a run that hangs at its start (faults.hang_t_s), so the
// test does not depend on how long a run takes.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <set>
#include <thread>

#include <nlohmann/json.hpp>

#include "campaign/support/campaign_support.h"
#include "lander/sim/util/process.h"

namespace lander::test {
namespace {

namespace fs = std::filesystem;

std::set<std::string> listing(const std::string& dir) {
  std::set<std::string> names;
  for (const auto& e : fs::recursive_directory_iterator(dir)) names.insert(e.path().string());
  return names;
}

std::string host() {
  char buf[256] = {0};
  gethostname(buf, sizeof buf - 1);
  return buf;
}

TEST(CampaignRunnerLock, SecondRunnerOfAShardStopsAnotherShardRuns) {
  const std::string d = temp_dir("lander_campaign_lock");
  // Plan index 0 (shard 0/2) hangs until its runner is stopped; plan index 1 (shard 1/2)
  // flies 0.1 s.
  const std::string tiny = std::string(LANDER_TESTS_DIR) + "/campaign/data/tiny.yaml";
  const std::string campaign = d + "/lock.yaml";
  std::ofstream(campaign) << "seed: 1\nrun_timeout_s: 900\nscenarios:\n"
                          << "  - {file: " << tiny << ", id: holds, runs: 1, dispersions: "
                          << "{faults.hang_t_s: {constant: 0.0}}}\n"
                          << "  - {file: " << tiny << ", id: short, runs: 1, dispersions: "
                          << "{duration_s: {constant: 0.1}}}\n";
  const std::string out = d + "/out";
  sim::SpawnOptions so;
  so.stdout_path = d + "/first.out";
  so.stderr_path = d + "/first.err";
  sim::ChildProcess first = sim::ChildProcess::spawn(
      {LANDER_BINARY, "campaign", "run", campaign, "--out", out, "--shard", "0/2", "--no-report"}, so);
  // Wait until the first runner holds its lock and its run process has started (its run
  // directory then holds its files: scenario, stdout.log, stderr.log).
  const std::string lock_file = out + "/runner.shard-0-of-2.lock";
  bool started = false;
  for (auto t0 = std::chrono::steady_clock::now();
       !started && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(300);) {
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(out + "/runs", ec)) {
      started |= e.path().filename().string().find(".partial-") != std::string::npos &&
                 fs::exists(e.path() / "stderr.log");
    }
    if (!started) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    ASSERT_FALSE(first.poll()) << read_text(d + "/first.err");
  }
  ASSERT_TRUE(started) << "the first runner did not start its run";
  const nlohmann::json rec = nlohmann::json::parse(read_text(lock_file));
  EXPECT_EQ(rec.at("pid").get<long>(), first.pid());
  EXPECT_EQ(rec.at("host").get<std::string>(), host());

  // The same shard again: refused at once, naming the first runner; nothing written.
  const std::set<std::string> before = listing(out);
  const Result again = lander({"campaign", "run", campaign, "--out", out, "--shard", "0/2", "--no-report"});
  EXPECT_EQ(again.code, 2) << again.output;
  EXPECT_NE(again.output.find("pid " + std::to_string(first.pid()) + " on host " + host()), std::string::npos)
      << again.output;
  EXPECT_NE(again.output.find(lock_file), std::string::npos) << again.output;
  EXPECT_EQ(listing(out), before);
  // Every run (no --shard) would do shard 0's run too: refused as well.
  EXPECT_EQ(lander({"campaign", "run", campaign, "--out", out, "--no-report"}).code, 2);

  // Another shard runs beside it.
  const Result other = lander({"campaign", "run", campaign, "--out", out, "--shard", "1/2", "--no-report"});
  EXPECT_EQ(other.code, 0) << other.output;
  EXPECT_TRUE(fs::exists(out + "/runs/short-0000/run.json"));

  // The first runner dies without a word: the kernel frees its lock; the next runner of the
  // shard takes its record over with a note (and finds its run hung: --timeout-s 0.5).
  first.kill(SIGKILL);
  first.wait();
  const Result next = lander({"campaign", "run", campaign, "--out", out, "--shard", "0/2",
                              "--timeout-s", "0.5", "--no-report"});
  EXPECT_EQ(next.code, 1) << next.output;  // the hung run is a simulator failure
  EXPECT_NE(next.output.find("lock taken over"), std::string::npos) << next.output;
  EXPECT_TRUE(fs::exists(out + "/runs/holds-0000/run.json"));
}

}  // namespace
}  // namespace lander::test
