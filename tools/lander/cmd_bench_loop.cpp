// `lander bench loop --json FILE [--scenario FILE] [--duration S]`
// Runs a closed-loop scenario (default scenarios/default.yaml, no video) and writes its
// speed: simulated and wall seconds, real-time factor, milliseconds per camera frame spent
// in rendering, the estimator, control (sensors, filters, controller) and physics.
#include <fstream>
#include <iostream>
#include <sstream>

#include "command.h"
#include "lander/sim/json.h"
#include "lander/sim/run.h"

namespace lander::cli {
namespace {

int bench_loop(const Args& args) {
  ArgParser a(args, {"json", "scenario", "duration", "out"}, {});
  if (!a.has("json")) throw UsageError("usage: lander bench loop --json FILE [--scenario FILE]");
  sim::Scenario s = sim::Scenario::load(a.value("scenario", std::string(LANDER_SCENARIOS_DIR) + "/default.yaml"));
  s.duration_s = a.number("duration", s.duration_s, 0.1);
  s.validate();
  sim::RunOptions o;
  o.out_dir = a.value("out", "/tmp/lander_bench_loop");
  const sim::Json summary = sim::run_scenario(s, o);
  std::ifstream perf_file(o.out_dir + "/performance.json");
  std::stringstream perf;
  perf << perf_file.rdbuf();
  sim::write_text_file(a.value("json"), perf.str());
  std::cout << perf.str();
  std::cerr << "scenario " << s.name << ": " << summary.find("outcome")->string() << "\n";
  return kExitOk;
}

const LanderCommand reg("loop", "loop --json FILE [--scenario FILE] [--duration S]", Kind::Bench,
                        bench_loop);

}  // namespace
}  // namespace lander::cli
