// The campaign runner's hang rule (campaign/runner.h, hang_reason): a run is hung when it has
// used more CPU than its limit, or when it is past the limit in wall time and has used no CPU
// for min(60 s, limit); a run that is only starved is not. The integration test
// CampaignRunnerFailures.HungRunIsKilledAndRecorded kills a sleeping run end to end.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <optional>
#include <string>

#include "lander/campaign/runner.h"

namespace lander::campaign {
namespace {

constexpr double kLimit_s = 600.0;

TEST(RunnerHang, StarvedRunThatStillGetsCpuIsNotHung) {
  // Beside other work at nice 19 a run may take far longer than its limit in wall time while
  // its CPU time still grows (here: it grew 2 s ago): not hung. Before this rule the
  // wall-clock limit alone killed such runs of the envelope campaign as "hung".
  EXPECT_FALSE(hang_reason(/*cpu_s=*/40.0, /*cpu_idle_s=*/2.0, /*wall_s=*/1500.0, kLimit_s));
  // Within the limit nothing is hung, however idle.
  EXPECT_FALSE(hang_reason(1.0, 500.0, 300.0, kLimit_s));
}

TEST(RunnerHang, AsleepPastTheLimitIsHung) {
  // Past the limit and no CPU for more than a minute: asleep or deadlocked.
  const std::optional<std::string> why = hang_reason(3.0, 61.0, 700.0, kLimit_s);
  ASSERT_TRUE(why);
  EXPECT_NE(why->find("no CPU used"), std::string::npos) << *why;
  // ... but not after only 59 s of no CPU.
  EXPECT_FALSE(hang_reason(3.0, 59.0, 700.0, kLimit_s));
  // A short limit shortens the idle window with it (the tests' 0.5 s limits).
  EXPECT_TRUE(hang_reason(0.3, 0.6, 0.7, 0.5));
}

TEST(RunnerHang, BusyBeyondTheLimitInCpuTimeIsHung) {
  const std::optional<std::string> why = hang_reason(kLimit_s + 1.0, 0.0, 300.0, kLimit_s);
  ASSERT_TRUE(why);
  EXPECT_NE(why->find("CPU time"), std::string::npos) << *why;
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

}  // namespace
}  // namespace lander::campaign
