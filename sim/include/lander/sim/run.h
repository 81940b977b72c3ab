// Runs one scenario and writes its outputs (docs/design/architecture.md, "Outputs of a run"):
// summary.json (versioned schema, deterministic for a scenario and seed), trace.csv,
// scenario.resolved.yaml, performance.json (wall-clock timings), and with video on,
// camera.mp4 and chase.mp4.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lander/flight/flight_software.h"
#include "lander/sim/scenario.h"

namespace lander::sim {

class World;
struct CameraFrame;
struct VehicleTruth;

// What a stepping caller sees after each physics step of a closed loop (the Python package's
// lander.Sim): the time, the world and the vehicle's truth, and the camera frame whose
// exposure ended in this step (null if none). Valid during the call only.
struct StepView {
  double t_s{0.0};
  const World* world{nullptr};
  const VehicleTruth* truth{nullptr};
  const CameraFrame* frame{nullptr};
};

// summary.json "outcome": landed | timeout | touched_ground | tipped_over (the vehicle fell
// over on the ground or platform) | diverged (NaN or runaway physics state, or a MuJoCo
// instability warning; outputs complete to that time) | error (an exception; trace.csv and
// the videos are discarded) | scripted_flight_complete (kinematic runs). "crashed" is left to
// the campaign runner for a simulator process that died. Version 2: crashed -> tipped_over,
// diverged, rejected_samples.
constexpr int kSummarySchemaVersion = 2;

struct RunOptions {
  std::string out_dir;         ///< created if missing; files inside are overwritten
  bool video{false};           ///< write camera.mp4 and chase.mp4
  bool progress{false};        ///< print progress to stderr
  std::string record_vision;   ///< closed loop: write the delivered vision results here
                               ///< (loop/vision_log.h; exact, for replay)
  std::string replay_vision;   ///< closed loop: deliver these recorded vision results instead
                               ///< of rendering and detecting (no renderer without video)
  std::string save_frames_dir; ///< write every camera frame as PNG (frame_NNNNN.png) here
  // Vision schedule of the closed loop. auto: the estimator works on frame k on a worker
  // thread while the plant and the camera go on, and its result is joined at its delivery
  // time (t_end + computer.vision_latency_ms), when that latency is at least a frame period
  // and not measured; serial otherwise. serial: detect at the exposure end, in line. overlap:
  // always the worker. All three give the same outputs bit for bit (a test checks).
  std::string vision_schedule{"auto"};
  // When set: one row per camera frame with the vision stage's cost and what it found
  // (frame, t, height, detected, status, tracking ROI used, code searched, ring detector wall
  // and CPU ms, path stage ms), for `lander bench loop --frames-csv`.
  std::string vision_profile_csv;
  // The flight software to fly instead of the scenario's (make_flight_software): the Python
  // package's flight softwares written in Python. Called once, before any output is written.
  std::function<std::unique_ptr<flight::FlightSoftware>(const Scenario&)> flight_factory;
  // Called on the loop's thread after every physics step of a closed loop (never changes the
  // run: it may only look, or wait). An exception from it ends the run as an error.
  std::function<void(const StepView&)> step_observer;
};

// The values of RunOptions::vision_schedule.
inline const std::vector<std::string> kVisionSchedules = {"auto", "serial", "overlap"};

// Checks everything that can be checked before any output is written: the scenario, the
// model and target files, the output directory's parent. Throws ConfigError.
void preflight(const Scenario& s, const RunOptions& o);

// Runs the scenario. Inputs are checked first (preflight); once outputs are being written,
// a failure still leaves a summary.json whose outcome says what went wrong, and rethrows.
// Every file is written under a temporary name and renamed when complete (output_files.h);
// a failed write throws OutputError naming the file.
nlohmann::ordered_json run_scenario(const Scenario& s, const RunOptions& o);

}  // namespace lander::sim
