// The landing modes, one class each (PX4's flight tasks: each owns its state, `enter` is its
// activation, `update` its outer step). A mode's update returns the setpoint of the step or
// the transition it takes instead; the machine (landing_controller.cpp) applies transitions
// from the one table of transitions.h, entering the next mode and updating it within the
// same step.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "lander/controller/path_guidance.h"
#include "lander/controller/trajectory.h"
#include "modes/context.h"
#include "modes/transitions.h"

namespace lander::ctl::modes {

// What one outer step of a mode gives: the setpoint, or a transition taken instead.
struct ModeResult {
  Setpoint setpoint;
  std::optional<Transition> next;

  static ModeResult stay(const Setpoint& sp) { return {sp, std::nullopt}; }
  static ModeResult go(Mode to, std::string reason, Exit exit = Exit::kSwitch) {
    return {Setpoint{}, Transition{to, std::move(reason), exit}};
  }
};

class LandingMode {
 public:
  virtual ~LandingMode() = default;
  // Entry actions, after the machine switched here from `from` for `reason`.
  virtual void enter(LandingContext& c, const Tick& k, Mode from, const std::string& reason) = 0;
  // One outer step.
  virtual ModeResult update(LandingContext& c, const Tick& k) = 0;
};

// The observe follow point (observe, the broadcast search): starts at the vehicle with its
// velocity relative to v_plat (bounded by observe_follow_max_speed_mps); each step moves with
// v_plat and closes the gap to a target at a bounded catch-up speed and acceleration.
class FollowPoint {
 public:
  void start(const NavState& nav, const Eigen::Vector2d& v_plat, const LandingParams& L);
  void slew(const Eigen::Vector2d& target, const Eigen::Vector2d& v_plat, double dt, const LandingParams& L);
  Eigen::Vector2d position() const { return p_.head<2>(); }
  const Eigen::Vector2d& catch_up_velocity() const { return catch_v_; }

 private:
  Eigen::Vector3d p_{Eigen::Vector3d::Zero()};
  Eigen::Vector2d catch_v_{Eigen::Vector2d::Zero()};  // velocity relative to the platform
};

// Target not (yet) in view: fly to a prediction or a broadcast of the platform, else sweep
// the heading, spiral out and climb (see Mode::kSearch).
class SearchMode final : public LandingMode {
 public:
  // The first search, at the first navigation state (no entry transition).
  void start(const LandingContext& c, double t_s);
  void enter(LandingContext& c, const Tick& k, Mode from, const std::string& reason) override;
  ModeResult update(LandingContext& c, const Tick& k) override;

 private:
  std::optional<Transition> exit_check(const LandingContext& c, const Tick& k) const;
  Setpoint first_search(LandingContext& c, const Tick& k);
  Setpoint sweep(LandingContext& c, const Tick& k);
  Setpoint after_loss(LandingContext& c, double t_s);
  Setpoint at_broadcast(LandingContext& c, const Tick& k, const Eigen::Vector2d& p, const Eigen::Vector2d& v);
  void expand(LandingContext& c, double t_exp_s, Setpoint* sp);
  void climb(const LandingContext& c, double t_climb_s, double rate_mps, Setpoint* sp) const;

  double t0_s_{0.0};        // start of the current sweep pattern (s)
  double entry_t_s_{0.0};   // search entry (s): search_give_up_s counts from it
  double yaw0_rad_{0.0};    // heading at search entry (rad)
  double climb_z_m_{-std::numeric_limits<double>::infinity()};  // highest climb setpoint of
                            // the first search, kept over a fix not yet acquired (m)
  bool after_loss_{false};  // entered with a fix history
  double t_seen_s_{0.0};    // last fix before that search's loss (s)
  Eigen::Vector2d centre_{Eigen::Vector2d::Zero()};  // pattern centre (m)
  bool broadcast_following_{false};  // the follow point flies to the broadcast
  double broadcast_arrived_t_s_{std::numeric_limits<double>::quiet_NaN()};  // came within
                            // telemetry_arrive_radius_m of it (s)
  FollowPoint follow_;
};

// seed 000 3.1: target in view, collect fixes, follow it horizontally.
class ObserveMode final : public LandingMode {
 public:
  void enter(LandingContext& c, const Tick& k, Mode from, const std::string& reason) override;
  ModeResult update(LandingContext& c, const Tick& k) override;

 private:
  void follow(LandingContext& c, const Tick& k, Setpoint* sp);
  double entry_t_s_{0.0};  // when observe was last entered (approach_entry_wait_s)
  // Height above the platform (m), fixed at entry (the height where the target was
  // acquired): the hold rides on the platform's height seen by vision, not on absolute W.
  double above_platform_m_{std::numeric_limits<double>::quiet_NaN()};
  FollowPoint follow_;
};

// seed 000 3.2: fly the eq. 29 cubic to the eq. 28 prediction.
class ApproachMode final : public LandingMode {
 public:
  void enter(LandingContext& c, const Tick& k, Mode from, const std::string& reason) override;
  ModeResult update(LandingContext& c, const Tick& k) override;

 private:
  std::optional<Transition> loss_check(LandingContext& c, const Tick& k) const;
  void plan_relative(LandingContext& c, const Tick& k);
  void plan_world(LandingContext& c, const Tick& k);
  void track_relative(LandingContext& c, const Tick& k) const;
  Setpoint relative_setpoint(const LandingContext& c, const Tick& k) const;
  void replan(LandingContext& c, const Tick& k);
  std::optional<Transition> recovery_check(const LandingContext& c, const Tick& k) const;
  CubicTrajectory plan_;  // in W (world), or the offset from the platform (platform)
  bool relative_{true};   // approach_frame platform
};

// seed 000 3.3: visual-servo tracking, the bounded final decision and the controlled
// descent; its decisions are the pure functions of recovery_decisions.h.
class RecoveryMode final : public LandingMode {
 public:
  void enter(LandingContext& c, const Tick& k, Mode from, const std::string& reason) override;
  ModeResult update(LandingContext& c, const Tick& k) override;

 private:
  std::optional<Transition> exit_check(LandingContext& c, const Tick& k) const;
  void start_final_stage(LandingContext& c, const Tick& k);
  std::optional<Transition> final_decision(LandingContext& c, const Tick& k, double rel_speed, bool fresh);
  std::optional<Transition> wide_gate_watch(LandingContext& c, const Tick& k);
  std::optional<Transition> cut_check(LandingContext& c, const Tick& k, bool fresh);
  Setpoint servo(LandingContext& c, const Tick& k, double rel_speed, bool fresh);

  double h_sp_m_{0.0};  // gear-clearance setpoint above the top (m)
  Eigen::Vector2d servo_int_{Eigen::Vector2d::Zero()};  // visual-servo integral (m)
  double platform_vz_lp_{0.0};  // platform vertical velocity, low-passed (m/s)
  double final_t0_s_{std::numeric_limits<double>::quiet_NaN()};  // final stage entry (s)
  double t0_s_{0.0};  // recovery entry (s)
  bool wide_committed_{false};
  int wide_departures_{0};  // times the error left the wide gate after the commit
  double wide_left_t_s_{std::numeric_limits<double>::quiet_NaN()};  // outside since (s)
  bool deck_window(LandingContext& c, const Tick& k, std::string* why);
  struct DeckFeedForward {
    bool valid{false};
    double vz_mps{0.0};   ///< the deck's predicted vertical speed (m/s)
    double az_mps2{0.0};  ///< its predicted vertical acceleration (m/s^2)
  };
  DeckFeedForward deck_feed_forward(const LandingContext& c, double t_s) const;
  bool deck_moving_{false};  // this step: the deck moves and the touchdown is timed on it
  double deck_window_end_s_{-std::numeric_limits<double>::infinity()};  // committed period's end
  std::string deck_window_why_;
  bool deck_quiescent_{true};  // this step: not a moving deck, or in a quiescent period
  std::string deck_state_;     // this step: deck_window's reason
};

// Motors cut, waiting for contact (detected on the inner loop's IMU samples).
class TouchdownMode final : public LandingMode {
 public:
  void enter(LandingContext& c, const Tick& k, Mode from, const std::string& reason) override;
  ModeResult update(LandingContext& c, const Tick& k) override;
  // Every inner step: contact (-> landed) or none within contact_timeout_s (-> go-around).
  std::optional<Transition> detect_contact(const LandingContext& c, double t_s, double dt_s,
                                           const ImuSample& imu);

 private:
  double cut_t_s_{0.0};
  double contact_accum_s_{0.0};
};

// Contact confirmed; motors stay off.
class LandedMode final : public LandingMode {
 public:
  void enter(LandingContext& c, const Tick& k, Mode from, const std::string& reason) override;
  ModeResult update(LandingContext& c, const Tick& k) override;
};

// Climb back to the observe height after a loss or a large error, the cart kept below.
class GoAroundMode final : public LandingMode {
 public:
  void enter(LandingContext& c, const Tick& k, Mode from, const std::string& reason) override;
  ModeResult update(LandingContext& c, const Tick& k) override;
};

// Terminal: straight up to the go-around height and hold (see Mode::kAborted).
class AbortedMode final : public LandingMode {
 public:
  void enter(LandingContext& c, const Tick& k, Mode from, const std::string& reason) override;
  ModeResult update(LandingContext& c, const Tick& k) override;
};

// seed 003: follow a painted route (path_guidance.h) until the target is acquired.
class FollowPathMode final : public LandingMode {
 public:
  void enter(LandingContext& c, const Tick& k, Mode from, const std::string& reason) override;
  ModeResult update(LandingContext& c, const Tick& k) override;

  long steps() const { return steps_; }
  long target_steps() const { return target_steps_; }

 private:
  // One outer step of the guidance law (seed 003 eq. 10-17).
  Setpoint guide(LandingContext& c, const Tick& k);
  void extend_trail(const Tick& k);
  GroundView ground_view(const LandingContext& c, const NavState& nav) const;
  Eigen::Vector2d travel_direction(const PathGuidanceParams& P, const NavState& nav) const;
  // The candidates on the ground, and which lie on the flown trail (set aside).
  void classify(const LandingContext& c, const NavState& nav, const GroundView& g, const Eigen::Vector2d& U,
                std::vector<Eigen::Vector2d>* ground, std::vector<bool>* excluded) const;
  std::optional<std::size_t> pick_target(const LandingContext& c, const Eigen::Vector2d& U,
                                         const Eigen::Vector2d& v_img, std::vector<bool>* excluded) const;
  Setpoint fly_to_target(LandingContext& c, const Tick& k, const Eigen::Vector2d& target);
  Setpoint no_target(LandingContext& c, double t_s, const Eigen::Vector2d& here);
  Setpoint pixel_distribution(LandingContext& c, const Tick& k, const GroundView& g, const Eigen::Vector2d& U,
                              const Eigen::Vector2d& v_img, const std::vector<Eigen::Vector2d>& candidates);

  double last_target_t_{0.0};  // last step with a target point (s)
  bool dir_known_{false};
  Eigen::Vector2d dir_W_{Eigen::Vector2d::UnitX()};
  double z_{0.0};  // constant height in W (m)
  std::vector<Eigen::Vector2d> trail_;  // flown positions (dead-reckoned), 0.1 m apart
  Eigen::Vector2d dr_{Eigen::Vector2d::Zero()};  // dead-reckoned position (m)
  double dr_t_{0.0};
  long steps_{0}, target_steps_{0};
};

}  // namespace lander::ctl::modes
