// `lander run SCENARIO.yaml --out DIR [--video] [--quiet] [--vision-schedule auto|serial|overlap]`
#include <iostream>

#include "command.h"
#include "lander/sim/run.h"

namespace lander::cli {
namespace {

int run(const Args& args) {
  ArgParser a(args, {"out", "seed", "record-vision", "replay-vision", "save-frames", "vision-schedule"}, {"video", "quiet"});
  if (a.positional().size() != 1) {
    throw UsageError(
        "usage: lander run SCENARIO.yaml --out DIR [--seed N] [--video] [--quiet] "
        "[--record-vision FILE | --replay-vision FILE] [--save-frames DIR] "
        "[--vision-schedule auto|serial|overlap]");
  }
  if (a.has("record-vision") && a.has("replay-vision")) {
    throw UsageError("--record-vision and --replay-vision exclude each other");
  }
  if (!a.has("out")) throw UsageError("missing --out DIR");
  sim::Scenario s = sim::Scenario::load(a.positional()[0]);
  // --seed replaces the scenario's seed (written to scenario.resolved.yaml).
  s.seed = static_cast<std::uint64_t>(a.integer("seed", static_cast<long long>(s.seed), 0));
  sim::RunOptions o;
  o.out_dir = a.value("out");
  o.video = a.flag("video");
  o.progress = !a.flag("quiet");
  o.record_vision = a.value("record-vision");
  o.replay_vision = a.value("replay-vision");
  o.save_frames_dir = a.value("save-frames");
  // The estimator on a worker thread or in line: same outputs bit for bit (README, Performance).
  o.vision_schedule = a.choice("vision-schedule", "auto", sim::kVisionSchedules);
  const nlohmann::ordered_json summary = sim::run_scenario(s, o);
  const std::string outcome = summary.at("outcome").get<std::string>();
  std::cout << "lander run: " << s.name << ": " << outcome << "\noutputs in " << o.out_dir
            << "/ (summary.json, trace.csv, scenario.resolved.yaml"
            << (o.video ? ", camera.mp4, chase.mp4" : "") << ")\n";
  // Success: the outcome the scenario expects (a landing by default; the route's end for a
  // path-following run), or a scripted flight flown to its end.
  return (outcome == s.expect_outcome || outcome == "scripted_flight_complete") ? kExitOk : kExitFailure;
}

const LanderCommand reg("run",
                        "run SCENARIO.yaml --out DIR [--seed N] [--video] [--quiet] "
                        "[--record-vision F | --replay-vision F] [--save-frames DIR] [--vision-schedule S]: run one scenario",
                        Kind::Command, run);

}  // namespace
}  // namespace lander::cli
