// The campaign runner's hang rule (campaign/runner.h, hang_reason): a run is hung when it has
// used more CPU than its limit; when it is past the limit in wall time and used less than
// kIdleCpuShare of a core over the last min(60 s, limit); or, whatever it does, past
// kHardWallFactor x the limit. A run that is only starved is not hung before that. The
// integration tests CampaignRunnerFailures.HungRunIsKilledAndRecorded and
// CrashDivergenceAndHangAreRecorded kill runs end to end.
#include <gtest/gtest.h>

#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <optional>
#include <string>

#include "lander/campaign/runner.h"
#include "lander/sim/util/process.h"

namespace lander::campaign {
namespace {

constexpr double kLimit_s = 600.0;

TEST(RunnerHang, StarvedRunThatStillGetsCpuIsNotHung) {
  // Beside other work at nice 19 a run may take far longer than its limit in wall time while
  // it still gets CPU: 1 % of a core is a nice-19 process beside two nice-0 ones per core.
  // Before this rule the wall-clock limit alone killed such runs of the envelope campaign.
  EXPECT_FALSE(hang_reason(/*cpu_s=*/40.0, /*recent_cpu_share=*/0.01, /*wall_s=*/1500.0, kLimit_s));
  // Within the limit nothing is hung, however idle.
  EXPECT_FALSE(hang_reason(1.0, 0.0, 300.0, kLimit_s));
  // Past the limit, but not yet watched for a whole window: not yet.
  EXPECT_FALSE(hang_reason(1.0, std::nullopt, 700.0, kLimit_s));
}

TEST(RunnerHang, AsleepPastTheLimitIsHungThoughATickComesNowAndThen) {
  // The hanging test run (sleeping in a 1 s loop beside the renderer's idle threads) gathered
  // one 10 ms clock tick every ~25 s: 0.04 % of a core. The rule before this one needed its
  // CPU time not to grow at all for a minute and never killed it (CI waited 1500 s).
  const std::optional<std::string> why = hang_reason(3.0, 0.01 / 25.0, 700.0, kLimit_s);
  ASSERT_TRUE(why);
  EXPECT_NE(why->find("of a core used"), std::string::npos) << *why;
  EXPECT_TRUE(hang_reason(3.0, 0.0, 700.0, kLimit_s));
  // The window follows a short limit (the tests' 0.5 s limits).
  EXPECT_DOUBLE_EQ(hang_window_s(0.5), 0.5);
  EXPECT_DOUBLE_EQ(hang_window_s(kLimit_s), 60.0);
}

TEST(RunnerHang, BusyBeyondTheLimitInCpuTimeIsHung) {
  const std::optional<std::string> why = hang_reason(kLimit_s + 1.0, 1.0, 300.0, kLimit_s);
  ASSERT_TRUE(why);
  EXPECT_NE(why->find("CPU time"), std::string::npos) << *why;
}

TEST(RunnerHang, NoRunOutlivesTheHardWallLimit) {
  // A starved run that still gets CPU is killed once past kHardWallFactor x its limit.
  EXPECT_FALSE(hang_reason(40.0, 0.01, kHardWallFactor * kLimit_s - 1.0, kLimit_s));
  const std::optional<std::string> why = hang_reason(40.0, 0.01, kHardWallFactor * kLimit_s + 1.0, kLimit_s);
  ASSERT_TRUE(why);
  EXPECT_NE(why->find("wall time"), std::string::npos) << *why;
}

TEST(RunnerHang, CpuTimeOfAProcessGrowsWithItsWork) {
  const std::optional<double> before = process_cpu_s(getpid());
  ASSERT_TRUE(before);
  // Spin for 0.3 s of wall time on this thread: the process's CPU time must grow (by up to
  // 0.3 s; on a loaded machine the thread gets only part of it, so only growth is required)
  // and cannot grow by more than the wall time spent plus one 10 ms tick per thread.
  const auto t0 = std::chrono::steady_clock::now();
  volatile double x = 0.0;
  while (std::chrono::steady_clock::now() - t0 < std::chrono::milliseconds(300)) x = x + 1.0;
  const std::optional<double> after = process_cpu_s(getpid());
  ASSERT_TRUE(after);
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GT(*after - *before, 0.0);
  EXPECT_LT(*after - *before, wall_s + 0.05);
  // A process that does not exist has no CPU time to read.
  EXPECT_FALSE(process_cpu_s(static_cast<pid_t>(0x7ffffff0)));
}

// The runner's kill path waits a bounded time for a killed run (ChildProcess::wait_for).
TEST(RunnerHang, WaitForAChildIsBounded) {
  sim::ChildProcess p = sim::ChildProcess::spawn({"sleep", "30"});
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_FALSE(p.wait_for(0.2));  // still asleep
  const double waited_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_GE(waited_s, 0.2);
  EXPECT_LT(waited_s, 25.0);  // returned long before the child's own end
  p.kill(SIGKILL);
  const std::optional<sim::ExitStatus> st = p.wait_for(10.0);
  ASSERT_TRUE(st);
  EXPECT_TRUE(st->signaled);
  EXPECT_EQ(st->signal, SIGKILL);
}

}  // namespace
}  // namespace lander::campaign
