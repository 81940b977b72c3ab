// The closed loop (DESIGN.md, "The loop"): the plant, the sensor rig, the flight stack and the
// recorder on one deterministic fixed-step scheduler (physics 1 kHz by default).
//
// Per physics step at time t: the camera renders what falls at t and, when an exposure ends,
// the flight stack's detector processes the frame, whose result is delivered after the
// processing latency; the plant steps with the rotor command; the sensors sample the new
// truth and transmit (after their latencies); everything delivered reaches the flight stack,
// whose controller's inner loop runs on each IMU sample and sets the rotor command; the
// recorder judges and logs. The flight stack is built from the scenario's `flight:` section
// only and never sees the plant's parameters or the truth.
#include <chrono>
#include <iostream>

#include <fmt/format.h>

#include "lander/estimator/altitude_vision.h"
#include "lander/flight/flight_stack.h"
#include "lander/sim/loop.h"
#include "lander/sim/loop/vision_log.h"
#include "lander/sim/util/output_files.h"
#include "lander/sim/plant/plant.h"
#include "lander/sim/recorder/recorder.h"
#include "lander/sim/sensors/sensors.h"
#include "loop/fault_hooks.h"

namespace lander::sim {

using Json = nlohmann::ordered_json;

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// Scenario fault keys that act on the sensors' physics (seed 004's robustness tests).
void schedule_sensor_faults(const FaultParams& F, SensorSuite& sensors) {
  if (F.gps_step_t_s >= 0) sensors.gps().inject_offset(F.gps_step_t_s, F.gps_step_duration_s, F.gps_step_W_m);
  if (F.ultrasonic_garbage_t_s >= 0) {
    sensors.ultrasonic().inject_garbage(F.ultrasonic_garbage_t_s, F.ultrasonic_garbage_duration_s);
  }
}

// Corrupted-sample test hooks: on the way to the flight software, after the metrics.
void corrupt_on_the_wire(const FaultParams& F, double t, SensorSuite::Sampled& smp) {
  if (smp.imu && fault_active(t, F.nan_imu_t_s, F.nan_imu_duration_s)) corrupt_sample(*smp.imu);
  if (smp.magnetometer && fault_active(t, F.nan_magnetometer_t_s, F.nan_magnetometer_duration_s)) {
    corrupt_sample(*smp.magnetometer);
  }
  if (smp.baro && fault_active(t, F.nan_baro_t_s, F.nan_baro_duration_s)) corrupt_sample(*smp.baro);
  if (smp.gps && fault_active(t, F.absurd_gps_t_s, F.absurd_gps_duration_s)) corrupt_sample(*smp.gps);
  if (smp.ultrasonic && fault_active(t, F.nan_ultrasonic_t_s, F.nan_ultrasonic_duration_s)) {
    corrupt_sample(*smp.ultrasonic);
  }
}

// Injected vision outliers (faults.vision_outlier_*): from the first detection at or after
// the start time, that many detections have their pose pushed along the optical axis.
class VisionOutliers {
 public:
  explicit VisionOutliers(const FaultParams& F) : F_(F) {}
  bool apply(double t_mid, RingDetection& det) {
    if (F_.vision_outlier_t_s >= 0 && t_mid >= F_.vision_outlier_t_s && left_ == 0 &&
        F_.vision_outlier_frames > 0 && !started_) {
      left_ = F_.vision_outlier_frames;
      started_ = true;
    }
    if (!det.detected || left_ == 0) return false;
    det.X_CP.translation().z() += F_.vision_outlier_m;
    --left_;
    return true;
  }

 private:
  const FaultParams& F_;
  int left_ = 0;
  bool started_ = false;
};

}  // namespace

LoopResult run_closed_loop(const Scenario& s, const RunOptions& o, World& world, Renderer* renderer,
                           Json& summary) {
  const double dt = s.world.physics_dt_s;
  const FaultParams& F = s.faults;
  Plant plant(s, world);
  SensorSuite sensors(s.sensors, s.seed);
  schedule_sensor_faults(F, sensors);
  CameraRig camera(s.camera, derive_seed(s.seed, "camera"), dt);
  flight::FlightStack flight(s.flight);
  // What the flight software was built from, beside the resolved scenario (the plant's truth).
  write_file_atomic(o.out_dir + "/flight.resolved.yaml", yaml_to_string(params_to_yaml(flight.config())));
  DelayQueue<flight::VisionResult> vision_q;
  Recorder recorder(s, o, world, renderer);
  VisionOutliers outliers(F);
  // Recorded vision (change indication): delivered at the recorded times, nothing rendered.
  const bool replay = !o.replay_vision.empty();
  std::vector<VisionLogEntry> vision_log;
  if (replay) {
    for (const VisionLogEntry& e : read_vision_log(o.replay_vision)) vision_q.push(e.result, e.deliver_t_s);
  } else if (renderer == nullptr) {
    throw std::logic_error("run_closed_loop: no renderer");
  }

  LoopResult res;
  RotorArray w_cmd;
  w_cmd.fill(plant.hover_speed_radps());
  Outcome outcome{"timeout", fmt::format("no landing within duration_s = {:.1f} s", s.duration_s)};
  const int n_steps = static_cast<int>(std::floor(s.duration_s / dt + 0.5));
  const auto wall0 = Clock::now();
  for (int k = 0; k < n_steps; ++k) {
    const double t = k * dt, tn = (k + 1) * dt;
    run_process_fault_hooks(F, t);  // abort / hang test hooks
    // ---- camera and vision ----
    std::optional<CameraFrame> frame;
    if (!replay) frame = camera.advance(t, world, *renderer, &res.render_ms);
    if (frame) {
      if (!o.save_frames_dir.empty()) save_frame_png(o.save_frames_dir, *frame);
      const auto t0 = Clock::now();
      RingDetection det = flight.detect(frame->bgr);
      const double t_mid = frame->exposure.mid();
      // The path stage (seed 003) runs only while the flight software can use it.
      std::optional<PathObservation> path;
      if (flight.wants_path()) path = flight.detect_path(frame->bgr, t_mid);
      const double proc_ms = ms_since(t0);
      res.estimator_ms += proc_ms;
      if (outliers.apply(t_mid, det)) recorder.count_outlier_injected();
      flight::VisionResult vr = flight.vision_result(det, t_mid);
      vr.path = std::move(path);
      recorder.on_frame(*frame, det, vr, flight);
      if (fault_active(t_mid, F.nan_vision_t_s, F.nan_vision_duration_s)) {
        corrupt_observation(vr.obs);  // test hook: a "detection" with a NaN pose
        vr.h_plane_m = height_above_target_m(vr.obs.X_CP, flight.mount().X_BC());
      }
      const double latency = s.computer.measured_latency ? proc_ms * 1e-3 : s.computer.vision_latency_s;
      vision_q.push(vr, frame->exposure.t_end_s + latency);
      if (!o.record_vision.empty()) {
        vision_log.push_back({frame->index, frame->exposure.t_end_s + latency, vr});
      }
    }
    // ---- plant ----
    const auto tp0 = Clock::now();
    std::string diverged;
    if (!plant.step(k, w_cmd, &diverged)) {
      outcome = {"diverged", diverged};
      break;
    }
    res.physics_ms += ms_since(tp0);
    const VehicleTruth& truth = plant.truth();
    // ---- sensors -> flight stack ----
    const auto tc0 = Clock::now();
    SensorSuite::Sampled smp = sensors.sample(truth);
    recorder.on_samples(smp, truth);
    corrupt_on_the_wire(F, tn, smp);
    sensors.transmit(smp);
    const SensorSuite::Delivered in = sensors.deliver(tn);
    for (const BaroSample& b : in.baro) flight.on_baro(b);
    for (const GpsSample& g : in.gps) flight.on_gps(g);
    for (const UltrasonicSample& u : in.ultrasonic) flight.on_ultrasonic(u);
    for (const flight::VisionResult& vr : vision_q.pop_ready(tn)) flight.on_vision(vr);
    for (const MagSample& m : in.magnetometer) flight.on_mag(m);
    for (const ImuSample& imu : in.imu) {
      if (const auto cmd = flight.on_imu(imu)) {
        for (int r = 0; r < kNumRotors; ++r) w_cmd[r] = cmd->w_radps[r];
      }
    }
    res.control_ms += ms_since(tc0);
    // ---- recorder ----
    res.sim_s = tn;
    if (std::optional<Outcome> end = recorder.on_step(k, truth, flight, plant.rotor_speeds_radps())) {
      outcome = *end;
      break;
    }
    if (o.progress && k % 5000 == 0) {
      std::cerr << fmt::format("\rt = {:.1f} s  mode {}            ", tn,
                               ctl::to_string(flight.controller().mode()))
                << std::flush;
    }
  }
  if (o.progress) std::cerr << "\n";
  res.wall_s = std::chrono::duration<double>(Clock::now() - wall0).count();
  res.frames = camera.frames();
  res.outliers_injected = recorder.outliers_injected();
  recorder.finish(outcome, flight, summary);
  if (!o.record_vision.empty()) write_vision_log(o.record_vision, vision_log);
  return res;
}

}  // namespace lander::sim
