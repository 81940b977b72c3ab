// The closed-loop run: physics, sensors, camera and flight software on one fixed-step
// scheduler (see closed_loop.cpp). run_scenario() runs it for vehicle.control: closed_loop.
#pragma once

#include <memory>

#include <nlohmann/json.hpp>

#include "lander/flight/flight_software.h"
#include "lander/sim/render/renderer.h"
#include "lander/sim/run.h"
#include "lander/sim/scenario.h"
#include "lander/sim/plant/world.h"

namespace lander::sim {

// Where the wall time went (ms summed over the run) and how much was simulated.
struct LoopResult {
  double sim_s{0.0};
  double wall_s{0.0};
  double render_ms{0.0};     ///< camera renders (incl. blur sub-frames)
  double estimator_ms{0.0};  ///< vision stage on each frame (ring detector + path stage)
  double detector_ms{0.0};   ///< of which the ring detector (wall)
  double detector_cpu_ms{0.0};  ///< the ring detector's thread CPU time
  double path_stage_ms{0.0}; ///< of which the path stage (seed 003)
  double control_ms{0.0};    ///< sensors, navigation, altitude fusion, controller
  double physics_ms{0.0};    ///< motors, ground-effect rays, wind, mj_step
  double vision_wait_ms{0.0}; ///< main thread blocked joining the vision worker (overlap)
  bool overlapped{false};     ///< the vision worker ran (RunOptions::vision_schedule)
  int frames{0};
  long renders{0};            ///< camera renders, blur sub-renders included
  int outliers_injected{0};
  /// Simulated past duration_s to judge a touchdown whose motors were cut before it (s).
  double judged_past_duration_s{0.0};
};

// End of the exposure that starts at t_start_s.
inline double camera_exposure_end(const CameraParams& p, double t_start_s) {
  return t_start_s + p.exposure_s;
}

// The closed loop: the plant, the sensor rig, the flight stack (built from the scenario's
// `flight:` section only) and the recorder on one fixed-step scheduler. run() fills `summary`
// (landed, outcome, touchdown figures, transitions, vision counts, altitude-fusion errors) and
// writes trace.csv and the videos into o.out_dir. `renderer` may be null only when
// o.replay_vision is set and o.video is not. `flight` is the run's flight software
// (make_flight_software, loop/flight_factory.h), reached through the seam only. One run per
// object.
class ClosedLoop {
 public:
  ClosedLoop(const Scenario& s, const RunOptions& o, World& world, Renderer* renderer,
             std::unique_ptr<flight::FlightSoftware> flight);
  ~ClosedLoop();
  ClosedLoop(const ClosedLoop&) = delete;
  ClosedLoop& operator=(const ClosedLoop&) = delete;
  LoopResult run(nlohmann::ordered_json& summary);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lander::sim
