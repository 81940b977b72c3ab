// `lander bench altitude --json FILE [--quick]`
// Seed 004's experiments in the closed-loop simulator, with vision from rendered frames:
//   static:  the vehicle holds 5.12, 9.32, 13.52 and 17.72 m above the (static) platform
//            (the controller stays in observe: it never starts an approach);
//   hover:   10 m above the platform for 60 s in light wind;
//   descent: the default landing, from 10 m to touchdown;
//   faults:  the default landing with a GPS step of +5 m for 2 s, an ultrasonic garbage
//            burst, and vision outliers, each reporting the fused estimate's max deviation.
// Per sensor (baro, gps, vision, ultrasonic in range, fused): RMSE and max error per band
// (all, above_3m, below_3m), from each run's summary (altitude_fusion.by_sensor).
#include <cmath>
#include <fstream>
#include <iostream>
#include <sstream>

#include "command.h"
#include "lander/sim/util/output_files.h"
#include "lander/sim/run.h"

namespace lander::cli {
namespace {

using Json = nlohmann::ordered_json;

// The "altitude_fusion.by_sensor" object of a run's summary.json.
Json by_sensor(const std::string& run_dir) {
  const std::string path = run_dir + "/summary.json";
  std::ifstream f(path);
  if (!f) throw std::runtime_error(path + ": cannot read");
  const Json summary = Json::parse(f);
  return summary.at("altitude_fusion").at("by_sensor");
}

// Max |fused z - true z| over [t0, t1] from a run's trace.csv.
double max_fused_deviation(const std::string& trace_path, double t0, double t1) {
  std::ifstream f(trace_path);
  std::string line;
  std::getline(f, line);
  std::vector<std::string> cols;
  std::stringstream hs(line);
  for (std::string c; std::getline(hs, c, ',');) cols.push_back(c);
  auto idx = [&](const std::string& name) {
    for (std::size_t i = 0; i < cols.size(); ++i) if (cols[i] == name) return i;
    throw std::runtime_error("trace.csv has no column " + name);
  };
  const std::size_t it = idx("t_s"), iz = idx("z_WB_m"), ifz = idx("fused_z_m");
  double worst = 0;
  while (std::getline(f, line)) {
    std::vector<std::string> v;
    std::stringstream ls(line);
    for (std::string c; std::getline(ls, c, ',');) v.push_back(c);
    const double t = std::stod(v[it]);
    if (t < t0 || t > t1) continue;
    worst = std::max(worst, std::abs(std::stod(v[ifz]) - std::stod(v[iz])));
  }
  return worst;
}

int bench_altitude(const Args& args) {
  ArgParser a(args, {"json", "out"}, {"quick"});
  if (!a.has("json")) throw UsageError("usage: lander bench altitude --json FILE [--quick]");
  const bool quick = a.flag("quick");
  const std::string out = a.value("out", "/tmp/lander_bench_altitude");
  const std::string dir = std::string(LANDER_SCENARIOS_DIR);
  Json result;
  auto run = [&](sim::Scenario s, const std::string& name) {
    sim::RunOptions o;
    o.out_dir = out + "/" + name;
    s.name = name;
    std::cerr << "bench altitude: " << name << " (" << s.duration_s << " s simulated)\n";
    sim::run_scenario(s, o);
    return o.out_dir;
  };
  // Static: hold above the static platform, never approach.
  Json statics;
  const std::vector<double> heights = quick ? std::vector<double>{5.12} : std::vector<double>{5.12, 9.32, 13.52, 17.72};
  for (double h : heights) {
    sim::Scenario s = sim::Scenario::load(dir + "/static_platform.yaml");
    s.vehicle.start_p_W_m = {0.0, 0.0, 0.8 + h};
    s.flight.controller.landing.observe_frames = 1000000;
    s.duration_s = quick ? 10.0 : 30.0;
    const std::string d = run(s, "static_" + std::to_string(static_cast<int>(h * 100)));
    statics[std::to_string(h).substr(0, 5)] = by_sensor(d);
  }
  result["static"] = statics;
  {  // Hover at 10 m for 60 s in light wind.
    sim::Scenario s = sim::Scenario::load(dir + "/static_platform.yaml");
    s.vehicle.start_p_W_m = {0.0, 0.0, 10.8};
    s.flight.controller.landing.observe_frames = 1000000;
    s.wind.steady_W_mps = {1.0, 0.5, 0.0};
    s.wind.gust_std_horizontal_mps = 0.3;
    s.duration_s = quick ? 10.0 : 60.0;
    result["hover"] = by_sensor(run(s, "hover"));
  }
  {  // Descent: the default landing.
    sim::Scenario s = sim::Scenario::load(dir + "/default.yaml");
    if (quick) s.duration_s = 30.0;
    result["descent"] = by_sensor(run(s, "descent"));
  }
  // Faults: each is the default landing with one fault injected at t = 12 s; the fused
  // estimate's max deviation from truth over the fault window.
  struct Fault {
    const char* key;
    const char* text;
    double window_s;  // fault window analysed, from t = 12 s
    void (*inject)(sim::FaultParams&);
  };
  const Fault fault_runs[] = {
      {"gps_step", "GPS +5 m vertical step for 2 s at t = 12 s", 4.0,
       [](sim::FaultParams& f) {
         f.gps_step_t_s = 12.0;
         f.gps_step_duration_s = 2.0;
         f.gps_step_W_m = {0.0, 0.0, 5.0};
       }},
      {"ultrasonic_garbage", "ultrasonic garbage burst of 1 s at t = 12 s", 3.0,
       [](sim::FaultParams& f) {
         f.ultrasonic_garbage_t_s = 12.0;
         f.ultrasonic_garbage_duration_s = 1.0;
       }},
      {"vision_outliers", "5 consecutive vision poses 1 m off along the optical axis from t = 12 s",
       3.0,
       [](sim::FaultParams& f) {
         f.vision_outlier_t_s = 12.0;
         f.vision_outlier_frames = 5;
         f.vision_outlier_m = 1.0;
       }},
  };
  Json faults;
  for (const Fault& fr : fault_runs) {
    sim::Scenario s = sim::Scenario::load(dir + "/default.yaml");
    fr.inject(s.faults);
    if (quick) s.duration_s = 20.0;
    const std::string d = run(s, std::string("fault_") + fr.key);
    Json j;
    j["fault"] = fr.text;
    j["fused_max_deviation_m"] = max_fused_deviation(d + "/trace.csv", 12.0, 12.0 + fr.window_s);
    faults[fr.key] = j;
  }
  result["faults"] = faults;
  sim::write_json_file(a.value("json"), result);
  std::cout << sim::json_text(result);
  return kExitOk;
}

const LanderCommand reg("altitude", "altitude --json FILE [--quick] [--out DIR]", Kind::Bench,
                        bench_altitude);

}  // namespace
}  // namespace lander::cli
