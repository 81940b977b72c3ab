// The campaign runner end to end, as a user runs it: `lander campaign run` on a small
// campaign of 3 s closed-loop runs (tests/campaign/data/tiny_campaign.yaml, 5 runs).
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "campaign/support/campaign_support.h"
#include "lander/sim/util/process.h"

namespace lander::test {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
const std::string kCampaign = std::string(LANDER_TESTS_DIR) + "/campaign/data/tiny_campaign.yaml";
const std::vector<std::string> kRunIds = {"tiny-0000", "tiny-0001", "tiny-0002", "tiny_arc-0000",
                                          "tiny_arc-0001"};

json read_json(const std::string& path) { return json::parse(read_text(path)); }

// Files of a run that must be identical between two executions of the same run.
void expect_same_run(const std::string& a, const std::string& b, const std::string& id) {
  for (const char* f : {"summary.json", "trace.csv", "scenario.resolved.yaml"}) {
    const std::string ta = read_text(a + "/runs/" + id + "/" + f);
    ASSERT_FALSE(ta.empty()) << a << " " << id << "/" << f;
    EXPECT_TRUE(ta == read_text(b + "/runs/" + id + "/" + f)) << id << "/" << f << " differs";
  }
}

// Checks the outputs of a complete campaign directory made from tiny_campaign.yaml.
void expect_complete_campaign(const std::string& d) {
  for (const std::string& id : kRunIds) {
    const json rec = read_json(d + "/runs/" + id + "/run.json");
    EXPECT_EQ(rec.at("status").get<std::string>(), "ok") << id;
    // 3 s of flight cannot land: the run ends in timeout, a landing outcome, not a failure.
    EXPECT_EQ(rec.at("outcome").get<std::string>(), "timeout") << id;
    EXPECT_TRUE(fs::exists(d + "/runs/" + id + "/summary.json"));
    EXPECT_TRUE(fs::exists(d + "/runs/" + id + "/scenario.resolved.yaml"));
  }
  const Result r = lander({"campaign", "report", d, "--no-html"});
  ASSERT_EQ(r.code, 0) << r.output;
  const Csv csv = read_csv(d + "/campaign.csv");
  ASSERT_EQ(csv.rows.size(), kRunIds.size());
  const std::vector<std::string> first = {"id", "scenario", "seed", "outcome", "landed", "touchdown_offset_m"};
  for (std::size_t i = 0; i < first.size(); ++i) EXPECT_EQ(csv.header.at(i), first[i]);
  for (const char* col : {"cart.speed_mps", "vehicle.start_m[0]", "vehicle.start_m[2]",
                          "wind.steady_W_mps[1]", "touchdown_x_P_m", "touchdown_y_P_m", "wall_s", "status"}) {
    EXPECT_NE(std::find(csv.header.begin(), csv.header.end(), col), csv.header.end()) << col;
  }
  // The copy of the campaign file names the original (its scenario paths are relative to
  // it) on its first line, then holds the file as given.
  const std::string copy = read_text(d + "/campaign.yaml");
  const std::string origin = fs::absolute(kCampaign).lexically_normal().string();
  const std::string first_line = copy.substr(0, copy.find('\n') + 1);
  EXPECT_EQ(first_line, "# copy of \"" + origin +
                            "\" (its scenario paths are relative to that file's directory)\n");
  EXPECT_EQ(copy.substr(first_line.size()), read_text(kCampaign));
  const json c = read_json(d + "/campaign.json");
  EXPECT_EQ(c.at("runs_planned").get<int>(), 5);
  EXPECT_EQ(c.at("runs_complete").get<int>(), 5);
  EXPECT_EQ(c.at("overall").at("landed").get<int>(), 0);
  EXPECT_EQ(c.at("overall").at("landing_failures").get<int>(), 5);
  EXPECT_EQ(c.at("overall").at("simulator_failures").get<int>(), 0);
  EXPECT_EQ(c.at("scenarios").at("tiny_arc").at("runs").get<int>(), 2);
  ASSERT_FALSE(c.at("worst_runs").empty());
  EXPECT_NE(c.at("worst_runs")[0].at("rerun").get<std::string>().find("scenario.resolved.yaml"), std::string::npos);
}

// One worker, two workers, and two shards run apart: the same runs, bit for bit, and the
// same campaign.csv (order and wall time aside).
TEST(CampaignRunner, WorkersAndShardsGiveTheSameRuns) {
  const std::string one = temp_dir("lander_campaign_j1");
  const Result r1 = lander({"campaign", "run", kCampaign, "--out", one, "--jobs", "1", "--no-report"});
  ASSERT_EQ(r1.code, 0) << r1.output;
  expect_complete_campaign(one);

  const std::string two = temp_dir("lander_campaign_j2");
  const Result r2 = lander({"campaign", "run", kCampaign, "--out", two, "--jobs", "2", "--no-report"});
  ASSERT_EQ(r2.code, 0) << r2.output;
  for (const std::string& id : kRunIds) expect_same_run(one, two, id);

  const std::string sh = temp_dir("lander_campaign_shards");
  const Result s0 = lander({"campaign", "run", kCampaign, "--out", sh, "--shard", "0/2", "--no-report"});
  ASSERT_EQ(s0.code, 0) << s0.output;
  int done = 0;
  for (const std::string& id : kRunIds) done += fs::exists(sh + "/runs/" + id);
  EXPECT_EQ(done, 3);  // plan indices 0, 2, 4
  const Result s1 = lander({"campaign", "run", kCampaign, "--out", sh, "--shard", "1/2", "--no-report"});
  ASSERT_EQ(s1.code, 0) << s1.output;
  ASSERT_EQ(lander({"campaign", "report", sh, "--no-html"}).code, 0);
  EXPECT_EQ(read_csv(sh + "/campaign.csv").canonical_rows({"wall_s"}),
            read_csv(one + "/campaign.csv").canonical_rows({"wall_s"}));
  for (const std::string& id : kRunIds) expect_same_run(one, sh, id);
}

// Killed with SIGKILL while runs are in flight, then run again: exactly the runs of an
// uninterrupted campaign, none lost or duplicated, and no run process left behind.
TEST(CampaignRunner, KilledAndResumedEndsWithTheSameRuns) {
  const std::string ref = temp_dir("lander_campaign_ref");
  const Result rr = lander({"campaign", "run", kCampaign, "--out", ref, "--jobs", "2", "--no-report"});
  ASSERT_EQ(rr.code, 0) << rr.output;
  const std::string d = temp_dir("lander_campaign_kill");
  sim::SpawnOptions o;
  o.stdout_path = d + ".out";
  o.stderr_path = d + ".err";
  sim::ChildProcess p = sim::ChildProcess::spawn(
      {LANDER_BINARY, "campaign", "run", kCampaign, "--out", d, "--jobs", "2", "--no-report"}, o);
  // Wait until one run is complete and others are in flight (partial directories), then kill.
  const auto t0 = std::chrono::steady_clock::now();
  bool killed_midway = false;
  while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(300)) {
    int complete = 0, partial = 0;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(d + "/runs", ec)) {
      const std::string n = e.path().filename().string();
      if (n.find(".partial-") != std::string::npos) ++partial;
      else if (fs::exists(e.path() / "run.json")) ++complete;
    }
    if (complete >= 1 && partial >= 1) {
      p.kill(SIGKILL);
      killed_midway = true;
      break;
    }
    if (p.poll()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(killed_midway) << "the campaign ended before it could be killed midway";
  const sim::ExitStatus st = p.wait();
  EXPECT_TRUE(st.signaled);
  // The run processes die with the runner (PR_SET_PDEATHSIG): none is left writing.
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string cmd = read_text((e.path() / "cmdline").string());
    EXPECT_EQ(cmd.find(d + "/runs"), std::string::npos) << "orphan run process " << e.path();
  }
  const Result r = lander({"campaign", "run", kCampaign, "--out", d, "--jobs", "2", "--no-report"});
  ASSERT_EQ(r.code, 0) << r.output;
  int dirs = 0;
  for (const auto& e : fs::directory_iterator(d + "/runs")) {
    EXPECT_EQ(e.path().filename().string().find(".partial-"), std::string::npos) << e.path();
    ++dirs;
  }
  EXPECT_EQ(dirs, 5);
  ASSERT_EQ(lander({"campaign", "report", d, "--no-html"}).code, 0);
  ASSERT_EQ(lander({"campaign", "report", ref, "--no-html"}).code, 0);
  EXPECT_EQ(read_csv(d + "/campaign.csv").canonical_rows({"wall_s"}),
            read_csv(ref + "/campaign.csv").canonical_rows({"wall_s"}));
  for (const std::string& id : kRunIds) expect_same_run(ref, d, id);
}

// A run past its wall-clock limit is killed and recorded as `hung`; the campaign goes on and
// says so in its exit code and statistics.
TEST(CampaignRunnerFailures, HungRunIsKilledAndRecorded) {
  const std::string d = temp_dir("lander_campaign_hung");
  const Result r = lander({"campaign", "run", kCampaign, "--out", d, "--only", "tiny-0000,tiny_arc-0001",
                           "--timeout-s", "0.5", "--no-report"});
  EXPECT_EQ(r.code, 1) << r.output;
  for (const char* id : {"tiny-0000", "tiny_arc-0001"}) {
    const json rec = read_json(d + "/runs/" + std::string(id) + "/run.json");
    EXPECT_EQ(rec.at("status").get<std::string>(), "hung");
    EXPECT_FALSE(rec.at("landed").get<bool>());
  }
  const Result m = lander({"campaign", "report", d, "--no-html"});
  EXPECT_EQ(m.code, 1) << m.output;  // simulator failures make the report exit 1
  const json c = read_json(d + "/campaign.json");
  EXPECT_EQ(c.at("overall").at("simulator_failures").get<int>(), 2);
  EXPECT_EQ(c.at("runs_complete").get<int>(), 2);
  EXPECT_EQ(c.at("missing").size(), 3u);
  EXPECT_TRUE(c.at("overall").at("landing_rate").at("value").is_null());  // no valid run
  // --retry-failed redoes them (here with a limit they can meet).
  const Result again = lander({"campaign", "run", kCampaign, "--out", d, "--only", "tiny-0000",
                               "--retry-failed", "--no-report"});
  EXPECT_EQ(again.code, 0) << again.output;
  EXPECT_EQ(read_json(d + "/runs/tiny-0000/run.json").at("status").get<std::string>(), "ok");
}

TEST(CampaignRunnerFailures, BadInputExitsTwoBeforeAnyRun) {
  const std::string d = temp_dir("lander_campaign_bad");
  EXPECT_EQ(lander({"campaign", "run", kCampaign + ".missing", "--out", d}).code, 2);
  EXPECT_EQ(lander({"campaign", "run", kCampaign, "--out", d, "--shard", "2/2"}).code, 2);
  EXPECT_EQ(lander({"campaign", "run", kCampaign, "--out", d, "--jobs", "0"}).code, 2);
  EXPECT_EQ(lander({"campaign", "run", kCampaign, "--out", d, "--only", "nope-0000"}).code, 2);
  EXPECT_EQ(lander({"campaign", "report", d + "/nothing"}).code, 2);
  EXPECT_FALSE(fs::exists(d + "/runs/tiny-0000"));
  // A directory holding another campaign is refused.
  const std::string other = d + "/other.yaml";
  std::ofstream(other) << "seed: 99\nscenarios: [{file: " << LANDER_TESTS_DIR
                       << "/campaign/data/tiny.yaml, runs: 1}]\n";
  ASSERT_EQ(lander({"campaign", "run", other, "--out", d + "/c", "--timeout-s", "0.2", "--no-report"}).code, 1);
  const Result r = lander({"campaign", "run", kCampaign, "--out", d + "/c", "--no-report"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("different campaign"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace lander::test

namespace lander::test {
namespace {

// A run killed by a signal (SIGABRT), one whose simulation goes non-finite, and one that stops
// making progress: each is recorded with its own status and the campaign goes on; the normal
// run is unaffected and the exit code says simulator failures happened.
TEST(CampaignRunnerFailures, CrashDivergenceAndHangAreRecorded) {
  const std::string d = temp_dir("lander_campaign_fail");
  const std::string c = std::string(LANDER_TESTS_DIR) + "/campaign/data/failing_campaign.yaml";
  const Result r = lander({"campaign", "run", c, "--out", d, "--jobs", "2", "--timeout-s", "40", "--no-report"});
  EXPECT_EQ(r.code, 1) << r.output;
  auto status = [&](const std::string& id) {
    return read_json(d + "/runs/" + id + "/run.json").at("status").get<std::string>();
  };
  EXPECT_EQ(status("normal-0000"), "ok");
  EXPECT_EQ(status("aborts-0000"), "crashed");
  EXPECT_EQ(status("diverges-0000"), "diverged");
  EXPECT_EQ(status("hangs-0000"), "hung");
  const json crashed = read_json(d + "/runs/aborts-0000/run.json");
  EXPECT_NE(crashed.at("detail").get<std::string>().find("signal 6"), std::string::npos) << crashed.dump();
  const Result m = lander({"campaign", "report", d, "--no-html"});
  EXPECT_EQ(m.code, 1) << m.output;
  const json j = read_json(d + "/campaign.json");
  EXPECT_EQ(j.at("overall").at("simulator_failures").get<int>(), 3);
  EXPECT_EQ(j.at("overall").at("landing_failures").get<int>(), 1);  // the normal 3 s run: timeout
  EXPECT_EQ(j.at("overall").at("landing_rate").at("of_runs").get<int>(), 1);
}

}  // namespace
}  // namespace lander::test
