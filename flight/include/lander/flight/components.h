// Component seams: where users most often swap one part of the flight software and keep the
// rest of ours.
//
//   VisionDetector  a frame -> the platform's pose with covariance, or nothing with a reason.
//                   Fly yours with our navigation and landing controller:
//                   FlightStack(config, std::move(your_detector)).
//   LandingLogic    a companion computer's landing logic (seed 000's vehicle: a Raspberry Pi
//                   4B ran vision and the landing logic and sent MAVLink setpoints to a
//                   Pixhawk 4): the estimate and the vision results -> position, velocity,
//                   attitude-and-thrust setpoints (or a motor cut) for our inner loop, the
//                   autopilot (controller/cascade.h). Fly yours on our estimator, our (or
//                   your) detector and our autopilot: CompanionStack(config, logic, detector).
//
// Both stacks are FlightSoftware (flight_software.h): they fly built in (tests), or from a
// plugin whose factory builds them (examples/pd_lander/). Every call comes on the loop thread
// except VisionDetector::detect, which runs inside FrameJob::process (possibly a worker
// thread, one frame at a time, in frame order: flight_software.h, "Threading").
#pragma once

#include <memory>
#include <optional>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "lander/estimator/altitude_fusion.h"
#include "lander/estimator/navigation.h"
#include "lander/core/sample_screen.h"
#include "lander/core/state.h"
#include "lander/flight/flight_config.h"
#include "lander/flight/flight_software.h"

namespace lander::ctl {
class CascadeController;
}

namespace lander::flight {

// ------------------------------------------------------------------------- vision detector

// A detector's answer for one frame: the observation the filters get (obs.t_s is set by the
// stack to the frame's mid-exposure time; obs.X_CP is the platform in the camera frame, cov
// its covariance [rotation; translation]) and what the recorder shows.
struct Detection {
  PlatformObservation obs;  ///< obs.detected false: no pose (report.reason says why)
  FrameReport report;
};

class VisionDetector {
 public:
  virtual ~VisionDetector() = default;
  // One frame (BGR as delivered, distorted: calibrate with your own configuration). May keep
  // state across frames (tracking). `predicted_blur_px`: the image motion the stack expects
  // over the exposure (zero when it has no estimate). Must not throw for bad image content.
  virtual Detection detect(const ImageView& image, const CameraFrameIn& frame,
                           const Eigen::Vector2d& predicted_blur_px) = 0;
};

// Our ring and code-map detector behind the detector seam (the same results FlightStack's
// built-in path gives), for a CompanionStack or a user's own stack.
std::unique_ptr<VisionDetector> make_ring_detector(const FlightConfig& config);

// ------------------------------------------------------------------------ state estimator

// Our estimator's filters without vision: the sample screen, the navigation filter and the
// altitude fusion, fed the way FlightStack feeds them. Shared by both stacks.
class StateEstimator {
 public:
  explicit StateEstimator(const EstimatorParams& p);
  void on_baro(const BaroSample& b);
  void on_gps(const GpsSample& g);
  void on_ultrasonic(const UltrasonicSample& u);
  void on_mag(const MagSample& m);
  // The screened sample (a rejected one replaced by the last good one), after the navigation's
  // and the fusion's prediction with it; nothing when there is no good sample yet.
  std::optional<ImuSample> on_imu(const ImuSample& raw);
  // A vision result through the sample screen (false: rejected, counted); a keyframe's
  // height above the target plane (else NaN) goes to the fusion.
  bool on_vision(const PlatformObservation& obs, double h_plane_m);

  bool altitude_started() const { return fusion_started_; }
  AltitudeEstimate altitude() const { return fusion_.estimate(); }
  // The navigation state to fly on (with the fusion's height when so configured).
  NavState nav_state() const;
  const RejectedSamples& rejected() const { return screen_.rejected(); }
  long height_resets() const { return fusion_.height_resets(); }
  long baro_fallback_updates() const { return fusion_.baro_fallback_updates(); }

 private:
  EstimatorParams p_;
  Navigation nav_;
  AltitudeFusion fusion_;
  SampleScreen screen_;
  // The vehicle starts in the air: the filter starts from the first barometer reading, with
  // the split between height and barometer bias left to GPS and vision.
  bool fusion_started_{false};
};

// --------------------------------------------------------------------------- landing logic

// What the autopilot is asked to fly (W, z up; SI units).
struct AutopilotSetpoint {
  enum class Kind {
    kPosition,        ///< p_W_m with v_W_mps / a_W_mps2 as feed-forward, yaw_rad
    kVelocity,        ///< v_W_mps (and a_W_mps2 feed-forward), yaw_rad; position free
    kAttitudeThrust,  ///< the thrust vector along q_WB's body z, thrust_N; heading from q_WB
    kMotorsCut,       ///< all rotors off (touchdown)
  } kind{Kind::kPosition};
  Eigen::Vector3d p_W_m{Eigen::Vector3d::Zero()};
  Eigen::Vector3d v_W_mps{Eigen::Vector3d::Zero()};
  Eigen::Vector3d a_W_mps2{Eigen::Vector3d::Zero()};
  double yaw_rad{0.0};
  Eigen::Quaterniond q_WB{Eigen::Quaterniond::Identity()};
  double thrust_N{0.0};
};

// What the landing logic knows at an outer-loop step: our estimator's state only.
struct LandingInputs {
  double t_s{0.0};
  NavState nav;                 ///< valid: the navigation has a state
  bool altitude_valid{false};
  AltitudeEstimate altitude;    ///< fused height above the W origin and above the surface
  CameraMount mount;            ///< the calibrated camera mount (flight.mount)
};

class LandingLogic {
 public:
  virtual ~LandingLogic() = default;
  // A vision result after its latency (screened: non-finite or implausible ones never come);
  // obs.t_s is the frame's mid-exposure time.
  virtual void on_vision(const PlatformObservation& obs) = 0;
  virtual void on_platform_telemetry(const GpsSample& g) {}
  // At the autopilot's outer-loop rate (flight.controller.cascade.outer_rate_hz), once the
  // navigation has a state.
  virtual AutopilotSetpoint update(const LandingInputs& in) = 0;
  // For the recorder: the mode name, whether it gave up, and its decisions.
  virtual std::string mode() const = 0;
  virtual bool aborted() const { return false; }
  // The platform as the logic believes it (W; trace.csv's ctl_platform_* columns), if known.
  virtual std::optional<Eigen::Vector3d> platform_W_m() const { return std::nullopt; }
  // Mode transitions, decisions and events for summary.json (FlightReport's fields).
  virtual void fill_report(FlightReport& r) const {}
};

// Our estimator, a detector (ours by default) and a landing logic on our autopilot.
class CompanionStack final : public FlightSoftware {
 public:
  CompanionStack(const FlightConfig& config, std::unique_ptr<LandingLogic> logic, FlightSoftwareInfo info,
                 std::unique_ptr<VisionDetector> detector = nullptr);
  ~CompanionStack() override;

  FlightSoftwareInfo info() const override { return info_; }
  void on_baro(const BaroSample& b) override { est_.on_baro(b); }
  void on_gps(const GpsSample& g) override { est_.on_gps(g); }
  void on_ultrasonic(const UltrasonicSample& u) override { est_.on_ultrasonic(u); }
  void on_mag(const MagSample& m) override { est_.on_mag(m); }
  void on_platform_telemetry(const GpsSample& g) override { logic_->on_platform_telemetry(g); }
  std::optional<RotorSpeeds> on_imu(const ImuSample& raw) override;
  std::unique_ptr<FrameJob> begin_frame(const CameraFrameIn& frame) override;
  void deliver_frame(std::unique_ptr<FrameJob> job) override;
  FlightStatus status() const override;
  FlightTelemetry telemetry() const override;
  FlightReport report() const override;

 private:
  FlightConfig config_;
  FlightSoftwareInfo info_;
  StateEstimator est_;
  std::unique_ptr<VisionDetector> detector_;
  std::unique_ptr<LandingLogic> logic_;
  std::unique_ptr<ctl::CascadeController> autopilot_;
  AutopilotSetpoint sp_;
  bool motors_cut_{false};
  bool started_{false};
};

}  // namespace lander::flight
