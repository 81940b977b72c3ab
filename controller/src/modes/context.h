// What the landing modes share: the controller's inputs, its beliefs about the platform, its
// records, and the services more than one mode uses (PX4's flight tasks share the vehicle's
// state the same way; each mode's own state lives in its class, modes.h).
#pragma once

#include <cmath>
#include <deque>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "lander/controller/cascade.h"
#include "lander/controller/deck_motion.h"
#include "lander/controller/landing_controller.h"
#include "lander/controller/params.h"
#include "lander/controller/platform_tracker.h"

namespace lander::ctl::modes {

// One outer step's inputs: its time, the time since the previous pass of the machine
// (0 for a mode entered within this step) and the navigation state.
struct Tick {
  double t_s{0.0};
  double dt_s{0.0};
  const NavState& nav;
};

// The latest route candidates of the estimator's path stage (on_path).
struct RouteInput {
  PathPoints points;
  bool have{false};
  int streak{0};          ///< consecutive frames with >= enter_min_points candidates
  double last_t_s{-1e9};  ///< last frame with a candidate (s)
};

// Fixes before the platform velocity is fed forward (observe, the observe entry): the velocity
// filter starts at zero with 1 m/s of uncertainty, and 6 fixes (0.2 s at 30 Hz) keep its first
// noisy updates out of the follow. A 1 m/s cart acquired at the edge of the view leaves it
// within ~1 s unless the follow starts at once, so this must stay small.
constexpr int kMinFixesForFeedForward = 6;

// A platform faster than the vehicle's speed limit minus this cannot be closed on (m/s): the
// follow would trail it however long it flew.
constexpr double kMinClosingSpeed_mps = 0.3;

inline double horizontal(const Eigen::Vector3d& v) { return v.head<2>().norm(); }

inline double yaw_of(const Eigen::Quaterniond& q_WB) {
  const Eigen::Vector3d x = q_WB * Eigen::Vector3d::UnitX();
  return std::atan2(x.y(), x.x());
}

// The vehicle's height in an inertial frame for the deck predictor (any datum): the IMU's
// vertical acceleration integrated, its velocity drawn towards the navigation's vertical
// velocity with time constant kLeak_s. Over a moving deck the navigation's vertical channel
// may carry the deck's heave (a still-surface altitude fusion rides on the ultrasonic and
// vision, which see the deck; estimator.altitude.moving_surface_rw_mps keeps it out); at the
// deck's periods (4-12 s) this filter passes only 1/(omega tau) of that, while an
// accelerometer bias becomes a constant velocity offset, a trend the predictor fits.
class InertialHeight {
 public:
  static constexpr double kLeak_s = 30.0;
  void update(double t_s, const NavState& nav, const ImuSample& imu, double gravity_mps2);
  // The height at t_s (interpolated over the last kHistory_s); NaN before the first update
  // or outside the history.
  double at(double t_s) const;

 private:
  static constexpr double kHistory_s = 1.0;
  bool started_{false};
  double t_s_{0.0}, v_mps_{0.0}, z_m_{0.0};
  std::deque<std::pair<double, double>> history_;  ///< (t, z)
};

class LandingContext {
 public:
  LandingContext(const ControllerParams& params, const CameraMount& mount);

  // --- what the controller knows -------------------------------------------------------
  ControllerParams p;
  CameraMount mount;
  CascadeController cascade;
  PlatformTracker tracker;
  DeckMotionPredictor deck;  ///< the platform's heave and tilt (a boat's deck), fed per fix
  InertialHeight inertial_height;  ///< the vehicle's height for the deck's (every inner step)
  AltitudeEstimate altitude;
  std::optional<GpsSample> broadcast;  ///< the newest accepted platform broadcast
  RouteInput route;
  Mode mode{Mode::kSearch};  ///< the mode in charge (set by the machine)
  LandingDiagnostics diag;
  double yaw_hold_rad{0.0};  ///< heading setpoint (rad)
  /// Search, go-around, abort, observe and follow_path: the point held; each sets it on entry.
  Eigen::Vector3d hold_p{Eigen::Vector3d::Zero()};
  bool low_clearance_logged{false};  ///< keep_min_height's event, once per mode
  long telemetry_received{0};        ///< broadcasts accepted
  long telemetry_search_steps{0};    ///< outer steps whose search flew to a broadcast
  /// follow_path: the route's end was reached (no candidate ahead for end_after_s); the
  /// vehicle holds there and the search never follows a route again. NaN time before.
  bool route_ended{false};
  double route_end_t_s{std::numeric_limits<double>::quiet_NaN()};

  // --- a moving deck (controller.deck) -------------------------------------------------
  // Feeds the newest fix to the deck predictor: its height (the vehicle's inertial height at
  // the fix's time plus the fix's relative vector) and its normal's roll and pitch about W's axes (the
  // deck's own axes on a straight course; the tilt's size whatever the course). Fixes farther
  // than deck.sample_max_range_m from the camera are left out.
  void feed_deck(const PlatformFix& fix);
  // The deck moves and its touchdown is timed (controller.deck.enabled, and the predictor's
  // moving(), or deck.expected while the predictor is not ready).
  bool deck_moving() const;
  // A moving deck's height since the last fix: the tracker's straight line taken back beyond
  // a fresh fix's age (m).
  double deck_height_since_fix(double t_s) const;
  // Whether a quiescent period (vertical speed and tilt within their limits for
  // deck.window_s, by the prediction) holds the contact planned lead_s from t_s; false while
  // the prediction is not trusted. `why` says why not, or the period when it does.
  bool deck_quiescent(double t_s, double lead_s, std::string* why, QuiescentWindow* window = nullptr) const;

  // --- records for summary.json --------------------------------------------------------
  LandingDecisionLog decisions;
  std::vector<Reacquisition> reacquisitions;

  // --- services ------------------------------------------------------------------------
  // Time since the last detection of the target (s).
  double loss_age_s(double t_s) const { return t_s - tracker.last_detection_t(); }
  // The target detected within timeout_s before t_s.
  bool in_view(double t_s, double timeout_s) const { return loss_age_s(t_s) <= timeout_s; }
  // Platform height of the last fix, even after the history was dropped; 0 (ground) before
  // the first.
  double platform_z() const;
  // Height in W that is h_m above the surface below (m): by the fused altitude (above the W
  // origin plane without one), and at least as high by the ultrasonic's clearance where it
  // has one (AltitudeEstimate::clearance_m: what is below, whatever the fusion believes).
  double z_above_surface(const NavState& nav, double h_m) const;
  // z_above_surface at search_min_height_m.
  double search_min_z(const NavState& nav) const;
  // Search, go-around and abort: raises the held height to search_min_z (every step, so a
  // height estimate that was wrong cannot hold the vehicle low); logs a "low_clearance" event
  // once per mode when the ultrasonic's clearance is what raises it.
  void keep_min_height(double t_s, const NavState& nav);
  // A setpoint holding p with the held heading.
  Setpoint hold(const Eigen::Vector3d& p) const;
  // Search / go-around after a loss: the motion model's prediction of the platform now and
  // its velocity (PlatformTracker::motion()); false (and the history dropped) when there is
  // no fix or the last is older than search_predict_max_s.
  bool predict_platform(double t_s, Eigen::Vector2d* p, Eigen::Vector2d* v);
  // The platform's broadcast position predicted to t_s with its velocity, and that velocity;
  // false without a message sampled within telemetry_max_age_s.
  bool broadcast_platform(double t_s, Eigen::Vector2d* p, Eigen::Vector2d* v) const;
  // The decision log: an event, and a decision (an event that is also the latest decision).
  void log_event(double t_s, const std::string& what, const std::string& reason);
  void decide(double t_s, const std::string& decision, const std::string& reason);
  // A loss of the target: opens a Reacquisition record with the motion model of now.
  void declare_loss(double t_s);
  // Observe and approach, every step: whether the platform's estimated speed leaves this
  // vehicle less than kMinClosingSpeed_mps of its speed limit (vehicle_limits.h) to close
  // with; the first time in a mode it logs an "out_of_reach" event naming the limit and
  // where it comes from. reach_note() is "" or that finding for a loss's reason.
  bool check_reach(double t_s);
  std::string reach_note() const;
  void reset_reach() { out_of_reach_speed_mps_ = 0.0; }
  // Closes an open Reacquisition record once the target is re-acquired.
  void check_reacquired(double t_s);
  // The platform's beliefs of this step in diag (platform now, error, clearance, skid drop).
  void update_platform_diagnostics(double t_s, const NavState& nav);

 private:
  PlatformMotion loss_motion_;   // motion model when the open loss was declared
  double out_of_reach_speed_mps_{0.0};  // platform speed of the mode's out_of_reach event
  double last_platform_z_{0.0};  // height of the last fix seen (m), see platform_z()
};

}  // namespace lander::ctl::modes
