// `lander run SCENARIO.yaml --out DIR [--video] [--quiet] [--vision-schedule auto|serial|overlap]`
// `--frames-csv F`: each camera frame's vision stage, as `lander bench loop --frames-csv` writes
// it (the true and the detected platform pose at the exposure's middle among its columns: the
// data `python3 -m lander.surrogate fit` reads).
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <vector>

#include "command.h"
#include "lander/sim/run.h"
#include "lander/sim/util/process.h"

namespace lander::cli {
namespace {

// Runs `python3 -m lander run ARGS` (LANDER_PYTHON names another interpreter; the package is
// found in this build's python/ folder first) in this process's group, and ends with its exit
// code: a signal that ends it ends this process the same way.
int python_run(const Args& args) {
  const char* py_env = std::getenv("LANDER_PYTHON");
  const std::string python = py_env && *py_env ? py_env : "/usr/bin/python3";
  std::vector<std::string> argv = {python, "-m", "lander", "run"};
  argv.insert(argv.end(), args.begin(), args.end());
  const char* old = std::getenv("PYTHONPATH");
  sim::SpawnOptions so;
  so.env = {"PYTHONPATH=" + std::string(LANDER_PYTHON_DIR) + (old && *old ? ":" + std::string(old) : "")};
  std::cout.flush();
  sim::ChildProcess child = [&] {
    try {
      return sim::ChildProcess::spawn(argv, so);
    } catch (const std::runtime_error& e) {
      throw ConfigError(std::string("flight.python: ") + e.what() + "; set LANDER_PYTHON to a python3");
    }
  }();
  const sim::ExitStatus st = child.wait();
  if (st.signaled) {
    signal(st.signal, SIG_DFL);
    raise(st.signal);
  }
  return st.code;
}

int run(const Args& args) {
  ArgParser a(args,
              {"out", "seed", "record-vision", "replay-vision", "save-frames", "frames-csv", "vision-schedule",
               "flight-plugin"},
              {"video", "quiet"});
  if (a.positional().size() != 1) {
    throw UsageError(
        "usage: lander run SCENARIO.yaml --out DIR [--seed N] [--video] [--quiet] "
        "[--record-vision FILE | --replay-vision FILE] [--save-frames DIR] [--frames-csv F] "
        "[--vision-schedule auto|serial|overlap] [--flight-plugin LIB.so]");
  }
  if (a.has("record-vision") && a.has("replay-vision")) {
    throw UsageError("--record-vision and --replay-vision exclude each other");
  }
  if (!a.has("out")) throw UsageError("missing --out DIR");
  sim::Scenario s = sim::Scenario::load(a.positional()[0]);
  // A flight software written in Python flies in the Python package: the same command there.
  if (!s.flight.python.empty() && !a.has("flight-plugin")) return python_run(args);
  // --seed replaces the scenario's seed (written to scenario.resolved.yaml).
  s.seed = static_cast<std::uint64_t>(a.integer("seed", static_cast<long long>(s.seed), 0));
  // --flight-plugin replaces the scenario's flight.plugin (a relative path from here).
  if (a.has("flight-plugin")) s.flight.plugin = std::filesystem::absolute(a.value("flight-plugin")).lexically_normal().string();
  sim::RunOptions o;
  o.out_dir = a.value("out");
  o.video = a.flag("video");
  o.progress = !a.flag("quiet");
  o.record_vision = a.value("record-vision");
  o.replay_vision = a.value("replay-vision");
  o.save_frames_dir = a.value("save-frames");
  o.vision_profile_csv = a.value("frames-csv");
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
                        "[--record-vision F | --replay-vision F] [--save-frames DIR] [--frames-csv F] "
                        "[--vision-schedule S] [--flight-plugin LIB.so]: run one scenario (with a plugin's flight "
                        "software)",
                        Kind::Command, run);

}  // namespace
}  // namespace lander::cli
