// `lander bench loop --json FILE [--scenario FILE] [--duration S] [--vision-schedule S]`
// Runs a closed-loop scenario (default scenarios/default.yaml, no video) and writes its
// speed: simulated and wall seconds, real-time factor, the vision schedule that ran (serial
// or overlapped: the estimator on a worker beside the next frame's render), renders per
// frame, milliseconds per camera frame spent in rendering, the estimator, control (sensors,
// filters, controller), physics and waiting for the vision worker. --frames-csv F: the vision
// stage's cost and result per camera frame (with the predicted blur, the least target depth
// the stack told its detector, the detection's height next to the true height, and the
// platform's pose in the camera at the exposure's middle, true_* from the truth and det_* from
// the detection: a detector's error frame by frame). --save-frames DIR: every camera frame as
// PNG, for `lander bench frames` (the detector alone on the same frames with the same
// predicted blur).
#include <fstream>
#include <iostream>

#include "command.h"
#include "lander/sim/util/output_files.h"
#include "lander/sim/run.h"

namespace lander::cli {
namespace {

int bench_loop(const Args& args) {
  ArgParser a(args, {"json", "scenario", "duration", "out", "vision-schedule", "frames-csv", "save-frames"}, {});
  if (!a.has("json")) throw UsageError("usage: lander bench loop --json FILE [--scenario FILE]");
  sim::Scenario s = sim::Scenario::load(a.value("scenario", std::string(LANDER_SCENARIOS_DIR) + "/default.yaml"));
  s.duration_s = a.number("duration", s.duration_s, 0.1);
  s.validate();
  sim::RunOptions o;
  o.out_dir = a.value("out", "/tmp/lander_bench_loop");
  o.vision_schedule = a.choice("vision-schedule", "auto", sim::kVisionSchedules);
  o.vision_profile_csv = a.value("frames-csv");
  o.save_frames_dir = a.value("save-frames");
  const nlohmann::ordered_json summary = sim::run_scenario(s, o);
  std::ifstream perf_file(o.out_dir + "/performance.json");
  const nlohmann::ordered_json perf = nlohmann::ordered_json::parse(perf_file);
  sim::write_json_file(a.value("json"), perf);
  std::cout << sim::json_text(perf);
  std::cerr << "scenario " << s.name << ": " << summary.at("outcome").get<std::string>() << "\n";
  return kExitOk;
}

const LanderCommand reg("loop", "loop --json FILE [--scenario FILE] [--duration S] [--vision-schedule auto|serial|overlap] [--frames-csv F] [--save-frames DIR]", Kind::Bench,
                        bench_loop);

}  // namespace
}  // namespace lander::cli
