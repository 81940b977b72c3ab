// `lander run` end to end on a short scripted flight: outputs exist, the resolved scenario
// loads back to the same scenario, and the same seed gives the same files.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "common/json_checks.h"
#include "lander/campaign/csv.h"
#include "lander/sim/run.h"
#include "lander/sim/scenario.h"
#include "tools/support/cli.h"

namespace {

using lander::test::slurp;

// Exit code of `lander ARGS` (its output is only needed when a check fails).
int run_lander(const std::string& args) { return lander::test::run_lander(args).code; }

TEST(CliRun, ShortScriptedFlightWritesItsOutputsDeterministically) {
  const std::string dir = lander::test::make_temp_dir("lander_run");
  // The flyover, cut to 1.5 s.
  std::ofstream(dir + "/s.yaml") << slurp(std::string(LANDER_SCENARIOS_DIR) + "/flyover.yaml")
                                 << "\n";
  std::string text = slurp(dir + "/s.yaml");
  text.replace(text.find("duration_s: 24"), 14, "duration_s: 1.5");
  std::ofstream(dir + "/s.yaml") << text;
  ASSERT_EQ(run_lander("run " + dir + "/s.yaml --out " + dir + "/a --quiet"), 0);
  ASSERT_EQ(run_lander("run " + dir + "/s.yaml --out " + dir + "/b --quiet"), 0);
  // Same scenario, same seed: identical outputs (wall-clock timings live in performance.json).
  for (const char* f : {"summary.json", "trace.csv", "scenario.resolved.yaml"}) {
    const std::string a = slurp(dir + "/a/" + f);
    EXPECT_FALSE(a.empty()) << f;
    EXPECT_EQ(a, slurp(dir + "/b/" + f)) << f;
  }
  const nlohmann::json summary = lander::test::read_json_file(dir + "/a/summary.json");
  EXPECT_EQ(lander::test::number_at(summary, "schema_version"), lander::sim::kSummarySchemaVersion);
  EXPECT_EQ(lander::test::string_at(summary, "outcome"), "scripted_flight_complete");
  EXPECT_EQ(lander::test::number_at(summary, "vision.frames"), 45);  // 1.5 s at 30 fps
  // The resolved scenario is a complete scenario: it loads, and saves to the same text.
  const lander::sim::Scenario resolved = lander::sim::Scenario::load(dir + "/a/scenario.resolved.yaml");
  EXPECT_EQ(lander::yaml_to_string(lander::params_to_yaml(resolved)),
            slurp(dir + "/a/scenario.resolved.yaml"));
  EXPECT_EQ(resolved.duration_s, 1.5);
}

TEST(CliRun, ClosedLoopRunsWithTheSameSeedGiveIdenticalOutputs) {
  const std::string dir = lander::test::make_temp_dir("lander_det");
  std::string text = slurp(std::string(LANDER_SCENARIOS_DIR) + "/default.yaml");
  text.replace(text.find("duration_s: 90"), 14, "duration_s: 2.0");
  std::ofstream(dir + "/s.yaml") << text;
  EXPECT_EQ(run_lander("run " + dir + "/s.yaml --out " + dir + "/a --quiet"), 1);  // not landed
  EXPECT_EQ(run_lander("run " + dir + "/s.yaml --out " + dir + "/b --quiet"), 1);
  for (const char* f : {"summary.json", "trace.csv"}) {
    const std::string a = slurp(dir + "/a/" + f);
    EXPECT_GT(a.size(), 100u) << f;
    EXPECT_EQ(a, slurp(dir + "/b/" + f)) << f;
  }
}

// --frames-csv: one row a camera frame with the platform's true pose at the exposure's middle
// and the detection's. The default landing's first 2 s (60 frames from 9.2 m, the platform 5 m
// to the side, the vehicle tilting towards it: true depths 5.0-9.1 m): every true depth finite
// in that range, and every detection within 1 cm of the truth (observed at most 3.9 mm; the
// estimator benchmark's views at 5-10 m: 1-3 cm at p95 over every tilt and blur).
TEST(CliRun, FramesCsvCarriesTheTrueAndTheDetectedPose) {
  constexpr double kDetectionTolM = 0.01;
  const std::string dir = lander::test::make_temp_dir("lander_frames_csv");
  std::string text = slurp(std::string(LANDER_SCENARIOS_DIR) + "/default.yaml");
  text.replace(text.find("duration_s: 90"), 14, "duration_s: 2.0");
  std::ofstream(dir + "/s.yaml") << text;
  ASSERT_EQ(run_lander("run " + dir + "/s.yaml --out " + dir + "/a --quiet --frames-csv " + dir + "/frames.csv"), 1);
  const lander::campaign::CsvTable t = lander::campaign::read_csv_file(dir + "/frames.csv");
  ASSERT_EQ(t.records.size(), 60u);  // 2 s at 30 fps
  auto num = [&](const lander::campaign::CsvTable::Record& r, const std::string& col) {
    const int c = t.column(col);
    EXPECT_GE(c, 0) << col;
    return c < 0 ? std::nan("") : std::stod(r.cells[static_cast<std::size_t>(c)]);
  };
  int detections = 0;
  for (const auto& r : t.records) {
    const double z = num(r, "true_z_CP_m");
    EXPECT_TRUE(z > 4.5 && z < 9.5) << "line " << r.line << ": " << z;
    if (num(r, "detected") != 1) continue;
    ++detections;
    const Eigen::Vector3d d(num(r, "det_x_CP_m") - num(r, "true_x_CP_m"), num(r, "det_y_CP_m") - num(r, "true_y_CP_m"),
                            num(r, "det_z_CP_m") - z);
    EXPECT_LT(d.norm(), kDetectionTolM) << "line " << r.line;
  }
  // Observed 20 of 60 (the platform enters the view's edge as the vehicle turns to it); the
  // loop is deterministic per seed, 15 leaves room for a detector change that loses a few.
  EXPECT_GE(detections, 15);
}

// The camera's frame timing in the loop (issue 54): of 3 s of frames (90) a third are dropped
// and never reach the flight software (its vision count is the delivered frames), the stamps
// carry their jitter, the latency its mean; the same seed gives the same files. The keys at 0
// (the scenario as shipped): every frame delivered with an exact stamp.
TEST(CliRun, DroppedAndJitteredFramesAreCountedAndDeterministic) {
  const std::string dir = lander::test::make_temp_dir("lander_frame_timing");
  std::string text = slurp(std::string(LANDER_SCENARIOS_DIR) + "/default.yaml");
  text.replace(text.find("duration_s: 90"), 14, "duration_s: 3.0");
  std::ofstream(dir + "/plain.yaml") << text;
  std::ofstream(dir + "/s.yaml") << text
                                 << "camera:\n  frame_drop_prob: 0.3\n  timestamp_jitter_ms: 4\n"
                                    "  delivery_latency_ms: 20\n  delivery_latency_std_ms: 5\n";
  ASSERT_EQ(run_lander("run " + dir + "/s.yaml --out " + dir + "/a --quiet"), 1);  // 3 s: not landed
  ASSERT_EQ(run_lander("run " + dir + "/s.yaml --out " + dir + "/b --quiet"), 1);
  for (const char* f : {"summary.json", "trace.csv"}) EXPECT_EQ(slurp(dir + "/a/" + f), slurp(dir + "/b/" + f)) << f;
  using lander::test::number_at;
  const nlohmann::json s = lander::test::read_json_file(dir + "/a/summary.json");
  constexpr double kFrames = 90;  // 3 s at 30 fps
  EXPECT_EQ(number_at(s, "camera_delivery.frames_captured"), kFrames);
  const double dropped = number_at(s, "camera_delivery.frames_dropped");
  const double delivered = number_at(s, "camera_delivery.frames_delivered");
  EXPECT_EQ(dropped + delivered, kFrames);
  // Binomial(90, 0.3): 27 +- 4.3 (1 sigma); 4 sigma either way.
  EXPECT_NEAR(dropped, 27.0, 4 * std::sqrt(kFrames * 0.3 * 0.7));
  EXPECT_EQ(number_at(s, "vision.frames"), delivered);
  // ~63 stamps: their rms within 35 % of 4 ms (4 sigma of a std from 63 draws: 4 / sqrt(126)),
  // the latency's mean within 4 sigma of 20 ms (5 / sqrt(63) = 0.63 ms).
  EXPECT_NEAR(number_at(s, "camera_delivery.stamp_error_ms.rms"), 4.0, 4.0 * 4.0 / std::sqrt(2 * 63.0));
  EXPECT_NEAR(number_at(s, "camera_delivery.delivery_latency_ms.mean"), 20.0, 4 * 5.0 / std::sqrt(63.0));

  ASSERT_EQ(run_lander("run " + dir + "/plain.yaml --out " + dir + "/plain --quiet"), 1);
  const nlohmann::json p = lander::test::read_json_file(dir + "/plain/summary.json");
  EXPECT_EQ(number_at(p, "camera_delivery.frames_dropped"), 0);
  EXPECT_EQ(number_at(p, "camera_delivery.frames_delivered"), kFrames);
  EXPECT_EQ(number_at(p, "vision.frames"), kFrames);
  EXPECT_EQ(number_at(p, "camera_delivery.stamp_error_ms.max_abs"), 0.0);
  EXPECT_EQ(number_at(p, "camera_delivery.delivery_latency_ms.max"), 0.0);
}

TEST(CliRun, ClosedLoopWithVideoWritesBothVideosAndASummary) {
  const std::string dir = lander::test::make_temp_dir("lander_video");
  std::string text = slurp(std::string(LANDER_SCENARIOS_DIR) + "/default.yaml");
  text.replace(text.find("duration_s: 90"), 14, "duration_s: 1.0");
  std::ofstream(dir + "/s.yaml") << text;
  // One simulated second cannot land: exit code 1 (did not land), outputs complete.
  EXPECT_EQ(run_lander("run " + dir + "/s.yaml --out " + dir + "/v --video --quiet"), 1);
  const nlohmann::json summary = lander::test::read_json_file(dir + "/v/summary.json");
  EXPECT_EQ(lander::test::string_at(summary, "outcome"), "timeout");
  EXPECT_EQ(lander::test::number_at(summary, "vision.frames"), 30);
  for (const char* f : {"camera.mp4", "chase.mp4"}) {
    EXPECT_GT(slurp(dir + "/v/" + f).size(), 10000u) << f;  // 30 frames of H.264, not a header
  }
}

}  // namespace

namespace {

// `lander batch` on two seeds of a 1 s closed-loop run (a campaign of one scenario with
// explicit seeds): one run directory per seed, a row per run in campaign.csv, campaign.json
// counting them; the seeds differ (different sensor noise), and each seed's run is the one
// `lander run --seed` gives.
TEST(CliBatch, TwoSeedsGiveOneRunEachAndTheStatistics) {
  const std::string dir = lander::test::make_temp_dir("lander_batch");
  std::string text = slurp(std::string(LANDER_SCENARIOS_DIR) + "/default.yaml");
  text.replace(text.find("duration_s: 90"), 14, "duration_s: 1.0");
  std::ofstream(dir + "/s.yaml") << text;
  const auto r = lander::test::run_lander("batch " + dir + "/s.yaml --seeds 2 --first-seed 40 --out " +
                                          dir + "/mc");
  ASSERT_EQ(r.code, 0) << r.output;  // both runs ended (timeout: 1 s is too short to land)
  const nlohmann::json j = lander::test::read_json_file(dir + "/mc/campaign.json");
  EXPECT_EQ(lander::test::number_at(j, "overall.runs"), 2);
  EXPECT_EQ(lander::test::number_at(j, "overall.landed"), 0);
  EXPECT_EQ(lander::test::number_at(j, "overall.outcomes.timeout"), 2);
  const std::string csv = slurp(dir + "/mc/campaign.csv");
  EXPECT_NE(csv.find("\ns-0000,s,40,timeout,0,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\ns-0001,s,41,timeout,0,"), std::string::npos) << csv;
  const std::string t40 = slurp(dir + "/mc/runs/s-0000/trace.csv");
  const std::string t41 = slurp(dir + "/mc/runs/s-0001/trace.csv");
  ASSERT_GT(t40.size(), 100u);
  EXPECT_NE(t40, t41);  // other seed, other noise
  ASSERT_EQ(run_lander("run " + dir + "/s.yaml --seed 41 --out " + dir + "/one --quiet"), 1);
  EXPECT_EQ(slurp(dir + "/one/trace.csv"), t41);
}

}  // namespace
