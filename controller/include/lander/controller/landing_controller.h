// The landing controller the simulation loop (or a vehicle) drives: mode machine of seed 000
// section 3 (observe -> approach -> recovery -> touchdown) with search, re-acquisition and
// go-around added, on top of the cascade of cascade.h. Inputs are only what a vehicle has:
// NavState, AltitudeEstimate, PlatformObservation (state.h), ImuSample and the camera mount.
//
// Usage (one instance per flight):
//   LandingController ctl(params, mount);
//   // whenever a vision result arrives (after its processing latency):
//   ctl.on_vision(obs);
//   ctl.on_altitude(alt);                               // whenever the fusion updates
//   RotorCommand cmd = ctl.step(t_s, nav, imu);          // at >= 250 Hz
//   // cmd.w_radps[k]: rotor k speed command (rad/s), layout of mixer.h
//   ctl.transitions();  // {t_s, from, to, reason} for summary.json
//
// Times are sim/vehicle time in seconds; positions in W (z up), metres.
#pragma once

#include <array>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "lander/controller/cascade.h"
#include "lander/controller/params.h"
#include "lander/controller/platform_tracker.h"
#include "lander/controller/trajectory.h"
#include "lander/core/state.h"
#include "lander/core/types.h"

namespace lander::ctl {

enum class Mode {
  kSearch,     ///< target not (yet) in view: after a loss fly to the tracker's prediction of
               ///< the platform (search_predict_max_s); with nothing to predict from, hold
               ///< position (at least search_min_height_m) and sweep the heading so the
               ///< wide image axis scans around
  kObserve,    ///< seed 000 3.1: target in view, collect fixes, follow it horizontally
  kApproach,   ///< seed 000 3.2: fly the eq. 29 cubic to the eq. 28 prediction
  kRecovery,   ///< seed 000 3.3: visual-servo tracking and controlled descent
  kTouchdown,  ///< motors cut, waiting for contact
  kLanded,     ///< contact confirmed; motors stay off
  kGoAround,   ///< climb back to the observe height after a loss or a large error
  kFollowPath, ///< seed 003: a painted route in view and the target not: follow the route
               ///< (path_guidance.h) until the target is acquired (-> observe), the route
               ///< is lost (-> search) or ends (hold there, route_ended())
  kAborted,    ///< terminal, after max_landing_attempts failed attempts or a search that
               ///< found nothing in search_give_up_s: climbs straight up to
               ///< go_around_height_m above the last known platform top (at least
               ///< search_min_height_m above the surface) and holds that point and the
               ///< heading, motors on, for the operator or a return-home outside this
               ///< controller; nothing leaves it
};

// Lower-case name ("search", "observe", ...), as written into summary.json.
const char* to_string(Mode m);

// One switch the mode machine may make, and what triggers it (the docs draw these).
struct ModeTransitionRule {
  Mode from;
  Mode to;
  const char* trigger;
};

// Every transition of the mode machine: the machine refuses any other
// (ModeMachineError, controller/src/modes/transitions.h).
const std::vector<ModeTransitionRule>& mode_transitions();

// Share of the platform's estimated acceleration (magnitude a_mps2) that the visual servo
// feeds forward: 0 up to deadband_mps2 (the estimate's noise at a constant cart speed),
// 1 from full_mps2 on (a cart's start or stop passes whole), linear between; a hard step at
// deadband_mps2 when full_mps2 <= deadband_mps2.
double accel_feed_forward_share(double a_mps2, double deadband_mps2, double full_mps2);

struct ModeTransition {
  double t_s{0.0};  ///< time of the switch (s)
  Mode from{Mode::kSearch};
  Mode to{Mode::kSearch};
  std::string reason;  ///< human-readable cause with the figures that triggered it
};

// One entry of the landing decision log (issue 10).
struct LandingEvent {
  double t_s{0.0};   ///< time (s)
  int attempt{0};    ///< attempt it belongs to (1-based; 0 before the first approach)
  /// "attempt_started" (approach entered), "final_stage" (first below final_hold_height_m in
  /// recovery: the decision timer starts), "committed_wide" (after final_decision_after_s,
  /// the error within the gate widening towards the wide gate: descent into contact, the cut
  /// allowed within the wide gate), "committed_nominal" (the cut within the nominal gate),
  /// "cut" (motors cut, either gate), "landed" (contact), "go_around", "lost" (the target
  /// lost high in approach: back to search), "aborted", "low_clearance" (in search,
  /// go-around or abort the ultrasonic's clearance, under search_min_height_m and under the
  /// fused height, raised the held height; once per mode), "out_of_reach" (in observe or
  /// approach the platform's estimated speed left the vehicle less than 0.3 m/s below its
  /// speed limit, vehicle_limits.h, to close with; once per observe entry).
  std::string what;
  std::string reason;  ///< human-readable, with the figures that decided it
};

// The landing decisions of a flight, for summary.json as
//   landing_decision: {attempts, decision, reason, t_s, wide_gate_m, events: [{t_s, attempt,
//   what, reason}, ...]}.
struct LandingDecisionLog {
  int attempts{0};               ///< landing attempts started (entries into approach)
  /// The latest decision: "none" (none yet), "committed_nominal", "committed_wide",
  /// "go_around", "lost", "aborted". After a landing it stays the commit that led to it.
  std::string decision{"none"};
  std::string reason;            ///< the reason of that decision, with its figures
  double t_s{std::numeric_limits<double>::quiet_NaN()};  ///< time of that decision (s)
  double wide_gate_m{0.0};       ///< the wide gate of LandingParams::wide_gate_m() (m)
  std::vector<LandingEvent> events;  ///< every event, in time order
};

// One loss of the target and its re-acquisition (issue 10), for summary.json as
//   reacquisitions: [{t_last_seen_s, t_lost_s, lost_in, t_reacquired_s, duration_s,
//   prediction_error_m}, ...]   (NaN written as null).
struct Reacquisition {
  double t_last_seen_s{0.0};  ///< last detection before the loss (s)
  double t_lost_s{0.0};       ///< loss declared (s): the switch out of observe, approach or
                              ///< recovery after loss_timeout_s / recovery_loss_timeout_s, or
                              ///< a go-around (for another cause) reaching its height with
                              ///< the target out of view
  Mode lost_in{Mode::kObserve};  ///< mode the target was lost in (to_string() for JSON)
  /// reacquire_frames consecutive keyframes again, in any mode (s); NaN while (or if never)
  /// re-acquired.
  double t_reacquired_s{std::numeric_limits<double>::quiet_NaN()};
  /// Horizontal distance of the first fix after the loss from where the motion model of the
  /// loss (PlatformTracker::motion() then) put the platform at that fix's time (m); NaN if
  /// not re-acquired or there was no model.
  double prediction_error_m{std::numeric_limits<double>::quiet_NaN()};
  /// t_reacquired_s - t_lost_s (s); NaN if not re-acquired.
  double duration_s() const { return t_reacquired_s - t_lost_s; }
};

// Output of one inner step.
struct RotorCommand {
  double t_s{0.0};
  std::array<double, kNumRotors> w_radps{};  ///< rotor speed commands (rad/s), k = 0..5
  bool motors_cut{false};                    ///< true in touchdown/landed (all w = 0)
};

// What the controller believes, for trace.csv and overlays. All in W unless named.
struct LandingDiagnostics {
  Mode mode{Mode::kSearch};
  Setpoint setpoint;                        ///< position setpoint given to the cascade
  bool platform_known{false};               ///< at least one fix
  Eigen::Vector3d platform_W_m{Eigen::Vector3d::Zero()};    ///< platform now (m)
  Eigen::Vector3d platform_v_W_mps{Eigen::Vector3d::Zero()};///< platform velocity (m/s)
  double horizontal_error_m{0.0};           ///< |platform - vehicle| horizontal (m)
  double gear_clearance_m{0.0};             ///< vehicle z - platform z - gear height (m)
  double skid_drop_m{0.0};                  ///< lowest skid end below the level gear for
                                            ///< the tilt relative to the platform (<= 0, m)
  int num_fixes{0};                         ///< fixes in the tracker history
  int keyframe_streak{0};
  bool approach_planned{false};
  Eigen::Vector3d approach_goal_W_m{Eigen::Vector3d::Zero()};  ///< P_d of eq. 28 (m)
  double approach_t0_s{0.0}, approach_td_s{0.0};               ///< t_0, t_d of eq. 29 (s)
  double approach_diff_m{0.0};              ///< |Diff| horizontal, vehicle to P_d (m)
  int replans{0};                           ///< approach replans so far
  bool motors_cut{false};
  bool contact{false};
  double contact_t_s{0.0};                  ///< time contact was confirmed (s)
  double final_stage_s{0.0};                ///< recovery: time since first below
                                            ///< final_hold_height_m (s), 0 before
  bool wide_committed{false};               ///< recovery: committed within the wide gate
  bool path_target_valid{false};            ///< follow_path: a target point this step
  Eigen::Vector2d path_dir_W{Eigen::Vector2d::UnitX()};  ///< follow_path: travel direction
  Eigen::Vector2d path_target_W_m{Eigen::Vector2d::Zero()};  ///< follow_path: target on the
                                            ///< ground (W, m)
  Eigen::Vector3d search_centre_W_m{Eigen::Vector3d::Zero()};  ///< search: the centre of
                                            ///< its pattern (after a loss the prediction, else
                                            ///< the hold point) (m)
};

class LandingController {
 public:
  // Throws ConfigError if the params are invalid.
  LandingController(const ControllerParams& params, const CameraMount& mount);
  ~LandingController();
  LandingController(LandingController&&) noexcept;
  LandingController& operator=(LandingController&&) noexcept;

  // A vision result, delivered after its latency; obs.t_s is the frame's mid-exposure time.
  // It is applied at the next step() with the navigation state interpolated at obs.t_s. A
  // result with a non-finite or impossible pose is dropped and counted (rejected_inputs).
  void on_vision(const PlatformObservation& obs);

  // A frame's route candidates from the estimator's path stage (seed 003), after its latency.
  // Non-finite points are dropped (the frame is counted as rejected).
  void on_path(const PathPoints& pts);

  // The fused altitude (used for the search height when no platform is known). A non-finite
  // estimate is dropped and counted.
  void on_altitude(const AltitudeEstimate& alt);

  // The platform's broadcast position: its own GNSS fix (sampling time t_s, position and
  // velocity in W), received over a radio link after its latency. Used by the search while no
  // fix of the target predicts the platform (LandingParams::telemetry_max_age_s). A message
  // without a fix (valid = false) or older than the newest is ignored; a non-finite one is
  // dropped and counted (rejected_inputs).
  void on_platform_telemetry(const GpsSample& g);

  // Inner loop (call at >= 250 Hz with non-decreasing t_s). Runs the outer loop and the mode
  // machine when due (CascadeParams::outer_rate_hz), contact detection every call. With a
  // non-finite time, navigation state or IMU sample it holds the previous command (counted).
  // Throws ModeMachineError (controller/src/modes/transitions.h) if the modes break the
  // transition table or switch back within one step.
  RotorCommand step(double t_s, const NavState& nav, const ImuSample& imu);

  // Inputs dropped as non-finite or impossible (vision results, altitudes, inner steps).
  long rejected_inputs() const { return rejected_inputs_; }

  Mode mode() const;
  const std::vector<ModeTransition>& transitions() const { return transitions_; }
  bool landed() const { return mode() == Mode::kLanded; }
  bool aborted() const { return mode() == Mode::kAborted; }  ///< terminal: see Mode::kAborted
  /// Attempts, the latest decision and every decision event (see LandingDecisionLog).
  const LandingDecisionLog& decision_log() const;
  /// Every loss of the target after it was first acquired, in order (see Reacquisition).
  const std::vector<Reacquisition>& reacquisitions() const;
  const LandingDiagnostics& diagnostics() const;
  const CascadeDiagnostics& cascade_diagnostics() const;
  const PlatformTracker& tracker() const;
  const ControllerParams& params() const;
  /// follow_path: the route's end was reached (no candidate ahead for end_after_s); the
  /// vehicle holds there. NaN time before.
  bool route_ended() const;
  double route_end_t() const;
  /// follow_path statistics: outer steps in follow_path and those with a target point.
  long path_steps() const;
  long path_target_steps() const;
  /// Platform broadcasts accepted (on_platform_telemetry), and outer steps whose search
  /// flew to one (transit and pattern around it).
  long telemetry_received() const;
  long telemetry_search_steps() const;

 private:
  struct Impl;  // the modes and what they share (controller/src/modes/)
  Setpoint run_mode_machine(double t_s, const NavState& nav);
  void detect_contact(double t_s, const ImuSample& imu, const NavState& nav);
  void start(double t_s, const NavState& nav);
  void apply_outer_limits(double t_s);

  std::unique_ptr<Impl> impl_;
  std::vector<PlatformObservation> pending_;
  std::vector<ModeTransition> transitions_;
  bool started_{false};
  double last_outer_t_{0.0};
  double last_inner_t_{0.0};
  Setpoint last_sp_;
  RotorCommand last_cmd_;
  long rejected_inputs_{0};
};

}  // namespace lander::ctl
