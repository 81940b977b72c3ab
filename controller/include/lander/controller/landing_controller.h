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
#include <string>
#include <vector>

#include "lander/controller/cascade.h"
#include "lander/controller/params.h"
#include "lander/controller/platform_tracker.h"
#include "lander/controller/trajectory.h"
#include "lander/estimator/state.h"
#include "lander/estimator/types.h"

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
};

// Lower-case name ("search", "observe", ...), as written into summary.json.
const char* to_string(Mode m);

struct ModeTransition {
  double t_s{0.0};  ///< time of the switch (s)
  Mode from{Mode::kSearch};
  Mode to{Mode::kSearch};
  std::string reason;  ///< human-readable cause with the figures that triggered it
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
};

class LandingController {
 public:
  // Throws ConfigError if the params are invalid.
  LandingController(const ControllerParams& params, const CameraMount& mount);

  // A vision result, delivered after its latency; obs.t_s is the frame's mid-exposure time.
  // It is applied at the next step() with the navigation state interpolated at obs.t_s. A
  // result with a non-finite or impossible pose is dropped and counted (rejected_inputs).
  void on_vision(const PlatformObservation& obs);

  // The fused altitude (used for the search height when no platform is known). A non-finite
  // estimate is dropped and counted.
  void on_altitude(const AltitudeEstimate& alt);

  // Inner loop (call at >= 250 Hz with non-decreasing t_s). Runs the outer loop and the mode
  // machine when due (CascadeParams::outer_rate_hz), contact detection every call. With a
  // non-finite time, navigation state or IMU sample it holds the previous command (counted).
  RotorCommand step(double t_s, const NavState& nav, const ImuSample& imu);

  // Inputs dropped as non-finite or impossible (vision results, altitudes, inner steps).
  long rejected_inputs() const { return rejected_inputs_; }

  Mode mode() const { return mode_; }
  const std::vector<ModeTransition>& transitions() const { return transitions_; }
  bool landed() const { return mode_ == Mode::kLanded; }
  const LandingDiagnostics& diagnostics() const { return diag_; }
  const CascadeDiagnostics& cascade_diagnostics() const { return cascade_.diagnostics(); }
  const PlatformTracker& tracker() const { return tracker_; }
  const ControllerParams& params() const { return p_; }

 private:
  void switch_to(double t_s, Mode to, const std::string& reason, const NavState& nav);
  Setpoint run_mode_machine(double t_s, const NavState& nav);
  void detect_contact(double t_s, const ImuSample& imu, const NavState& nav);
  bool in_view(double t_s, double timeout_s) const;
  double platform_z() const;  // last known platform height, or 0 (ground)
  Setpoint hold(const Eigen::Vector3d& p) const;
  // Search with nothing to predict from, t_spiral_s after the in-place heading sweep: moves
  // the setpoint along an outward spiral around hold_p_ (no-op before it starts).
  void search_spiral(double t_spiral_s, Setpoint* sp) const;
  // Search / go-around after a loss: sets sp's horizontal position (and hold_p_) to the
  // tracker's prediction of the platform now and its velocity as feed-forward; returns false
  // (and drops the history) when there is no fix or the last is older than
  // search_predict_max_s.
  bool follow_prediction(double t_s, Setpoint* sp);

  ControllerParams p_;
  CascadeController cascade_;
  PlatformTracker tracker_;
  std::vector<PlatformObservation> pending_;
  AltitudeEstimate altitude_;
  Mode mode_{Mode::kSearch};
  std::vector<ModeTransition> transitions_;
  LandingDiagnostics diag_;
  bool started_{false};
  double yaw_hold_{0.0};         // heading setpoint (rad)
  double search_t0_{0.0};        // search entry time (s)
  double search_yaw0_{0.0};      // heading at search entry (rad)
  double last_outer_t_{0.0};
  Eigen::Vector3d hold_p_{Eigen::Vector3d::Zero()};    // search / go-around target
  Eigen::Vector3d follow_p_{Eigen::Vector3d::Zero()};  // observe: slewed platform follow point
  Eigen::Vector2d follow_catch_v_{Eigen::Vector2d::Zero()};  // its velocity rel. to platform
  CubicTrajectory approach_;
  double recovery_h_sp_{0.0};  // recovery: gear-clearance setpoint above the top (m)
  Eigen::Vector2d servo_int_{Eigen::Vector2d::Zero()};  // visual-servo integral (m)
  double platform_vz_lp_{0.0};  // platform vertical velocity, low-passed (m/s), recovery
  double cut_t_{0.0};
  double contact_accum_s_{0.0};
  double last_inner_t_{0.0};
  Setpoint last_sp_;
  RotorCommand last_cmd_;
  long rejected_inputs_{0};
};

}  // namespace lander::ctl
