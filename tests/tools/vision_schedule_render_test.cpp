// The closed loop's two vision schedules (RunOptions::vision_schedule): the estimator on a
// worker thread, joined at each result's delivery time, must give exactly the outputs of the
// serial schedule (detect in line at the exposure end). Compared byte for byte: summary.json
// and trace.csv, on a landing approach with a vision latency shorter than a frame (the worker
// is joined at the result's delivery step) and injected vision faults (their hooks act at the
// join), and on a path-following run with a latency longer than a frame (the worker runs
// beside the next frame's render and is joined when that frame is due; the path stage on the
// worker, the decision to run it on the main thread).
#include <gtest/gtest.h>

#include <fstream>

#include "common/json_checks.h"
#include "tools/support/cli.h"

namespace {

using lander::test::slurp;

// Runs `scenario_text` with both schedules and compares their outputs.
// Returns the serial run's summary.
nlohmann::json expect_same_outputs(const std::string& name, const std::string& scenario_text) {
  const std::string dir = lander::test::make_temp_dir("lander_sched_" + name);
  std::ofstream(dir + "/s.yaml") << scenario_text;
  for (const char* sched : {"serial", "overlap"}) {
    const lander::test::CliResult r = lander::test::run_lander(
        {"run", dir + "/s.yaml", "--out", dir + "/" + sched, "--quiet", "--vision-schedule", sched});
    EXPECT_TRUE(r.code == 0 || r.code == 1) << r.output;  // landed or not: a complete run
    const nlohmann::json perf = lander::test::read_json_file(dir + "/" + sched + "/performance.json");
    EXPECT_EQ(lander::test::string_at(perf, "vision_schedule"),
              std::string(sched) == "serial" ? "serial" : "overlapped");
  }
  for (const char* f : {"summary.json", "trace.csv"}) {
    const std::string a = slurp(dir + "/serial/" + f);
    EXPECT_GT(a.size(), 100u) << name << ": " << f;
    EXPECT_EQ(a, slurp(dir + "/overlap/" + f)) << name << ": " << f << " differs between the schedules";
  }
  return lander::test::read_json_file(dir + "/serial/summary.json");
}

std::string with_duration(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

TEST(VisionSchedule, OverlappedApproachWithVisionFaultsMatchesTheSerialRunBitForBit) {
  // 8 s of the default approach (detection, keyframes, altitude fusion with vision, follow),
  // a 20 ms vision latency (due before the next frame), three injected outliers and a NaN pose.
  std::string text = with_duration(slurp(std::string(LANDER_SCENARIOS_DIR) + "/default.yaml"),
                                   "duration_s: 90", "duration_s: 8");
  text += "computer:\n  vision_latency_ms: 20\n"
          "faults:\n  vision_outlier_t_s: 3.0\n  nan_vision_t_s: 5.0\n  nan_vision_duration_s: 0.2\n";
  const nlohmann::json summary = expect_same_outputs("approach", text);
  EXPECT_GT(lander::test::number_at(summary, "vision.detections"), 0);
}

TEST(VisionSchedule, OverlappedBlurAwareDetectionMatchesTheSerialRunBitForBit) {
  // 4 s of the motion-blur landing (20 ms exposure): the flight software predicts each
  // frame's blur on the loop's thread and the detector's blur-aware pass (issue 12) runs on
  // the worker; a 40 ms vision latency lets the schedule overlap.
  std::string text = with_duration(slurp(std::string(LANDER_SCENARIOS_DIR) + "/motion_blur.yaml"),
                                   "duration_s: 90", "duration_s: 4");
  text += "computer:\n  vision_latency_ms: 40\n";
  const nlohmann::json summary = expect_same_outputs("blur", text);
  // Frames the plain passes missed were found in the deblurred frame.
  EXPECT_GT(lander::test::number_at(summary, "vision.detections_deblurred"), 0);
}

TEST(VisionSchedule, OverlappedPathFollowingMatchesTheSerialRunBitForBit) {
  std::string text = with_duration(slurp(std::string(LANDER_SCENARIOS_DIR) + "/path_follow.yaml"),
                                   "duration_s: 120", "duration_s: 6");
  text += "computer:\n  vision_latency_ms: 50\n";
  const nlohmann::json summary = expect_same_outputs("path", text);
  // The route was followed on the path stage's points (computed on the worker).
  EXPECT_GT(lander::test::number_at(summary, "path_following.guidance_steps"), 0);
}

}  // namespace
