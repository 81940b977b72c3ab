// The flight stack: the estimator (ring detector, navigation, altitude fusion, sample screen)
// and the landing controller, built only from the flight configuration (flight_config.h).
// What a vehicle's flight computer runs: it takes timestamped sensor samples and camera
// frames and gives rotor speed commands. No MuJoCo, no GL, no truth. It is our implementation
// of the flight-software seam (flight_software.h, whose header states the call order and
// threading); the same class flies built in or as a plugin (flight/plugin/builtin_plugin.cpp).
//
// Call order per delivery instant (the simulator's loop does this; a vehicle's drivers would
// too): on_baro / on_gps / on_ultrasonic / deliver_frame (on_vision) / on_mag for everything
// delivered, then on_imu for each IMU sample, which runs the controller's inner loop and
// returns its command.
#pragma once

#include <limits>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "lander/controller/landing_controller.h"
#include "lander/estimator/altitude_fusion.h"
#include "lander/estimator/navigation.h"
#include "lander/estimator/path_extractor.h"
#include "lander/core/sample_screen.h"
#include "lander/estimator/vision_detector.h"
#include "lander/flight/components.h"
#include "lander/flight/flight_config.h"
#include "lander/flight/flight_software.h"

namespace lander::flight {

// A frame's vision result on its way to the filters: the controller's observation (stamped at
// mid-exposure) and, for a keyframe, the camera's height above the target plane (else NaN).
struct VisionResult {
  PlatformObservation obs;
  double h_plane_m{std::numeric_limits<double>::quiet_NaN()};
  std::optional<PathObservation> path;  ///< the route's candidates, when the path stage ran
};

class FlightStack;

// One camera frame's work in our stack: the ring detector (or the user's detector given to
// the stack) and, while the controller can use it, the path stage on the frame; the result to
// deliver (VisionResult) once processed.
class RingFrameJob final : public FrameJob {
 public:
  RingFrameJob(FlightStack& stack, const CameraFrameIn& frame, bool run_path, const Eigen::Vector2d& blur_px,
               double min_depth_m = 0.0);
  void process() override;
  FrameReport report() const override { return report_; }
  bool inject(const VisionFault& fault) override;
  // The result as it will be delivered (after any injected fault).
  const VisionResult& result() const { return vr_; }
  const Eigen::Vector2d& predicted_blur_px() const { return blur_px_; }
  double min_depth_m() const { return min_depth_m_; }

 private:
  FlightStack& stack_;
  CameraFrameIn frame_;
  bool run_path_;
  Eigen::Vector2d blur_px_;
  double min_depth_m_;
  VisionResult vr_;
  FrameReport report_;
};

class FlightStack final : public FlightSoftware {
 public:
  // Loads the target geometry from config.target_path; throws ConfigError for a bad
  // configuration or target file. `detector`: a user's detector flown instead of ours with
  // our navigation and controller (components.h); null for ours.
  explicit FlightStack(const FlightConfig& config, std::unique_ptr<VisionDetector> detector = nullptr);
  ~FlightStack() override;

  // ---- the flight-software seam (flight_software.h)
  FlightSoftwareInfo info() const override;
  void on_baro(const BaroSample& b) override { est_.on_baro(b); }
  void on_gps(const GpsSample& g) override { est_.on_gps(g); }
  void on_ultrasonic(const UltrasonicSample& u) override { est_.on_ultrasonic(u); }
  void on_mag(const MagSample& m) override { est_.on_mag(m); }
  // The platform's broadcast position: its own GNSS fix, received over a radio link (only
  // when the plant broadcasts one: sensors.platform_telemetry). Goes to the controller's
  // search (LandingController::on_platform_telemetry).
  void on_platform_telemetry(const GpsSample& g) override;
  std::optional<RotorSpeeds> on_imu(const ImuSample& raw) override;
  std::unique_ptr<FrameJob> begin_frame(const CameraFrameIn& frame) override;
  void deliver_frame(std::unique_ptr<FrameJob> job) override;
  FlightStatus status() const override;
  FlightTelemetry telemetry() const override;
  FlightReport report() const override;

  // ---- our stack's own parts, for tests, benchmarks and the change indication
  // Vision: detects the target in one frame (BGR, as the camera delivers it, distorted; the
  // detector undistorts with the configuration's calibration). Stateful (tracking window,
  // keyframes); frames in order. Never throws for bad image content. `blur_px`: the image
  // motion expected over the frame's exposure (predicted_blur_px()), zero for none.
  RingDetection detect(const cv::Mat& bgr, const Eigen::Vector2d& blur_px = Eigen::Vector2d::Zero(),
                       double min_depth_m = 0.0) {
    return detector_.detect(bgr, blur_px, min_depth_m);
  }
  // The motion blur the flight software expects in a frame exposed over `exposure` (its
  // duration is the camera driver's per-frame metadata), from its own state only: the
  // navigation's body rates and velocity, the platform's velocity and position as the tracker
  // has them (else the fused height below the vehicle as the depth, the platform still), the
  // calibrated mount and focal lengths: the image motion of the point on the optical axis
  // (axis_point_motion_blur_px) times the exposure time. Zero while the navigation has no
  // state, or when estimator.vision.predict_blur is off. Call on the loop's thread when the
  // frame arrives.
  Eigen::Vector2d predicted_blur_px(const ExposureInterval& exposure) const;
  // The least depth along the optical axis at which the target's plane can be in the next
  // frame (m), from the flight software's own state: the camera's fused height above W less
  // the plane's prior height (estimator.altitude.platform_height_m), less kDepthSigmas of both
  // heights' std and kDepthMargin_m (a heaving deck, the cart's bounce), seen through the
  // calibrated mount and the image's border (least_plane_depth_m: over a plane, the least
  // depth is on the border).
  // 0 (unknown) while the altitude fusion has not started, when the plane is not below the
  // camera or not in view, or when estimator.vision.predict_min_depth is off.
  double min_target_depth_m() const;
  // The path stage (seed 003 eq. 6-9) on the same frame. It runs only while the controller
  // can use it (wants_path(): search and follow_path, both stages enabled).
  bool wants_path() const;
  PathObservation detect_path(const cv::Mat& bgr, double t_mid_s) const;
  // The result to deliver after the processing latency.
  VisionResult vision_result(const RingDetection& det, double t_mid_s) const;
  // When a pose in a frame exposed over `e` was taken: the middle row's mid-exposure
  // (e.mid()); with estimator.vision.rolling_shutter_row_time and a rolling shutter, the
  // mid-exposure of the row where the flight software's camera model projects the platform's
  // centre (of image_rows rows).
  double observation_time(const ExposureInterval& e, const PlatformObservation& obs, int image_rows) const;
  // A vision result reaching the filters and the controller (deliver_frame's work; the
  // change indication delivers recorded ones).
  void on_vision(const VisionResult& vr);
  // Navigation and altitude prediction, then the controller's inner loop. Returns the rotor
  // command, or nothing while the navigation has no valid state yet (or the sample was
  // rejected with nothing good to hold).
  std::optional<ctl::RotorCommand> step_imu(const ImuSample& raw);

  // State for the recorder and tests (no truth in here).
  bool altitude_started() const { return est_.altitude_started(); }  ///< fusion has an estimate
  AltitudeEstimate altitude() const { return est_.altitude(); }
  // The navigation state the controller flies on: the navigation filter's, with the
  // altitude fusion's height and climb rate once it has an estimate
  // (navigation.height_from_altitude_fusion).
  NavState nav_state() const { return est_.nav_state(); }
  const ctl::LandingController& controller() const { return controller_; }
  const RejectedSamples& rejected() const { return est_.rejected(); }
  const FlightConfig& config() const { return config_; }
  const CameraMount& mount() const { return config_.mount; }

 private:
  friend class RingFrameJob;
  FlightConfig config_;
  RingTargetDetector detector_;
  std::unique_ptr<VisionDetector> user_detector_;  // flown instead of detector_ when set
  PathExtractor path_extractor_;
  std::vector<Eigen::Vector3d> border_rays_;  // the calibration's image border (min_target_depth_m)
  StateEstimator est_;
  ctl::LandingController controller_;
};

}  // namespace lander::flight
