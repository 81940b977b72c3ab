// The closed loop (docs/design/architecture.md, "The loop"): the plant, the sensor rig, the
// flight software and the recorder on one deterministic fixed-step scheduler (physics 1 kHz
// by default).
//
// Per physics step at time t: the camera renders what falls at t and, when an exposure ends,
// the flight stack's detector processes the frame, whose result is delivered after the
// processing latency (on a worker thread while the plant goes on, joined at the delivery time
// at the latest: see VisionStage); the plant steps with the rotor command; the sensors sample the new
// truth and transmit (after their latencies); everything delivered reaches the flight stack,
// whose controller's inner loop runs on each IMU sample and sets the rotor command; the
// recorder judges and logs. The flight software (ours, FlightStack, or a plugin's) is built
// from the scenario's `flight:` section only, never sees the plant's parameters or the truth,
// and is reached through the seam only (flight/include/lander/flight/flight_software.h).
#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <ctime>
#include <exception>
#include <iostream>
#include <limits>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>

#include <fmt/format.h>

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

// A vision fault the flight software cannot take: the run's configuration is wrong.
void inject_or_refuse(flight::FrameJob& job, const flight::VisionFault& f, const char* key,
                      const flight::FlightSoftware& fs) {
  if (!job.inject(f)) {
    throw ConfigError(fmt::format("invalid value for '{}': the flight software '{}' takes no injected vision "
                                  "faults (its frame results carry no pose the simulator can move)",
                                  key, fs.info().name));
  }
}

// Injected vision outliers (faults.vision_outlier_*): from the first detection at or after
// the start time, that many detections have their pose pushed along the optical axis.
class VisionOutliers {
 public:
  explicit VisionOutliers(const FaultParams& F) : F_(F) {}
  bool apply(double t_mid, bool detected, flight::FrameJob& job, const flight::FlightSoftware& fs) {
    if (F_.vision_outlier_t_s >= 0 && t_mid >= F_.vision_outlier_t_s && left_ == 0 &&
        F_.vision_outlier_frames > 0 && !started_) {
      left_ = F_.vision_outlier_frames;
      started_ = true;
    }
    if (!detected || left_ == 0) return false;
    flight::VisionFault f;
    f.kind = flight::VisionFault::Kind::kOffsetAlongAxis;
    f.offset_m = F_.vision_outlier_m;
    inject_or_refuse(job, f, "faults.vision_outlier_m", fs);
    --left_;
    return true;
  }

 private:
  const FaultParams& F_;
  int left_ = 0;
  bool started_ = false;
};

// summary.json's camera_delivery: the frames the flight software received of those captured.
Json delivery_json(const FrameDeliveryStats& d) {
  return Json{{"frames_captured", d.captured()},
              {"frames_delivered", d.delivered()},
              {"frames_dropped", d.dropped()},
              {"stamp_error_ms", {{"rms", 1e3 * d.stamp_error_rms_s()}, {"max_abs", 1e3 * d.stamp_error_max_abs_s()}}},
              {"delivery_latency_ms", {{"mean", 1e3 * d.delivery_latency_mean_s()}, {"max", 1e3 * d.delivery_latency_max_s()}}}};
}

// One camera frame's vision work: the frame, what the recorder captured at its exposure end,
// and the flight software's job for it (FrameJob::process: from the frame alone).
struct VisionJob {
  CameraFrame frame;
  Recorder::FrameCapture capture;
  std::unique_ptr<flight::FrameJob> work;
  double proc_ms{0};                    ///< wall time of FrameJob::process
  double delivery_latency_s{0};         ///< the frame's transfer to the computer (FrameTiming)
};

// A processed frame waiting for its delivery time, or (change indication) a recorded result.
struct Delivery {
  std::unique_ptr<flight::FrameJob> work;
  cv::Mat pixels;                          ///< the frame's image, alive until delivered
  bool detected{false};                    ///< what the flight software is told (trace.csv)
  std::optional<flight::VisionResult> recorded;
};

// The flight software's vision stage of the loop. A frame's job depends only on the frame and
// the state only frame jobs use (flight_software.h, "Threading"), never on the filters or the
// controller, whose state moves on meanwhile. So frame k's processing can run on a worker
// thread while the main thread steps the plant, samples the sensors and renders frame k + 1,
// as long as it is joined (a) before the next frame's job begins and (b) no later than the
// physics step at which its result is delivered. The result then enters the delivery queue at
// the same instant, in the same order, as in the serial schedule: the outputs are the same bit
// for bit. Only FrameJob::process runs on the worker; everything else (fault hooks, the
// recorder, the queue) runs on the main thread at the join, in frame order.
class VisionStage {
 public:
  explicit VisionStage(bool overlap) : overlap_(overlap) {
    // One worker for the whole run (not a thread per frame): the detector's per-thread scratch
    // buffers stay allocated from frame to frame, as on the loop's thread in the serial
    // schedule. Results never depend on which thread ran them (vision_determinism_test.cpp).
    if (overlap_) worker_ = std::thread([this] { work(); });
  }
  ~VisionStage() {
    if (!worker_.joinable()) return;
    {
      std::lock_guard<std::mutex> lock(m_);
      stop_ = true;
    }
    cv_.notify_all();
    worker_.join();  // finishes a job in flight first: never leave the worker past the loop
  }
  VisionStage(const VisionStage&) = delete;
  VisionStage& operator=(const VisionStage&) = delete;
  bool overlapped() const { return overlap_; }

  // Starts (or, serially, does) frame `job`'s detection, whose result is due at `deliver_t_s`
  // (used only by the overlapped schedule, which never runs with a measured latency). The
  // previous job must be taken.
  void submit(VisionJob job, double deliver_t_s) {
    deliver_t_ = deliver_t_s;
    if (overlap_) {
      {
        std::lock_guard<std::mutex> lock(m_);
        todo_ = std::move(job);
      }
      cv_.notify_all();
    } else {
      run(job);
      done_ = std::move(job);
    }
    pending_ = true;
  }
  bool pending() const { return pending_; }
  double pending_deliver_t() const { return deliver_t_; }
  // The submitted job, finished (waits for the worker; rethrows what the job threw).
  // *wait_ms gets the time waited.
  VisionJob take(double* wait_ms) {
    pending_ = false;
    std::unique_lock<std::mutex> lock(m_, std::defer_lock);  // held to the end when overlapped
    if (overlap_) {
      const auto t0 = Clock::now();
      lock.lock();
      cv_.wait(lock, [this] { return done_.has_value() || error_; });
      *wait_ms += ms_since(t0);
      if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
    }
    VisionJob j = std::move(*done_);
    done_.reset();
    return j;
  }

 private:
  static void run(VisionJob& j) {
    const auto t0 = Clock::now();
    j.work->process();
    j.proc_ms = ms_since(t0);
  }
  void work() {
    std::unique_lock<std::mutex> lock(m_);
    for (;;) {
      cv_.wait(lock, [this] { return stop_ || todo_.has_value(); });
      if (!todo_) return;  // stopped with nothing to do
      VisionJob j = std::move(*todo_);
      todo_.reset();
      lock.unlock();
      std::exception_ptr err;
      try {
        run(j);
      } catch (...) {
        err = std::current_exception();
      }
      lock.lock();
      if (err) {
        error_ = err;
      } else {
        done_ = std::move(j);
      }
      cv_.notify_all();
    }
  }

  const bool overlap_;
  bool pending_ = false;
  double deliver_t_ = 0;
  std::thread worker_;
  std::mutex m_;
  std::condition_variable cv_;
  bool stop_ = false;                ///< guarded by m_
  std::optional<VisionJob> todo_;    ///< submitted, not started (guarded by m_ when overlapped)
  std::optional<VisionJob> done_;    ///< finished, not taken (guarded by m_ when overlapped)
  std::exception_ptr error_;         ///< what the worker's job threw (guarded by m_)
};

// How long past duration_s a run goes on when the flight software cut the motors to touch
// down before it ended (s): the judge's 1 s of rest on the platform, plus the fall from the
// cut (a few centimetres: under 0.1 s) and a bounce settling, with margin. Without it a
// landing cut at 59.0 s of a 60 s run read as a timeout (envelope default-0040).
constexpr double kTouchdownJudgement_s = 2.0;

bool overlap_vision(const Scenario& s, const RunOptions& o) {
  if (std::find(kVisionSchedules.begin(), kVisionSchedules.end(), o.vision_schedule) == kVisionSchedules.end()) {
    throw std::invalid_argument("vision_schedule must be auto, serial or overlap (got '" + o.vision_schedule + "')");
  }
  if (o.vision_schedule == "serial") return false;
  if (o.vision_schedule == "overlap") return !s.computer.measured_latency;
  // The overlap pays only when the result is due after the next frame's exposure starts.
  return !s.computer.measured_latency && s.computer.vision_latency_s + s.camera.exposure_s >= 1.0 / s.camera.rate_hz;
}

std::unique_ptr<CsvWriter> open_vision_profile(const RunOptions& o) {
  if (o.vision_profile_csv.empty()) return nullptr;
  return std::make_unique<CsvWriter>(
      o.vision_profile_csv, std::vector<std::string>{"frame", "t_s", "height_m", "detected", "status", "tracking_roi",
                                                     "code_searched", "rings", "predicted_blur_px", "predicted_blur_x_px", "predicted_blur_y_px",
                                                     "deblurred", "vision_height_m",
                                                     "detector_ms", "detector_cpu_ms", "path_ms", "zoomed", "by_layout",
                                                     "min_depth_m",
                                                     "true_x_CP_m", "true_y_CP_m", "true_z_CP_m", "true_qw_CP", "true_qx_CP", "true_qy_CP", "true_qz_CP",
                                                     "det_x_CP_m", "det_y_CP_m", "det_z_CP_m", "det_qw_CP", "det_qx_CP", "det_qy_CP", "det_qz_CP"});
}

}  // namespace

// The parts of the loop and the steps that tie them together (ClosedLoop::run).
struct ClosedLoop::Impl {
  Impl(const Scenario& scenario, const RunOptions& options, World& w, Renderer* r,
       std::unique_ptr<flight::FlightSoftware> fs)
      : s(scenario),
        o(options),
        world(w),
        renderer(r),
        dt(s.world.physics_dt_s),
        plant(s, world),
        sensors(s.sensors, s.seed),
        camera(s.camera, derive_seed(s.seed, "camera"), dt),
        frame_timing(s.camera, derive_seed(s.seed, "camera_timing")),
        flight_owner(std::move(fs)),
        flight(*flight_owner),
        builtin(dynamic_cast<flight::FlightStack*>(flight_owner.get())),
        recorder(s, o, world, renderer),
        outliers(s.faults),
        replay(!o.replay_vision.empty()),
        vision(!replay && overlap_vision(s, o)),
        profile(open_vision_profile(o)),
        outcome{"timeout", fmt::format("no landing within duration_s = {:.1f} s", s.duration_s)},
        n_steps(static_cast<int>(std::floor(s.duration_s / dt + 0.5))),
        n_judge(static_cast<int>(std::floor(kTouchdownJudgement_s / dt + 0.5))) {
    schedule_sensor_faults(s.faults, sensors);
    // Recording and replaying vision results (the change indication) is our stack's: its
    // results are a type the simulator knows (flight::VisionResult).
    if ((replay || !o.record_vision.empty()) && !builtin) {
      throw ConfigError("recording or replaying vision results needs the builtin flight software");
    }
    // Recorded vision (change indication): delivered at the recorded times, nothing rendered.
    if (replay) {
      for (const VisionLogEntry& e : read_vision_log(o.replay_vision)) {
        Delivery d;
        d.detected = e.result.obs.detected;
        d.recorded = e.result;
        vision_q.push(std::move(d), e.deliver_t_s);
      }
    }
    w_cmd.fill(plant.hover_speed_radps());
  }

  // Whether step k runs: every step up to duration_s, then, while the flight software has cut
  // the motors to touch down, up to kTouchdownJudgement_s more for the judge to see it rest.
  bool running(int k) {
    if (k < n_steps) return true;
    if (k >= n_steps + n_judge || !flight.status().motors_cut) return false;
    if (k == n_steps) {
      outcome.detail = fmt::format("motors cut before duration_s = {:.1f} s, but not resting on the platform "
                                   "for 1 s within {:.1f} s after it",
                                   s.duration_s, kTouchdownJudgement_s);
    }
    res.judged_past_duration_s = (k + 1) * dt - s.duration_s;
    return true;
  }

  // The camera renders what falls at t; a frame whose exposure ended goes to the vision stage
  // (after the previous frame's detection: the detector takes frames in order).
  void camera_step(double t) {
    if (replay) return;
    std::optional<CameraFrame> frame = camera.advance(t, world, *renderer, &res.render_ms);
    if (!frame) return;
    const FrameTiming timing = frame_timing.at(frame->index);
    delivered_frames.add(timing);
    if (timing.dropped) return;  // never reaches the flight software (nor the saved frames)
    if (!o.save_frames_dir.empty()) save_frame_png(o.save_frames_dir, *frame);
    if (vision.pending()) finish_vision();
    VisionJob job;
    job.capture = recorder.capture_frame(*frame, flight);
    // Begun here, on the loop's thread, with the state the flight software has when the frame
    // arrives: the same in the serial and the overlapped schedule.
    job.frame = std::move(*frame);
    if (o.step_observer) {
      observed_frame = job.frame;  // a header: the pixels are shared, not copied
      frame_this_step = true;
    }
    flight::CameraFrameIn in;
    in.index = job.frame.index;
    // What the driver reports: its stamp (the exposure end, or the arrival with
    // camera.stamp_at_arrival; with the stamp's error) and the exposure interval that ends there.
    const double stamp_shift_s = timing.stamp_error_s + (s.camera.stamp_at_arrival ? timing.delivery_latency_s : 0.0);
    in.exposure = job.frame.exposure;
    in.exposure.t_start_s += stamp_shift_s;
    in.exposure.t_end_s += stamp_shift_s;
    in.stamp_s = in.exposure.t_end_s;
    in.image = {job.frame.bgr.cols, job.frame.bgr.rows, static_cast<int>(job.frame.bgr.step[0]), job.frame.bgr.data};
    job.work = flight.begin_frame(in);
    job.delivery_latency_s = timing.delivery_latency_s;
    const double t_end = job.frame.exposure.t_end_s;
    vision.submit(std::move(job), t_end + timing.delivery_latency_s + s.computer.vision_latency_s);
    if (!vision.overlapped()) finish_vision();
  }

  // The plant steps with the rotor command (rotors, ground effect, wind, cart, physics).
  bool plant_step(int k) {
    const auto tp0 = Clock::now();
    std::string diverged;
    if (!plant.step(k, w_cmd, &diverged)) {
      outcome = {"diverged", diverged};
      return false;
    }
    res.physics_ms += ms_since(tp0);
    return true;
  }

  // The sensors sample the new truth and transmit; what is delivered at tn (sensor samples,
  // vision results) reaches the flight stack, whose inner loop sets the rotor command.
  void flight_step(double tn) {
    if (vision.pending() && vision.pending_deliver_t() <= tn + 1e-12) finish_vision();  // due now
    const auto tc0 = Clock::now();
    // The platform's truth only when its broadcast samples now (not on every physics step).
    std::optional<PlatformTruth> platform;
    if (sensors.platform_telemetry().due(tn)) {
      const Eigen::Vector3d p_WP = world.X_WP().translation();
      platform = PlatformTruth{tn, p_WP, world.cart_point_velocity_W(p_WP)};
    }
    const VehicleTruth& truth = plant.truth();
    SensorSuite::Sampled smp = sensors.sample(truth, platform ? &*platform : nullptr);
    recorder.on_samples(smp, truth);
    corrupt_on_the_wire(s.faults, tn, smp);
    sensors.transmit(smp);
    const SensorSuite::Delivered in = sensors.deliver(tn);
    for (const BaroSample& b : in.baro) flight.on_baro(b);
    for (const GpsSample& g : in.gps) flight.on_gps(g);
    for (const UltrasonicSample& u : in.ultrasonic) flight.on_ultrasonic(u);
    for (Delivery& d : vision_q.pop_ready(tn)) {
      recorder.on_vision_delivered(d.detected);
      if (d.recorded) {
        builtin->on_vision(*d.recorded);
      } else {
        flight.deliver_frame(std::move(d.work));
      }
    }
    for (const MagSample& m : in.magnetometer) flight.on_mag(m);
    for (const GpsSample& g : in.platform_telemetry) flight.on_platform_telemetry(g);
    for (const ImuSample& imu : in.imu) {
      if (const std::optional<flight::RotorSpeeds> cmd = flight.on_imu(imu)) {
        for (int r = 0; r < kNumRotors; ++r) w_cmd[r] = cmd->w_radps[r];
      }
    }
    res.control_ms += ms_since(tc0);
  }

  // The recorder logs step k and judges it; true when the run has ended.
  bool judged_over(int k, double tn) {
    res.sim_s = tn;
    if (std::optional<Outcome> end = recorder.on_step(k, plant.truth(), flight, plant.rotor_speeds_radps())) {
      outcome = *end;
      return true;
    }
    if (o.progress && k % 5000 == 0) {
      std::cerr << fmt::format("\rt = {:.1f} s  mode {}            ", tn, flight.status().mode)
                << std::flush;
    }
    return false;
  }

  // A stepping caller's look after the step (RunOptions::step_observer).
  void observe(double tn) {
    if (!o.step_observer) return;
    o.step_observer(StepView{tn, &world, &plant.truth(), frame_this_step ? &observed_frame : nullptr});
    frame_this_step = false;
  }

  // A processed frame, in frame order on the main thread: the outlier hook, the recorder,
  // the NaN-pose hook, the delivery queue.
  void finish_vision() {
    VisionJob j = vision.take(&res.vision_wait_ms);
    res.estimator_ms += j.proc_ms;
    const double t_mid = j.frame.exposure.mid();
    flight::FrameReport rep = j.work->report();
    if (profile) write_profile_row(j, rep);
    if (outliers.apply(t_mid, rep.detected, *j.work, flight)) {
      recorder.count_outlier_injected();
      rep = j.work->report();
    }
    res.detector_ms += rep.detector_ms;
    res.detector_cpu_ms += rep.detector_cpu_ms;
    res.path_stage_ms += rep.path_ms;
    recorder.on_frame(j.frame, j.capture, rep);
    Delivery d;
    d.detected = rep.detected;
    if (fault_active(t_mid, s.faults.nan_vision_t_s, s.faults.nan_vision_duration_s)) {
      // Test hook: a "detection" with a NaN pose.
      inject_or_refuse(*j.work, {flight::VisionFault::Kind::kNanPose, 0.0}, "faults.nan_vision_t_s", flight);
      d.detected = true;
    }
    const double latency = s.computer.measured_latency ? j.proc_ms * 1e-3 : s.computer.vision_latency_s;
    // After the frame's own delivery latency; never before the previous frame's result.
    const double deliver_t = std::max(last_deliver_t, j.frame.exposure.t_end_s + j.delivery_latency_s + latency);
    last_deliver_t = deliver_t;
    if (!o.record_vision.empty()) {
      vision_log.push_back({j.frame.index, deliver_t, static_cast<const flight::RingFrameJob&>(*j.work).result()});
    }
    d.pixels = j.frame.bgr;
    d.work = std::move(j.work);
    vision_q.push(std::move(d), deliver_t);
  }

  // A pose's translation (m) and unit quaternion (w, x, y, z) into the profile row.
  void write_pose(const Eigen::Isometry3d& X) {
    const Eigen::Vector3d p = X.translation();
    Eigen::Quaterniond q(X.linear());
    if (q.w() < 0) q.coeffs() *= -1.0;  // one of the two signs: w >= 0
    for (int i = 0; i < 3; ++i) profile->num(p(i), 6);
    for (double c : {q.w(), q.x(), q.y(), q.z()}) profile->num(c, 9);
  }

  void write_profile_row(const VisionJob& j, const flight::FrameReport& r) {
    const auto* ring = dynamic_cast<const flight::RingFrameJob*>(j.work.get());
    constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
    const Eigen::Vector2d blur = ring ? ring->predicted_blur_px() : Eigen::Vector2d(kNaN, kNaN);
    profile->integer(j.frame.index).num(j.frame.exposure.mid(), 4).num(j.capture.z_mid_m - j.capture.platform_z_m, 3);
    profile->integer(r.detected ? 1 : 0).text(r.reason).integer(r.used_roi ? 1 : 0);
    profile->integer(r.code_searched ? 1 : 0).integer(r.rings);
    // The blur's components with 17 decimals: `lander bench frames` gives the detector the same.
    profile->num(blur.norm(), 2).num(blur.x(), 17).num(blur.y(), 17).integer(r.deblurred ? 1 : 0);
    // The detection's camera height above the target (compare with height_m, the truth).
    profile->num(r.vision_height_m, 4);
    profile->num(r.detector_ms, 3).num(r.detector_cpu_ms, 3).num(r.path_ms, 3);
    profile->integer(r.zoomed ? 1 : 0).integer(r.by_layout ? 1 : 0);
    // The least depth the stack told its detector (0: unknown): `lander bench frames` too.
    profile->num(ring ? ring->min_depth_m() : kNaN, 17);
    // The platform in the camera at the exposure's middle (truth), and as the flight software's
    // pose has it (NaN without one): a detector's error frame by frame.
    write_pose(j.frame.X_WC_true.inverse() * j.frame.X_WP_true);
    const bool pose = ring != nullptr && ring->result().obs.detected;
    write_pose(pose ? ring->result().obs.X_CP : Eigen::Isometry3d(Eigen::Matrix4d::Constant(kNaN)));
    profile->end_row();
  }

  // After the last step: the last frame's detection (as in the serial schedule), the summary,
  // the profile and the vision log.
  LoopResult finish(Clock::time_point wall0, Json& summary) {
    if (vision.pending()) finish_vision();
    if (o.progress) std::cerr << "\n";
    res.overlapped = vision.overlapped();
    res.wall_s = std::chrono::duration<double>(Clock::now() - wall0).count();
    res.frames = camera.frames();
    res.renders = camera.renders();
    res.outliers_injected = recorder.outliers_injected();
    recorder.finish(outcome, flight, summary);
    summary["judged_past_duration_s"] = res.judged_past_duration_s;
    summary["camera_delivery"] = delivery_json(delivered_frames);
    if (profile) profile->commit();
    if (!o.record_vision.empty()) write_vision_log(o.record_vision, vision_log);
    return res;
  }

  const Scenario& s;
  const RunOptions& o;
  World& world;
  Renderer* renderer;
  const double dt;
  Plant plant;                // MuJoCo world, rotors, ground effect, wind, cart
  SensorSuite sensors;        // IMU, barometer, GPS, ultrasonic, magnetometer, telemetry
  CameraRig camera;           // exposures, renders (motion blur), image noise
  FrameTimingModel frame_timing;      // drops, stamp jitter, delivery latency per frame
  FrameDeliveryStats delivered_frames;  // what of it the flight software received
  double last_deliver_t{-std::numeric_limits<double>::infinity()};  // frames keep their order
  // The flight software, from the flight configuration only (declared before everything
  // that holds its frame jobs: a plugin's code must outlive them).
  std::unique_ptr<flight::FlightSoftware> flight_owner;
  flight::FlightSoftware& flight;
  flight::FlightStack* builtin;  // ours, when it flies built in (vision record and replay)
  Recorder recorder;          // trace, metrics, judge, summary, video
  VisionOutliers outliers;
  const bool replay;
  DelayQueue<Delivery> vision_q;  // results waiting for their delivery time
  std::vector<VisionLogEntry> vision_log;
  LoopResult res;
  VisionStage vision;         // the detector, on a worker thread when the schedule allows
  std::unique_ptr<CsvWriter> profile;
  RotorArray w_cmd;
  CameraFrame observed_frame;   // the frame of this step, for the step observer
  bool frame_this_step{false};
  Outcome outcome;
  const int n_steps, n_judge;
};

ClosedLoop::ClosedLoop(const Scenario& s, const RunOptions& o, World& world, Renderer* renderer,
                       std::unique_ptr<flight::FlightSoftware> flight) {
  if (o.replay_vision.empty() && renderer == nullptr) throw std::logic_error("ClosedLoop: no renderer");
  if (!flight) throw std::logic_error("ClosedLoop: no flight software");
  impl_ = std::make_unique<Impl>(s, o, world, renderer, std::move(flight));
}

ClosedLoop::~ClosedLoop() = default;

LoopResult ClosedLoop::run(Json& summary) {
  Impl& L = *impl_;
  const auto wall0 = Clock::now();
  for (int k = 0; L.running(k); ++k) {
    const double t = k * L.dt, tn = (k + 1) * L.dt;
    run_process_fault_hooks(L.s.faults, t);  // abort / hang test hooks
    L.camera_step(t);                        // render at t; a finished frame to the vision stage
    if (!L.plant_step(k)) break;             // rotor command in, physics to tn
    L.flight_step(tn);                       // sensors and vision results -> flight stack
    if (L.judged_over(k, tn)) break;         // recorder: trace, metrics, outcome
    L.observe(tn);                           // a stepping caller's look (lander.Sim)
  }
  return L.finish(wall0, summary);
}

}  // namespace lander::sim
