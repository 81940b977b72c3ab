// The flight-software seam: the boundary a vehicle's flight computer has. Timestamped sensor
// samples, platform telemetry and camera frames go in; rotor speed commands come out; and the
// flight software tells the recorder what it believes (its estimate, mode, decisions and
// their reasons, overlays for the video). No truth crosses this boundary, and nothing of
// MuJoCo, GL or the simulator's parameters: a flight software knows only its own
// configuration (the scenario's resolved `flight:` section, flight_config.h, and for a plugin
// the free-form `flight.plugin_config:` mapping).
//
// Our stack (FlightStack, flight_stack.h) is one implementation; a plugin (flight_plugin.h)
// or the component seams (components.h) give others. The simulator's closed loop talks to
// this interface only (sim/src/loop/closed_loop.cpp).
//
// ## Call order (one physics step of the simulator, at time t; all on the loop thread)
//   1. A camera frame whose exposure ended: begin_frame(frame) -> a FrameJob. Then
//      job->process() (see Threading), then job->report() for the recorder.
//   2. Everything delivered at t (after each sensor's latency), in this order: on_baro,
//      on_gps, on_ultrasonic, deliver_frame (a processed job whose result is due), on_mag,
//      on_platform_telemetry, then on_imu for each IMU sample; on_imu returns the rotor
//      command, held by the simulator until the next command.
//   3. status() every step (the judge), telemetry() at the trace rate and at each frame,
//      report() once after the last step.
//   Samples arrive in time order per sensor; times never decrease.
//
// ## Units and frames (docs/design/architecture.md, "Frames and units")
//   SI units (m, s, rad, m/s, rad/s, Pa, uT); W world (z up), B body (x forward, y left,
//   z up), C camera (OpenCV: x right, y down, z along the optical axis), P platform (z out of
//   its top). X_AB is the pose of frame B in frame A. Times are the simulator's (vehicle)
//   clock in seconds. The camera frame's pixels are those of the sensor: distorted, BGR 8-bit,
//   the calibration is the flight software's own (flight.camera).
//
// ## Threading and the processing time of a camera frame
//   The simulator models a frame's processing as taking computer.vision_latency_ms (or, with
//   computer.measured_latency, the measured wall time of FrameJob::process): the result is
//   delivered (deliver_frame) at the exposure end plus that latency (plus the camera's own
//   delivery latency, camera.delivery_latency_ms), whatever the processing really cost. A
//   frame the camera drops (camera.frame_drop_prob) never reaches begin_frame. Meanwhile the
//   plant, the sensors and every other call go on. So that this can run in parallel, FrameJob::process may be called on a worker thread concurrently with any
//   other call on the loop thread; it must touch only what begin_frame captured into the job
//   and state that only frame jobs use (a detector's tracking state: jobs run one at a time,
//   in frame order, and each job's process has returned before the next begin_frame). Every
//   other method is called on the loop thread only. A flight software that cannot split its
//   frame work this way does everything in deliver_frame and leaves process empty.
//   The results must not depend on which thread ran process (ours do not:
//   tests/estimator/vision_determinism_test.cpp); the serial and overlapped schedules then
//   give the same outputs bit for bit.
//
// ## Errors
//   A method that throws ends the run: the summary's outcome is "error" with the exception's
//   message and the method's name. A plugin that crashes or hangs ends its process; the
//   campaign runner records the run as crashed or timed out (campaign/runner.cpp).
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "lander/core/sample_screen.h"
#include "lander/core/state.h"
#include "lander/core/types.h"

namespace lander::flight {

// The interface's version: a plugin built against another version is refused
// (flight_plugin.h). Raise it whenever a type or method of this header changes.
constexpr int kFlightSoftwareApiVersion = 1;

constexpr int kRotorCount = 6;  ///< hex-X layout of controller/mixer.h (rotor k = 0..5)

// A camera image as delivered: 8-bit BGR, row-major, `stride_bytes` between rows. The memory
// belongs to the simulator and stays valid until the frame's job is delivered (deliver_frame)
// or destroyed; a flight software that keeps pixels longer copies them.
struct ImageView {
  int width_px{0};
  int height_px{0};
  int stride_bytes{0};
  const std::uint8_t* bgr{nullptr};
};

// One camera frame with the metadata a camera driver gives.
struct CameraFrameIn {
  long index{0};              ///< frame number from 0
  ExposureInterval exposure;  ///< exposure start and end (s) as the driver reports them:
                              ///< they carry its stamp's error (camera.timestamp_jitter_ms)
                              ///< and, with camera.stamp_at_arrival, end at the arrival
  double stamp_s{0.0};        ///< the driver's timestamp (s): the reported exposure end
  ImageView image;
};

// The rotor speed command (rad/s) of one inner-loop step.
struct RotorSpeeds {
  double t_s{0.0};
  std::array<double, kRotorCount> w_radps{};
  bool motors_cut{false};  ///< the flight software has cut the motors to touch down
};

// What a frame's processing found, for the recorder (vision counts, the vision height error,
// the video overlays). Ours fills every field; another flight software fills what it has.
struct FrameReport {
  bool detected{false};
  std::string reason;          ///< the detector's status: why not, when not detected (a short
                               ///< key, counted in summary.json's not_detected_by_reason)
  bool keyframe{false};        ///< a pose the flight software uses for its height
  bool keyframe_rejected{false};
  /// The camera's height above the target plane from this frame's pose (m), NaN if none;
  /// keyframes' heights are compared with the truth in summary.json's
  /// altitude_fusion.by_sensor.vision.
  double vision_height_m{std::numeric_limits<double>::quiet_NaN()};
  int rings{0};                ///< features identified (ours: ring centres)
  double reproj_err_px{0.0};
  // Our detector's passes (summary.json's vision.detections_*); false for other detectors.
  bool deblurred{false}, unfiltered{false}, zoomed{false}, by_layout{false}, by_platform{false};
  bool used_roi{false}, code_searched{false};  ///< `lander bench loop --frames-csv` columns
  // Informative timings the job measured itself (ms; 0 when it does not): performance.json
  // and `lander bench loop --frames-csv`. Never part of summary.json.
  double detector_ms{0}, detector_cpu_ms{0}, path_ms{0};
  // Overlays on the video's camera frame (full-resolution pixels of the delivered image).
  struct Ellipse {
    Eigen::Vector2d centre_px{Eigen::Vector2d::Zero()};
    double a_px{0}, b_px{0}, angle_rad{0};
    bool identified{false};    ///< drawn green (identified) or orange
  };
  struct Point {
    Eigen::Vector2d px{Eigen::Vector2d::Zero()};
    std::string label;
  };
  std::vector<Ellipse> ellipses;
  std::vector<Point> points;
  std::vector<Eigen::Vector2d> route_points_px;  ///< route candidates (cyan circles)
  bool route_searched{false};                    ///< the route stage ran on this frame
  std::string overlay_text;                      ///< one line under the mode line
};

// A vision fault the simulator injects into a frame's result before delivery (scenario keys
// faults.vision_outlier_* and faults.nan_vision_*). Only a flight software whose frame result
// carries a pose can take them (FrameJob::inject).
struct VisionFault {
  enum class Kind { kOffsetAlongAxis, kNanPose } kind{Kind::kOffsetAlongAxis};
  double offset_m{0.0};  ///< kOffsetAlongAxis: the pose moved this far along the optical axis
};

// One camera frame's work (see Threading above).
class FrameJob {
 public:
  virtual ~FrameJob() = default;
  // The image processing; called exactly once, possibly on a worker thread.
  virtual void process() = 0;
  // After process, on the loop thread: what the recorder shows of this frame.
  virtual FrameReport report() const = 0;
  // Applies a fault to the result; false when this flight software cannot take it (the run
  // then ends with a configuration error naming the fault key).
  virtual bool inject(const VisionFault& fault) { return false; }
};

// Every step: what the judge and the altitude metrics need.
struct FlightStatus {
  std::string mode;        ///< the flight software's mode name (free form; ours: search, ...)
  bool motors_cut{false};  ///< cut to touch down
  bool aborted{false};     ///< gave up landing, for good (the run ends, outcome "aborted")
  bool following_route{false};  ///< following a painted route (path-following metrics)
  bool route_ended{false};      ///< reached the route's end without finding the target
  double route_end_t_s{std::numeric_limits<double>::quiet_NaN()};
  bool altitude_valid{false};   ///< the height estimate below exists yet
  AltitudeEstimate altitude;    ///< fused height (summary.json's altitude_fusion errors)
};

// At the trace rate: what the flight software believes (trace.csv's nav_*, fused_*, ctl_*
// and sp_* columns). NaN where it has no such estimate.
struct FlightTelemetry {
  NavState nav;                    ///< nav.valid false before it has a state
  Eigen::Vector3d platform_W_m{Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN())};
  Eigen::Vector3d platform_v_W_mps{Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN())};
  double horizontal_error_m{std::numeric_limits<double>::quiet_NaN()};
  Eigen::Vector3d setpoint_W_m{Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN())};
};

// Once, after the last step: summary.json's flight-software sections. Empty lists and zeros
// where a flight software has nothing to say.
struct FlightReport {
  struct Transition {
    double t_s{0.0};
    std::string from, to, reason;
  };
  struct Event {
    double t_s{0.0};
    int attempt{0};
    std::string what, reason;
  };
  struct Reacquisition {
    double t_last_seen_s{0.0}, t_lost_s{0.0};
    std::string lost_in;
    double t_reacquired_s{std::numeric_limits<double>::quiet_NaN()};
    double prediction_error_m{std::numeric_limits<double>::quiet_NaN()};
  };
  std::vector<Transition> transitions;
  std::string final_mode;
  int attempts{0};
  std::string decision{"none"}, decision_reason;
  double decision_t_s{std::numeric_limits<double>::quiet_NaN()};
  double wide_gate_m{0.0};
  std::vector<Event> events;
  std::vector<Reacquisition> reacquisitions;
  long telemetry_received{0};
  double telemetry_search_s{0.0};
  RejectedSamples rejected;
  long altitude_height_resets{0}, altitude_baro_fallback_updates{0};
  long path_steps{0}, path_target_steps{0};
};

// Who flew: summary.json's `flight_software` record.
struct FlightSoftwareInfo {
  std::string name;     ///< e.g. "lander" (ours)
  std::string version;  ///< the version string the software reports
};

class FlightSoftware {
 public:
  virtual ~FlightSoftware() = default;
  virtual FlightSoftwareInfo info() const = 0;

  // Sensors (after their latencies; see the call order).
  virtual void on_baro(const BaroSample& b) = 0;
  virtual void on_gps(const GpsSample& g) = 0;
  virtual void on_ultrasonic(const UltrasonicSample& u) = 0;
  virtual void on_mag(const MagSample& m) = 0;
  // The platform's broadcast of its own GNSS fix over a radio link (only when the scenario's
  // platform broadcasts: sensors.platform_telemetry).
  virtual void on_platform_telemetry(const GpsSample& g) = 0;
  // The inner loop: one IMU sample; returns the rotor command, or nothing to keep the last
  // one (at the start: every rotor at the plant's hover speed).
  virtual std::optional<RotorSpeeds> on_imu(const ImuSample& s) = 0;

  // Camera: a frame whose exposure just ended (loop thread). The job captures what it needs
  // of the flight software's state now (e.g. the predicted motion blur).
  virtual std::unique_ptr<FrameJob> begin_frame(const CameraFrameIn& frame) = 0;
  // The frame's processed result reaches the rest of the flight software (its filters and
  // controller) after the processing latency (loop thread).
  virtual void deliver_frame(std::unique_ptr<FrameJob> job) = 0;

  // For the recorder (loop thread; never changes the flight software's state).
  virtual FlightStatus status() const = 0;
  virtual FlightTelemetry telemetry() const = 0;
  virtual FlightReport report() const = 0;
};

}  // namespace lander::flight
