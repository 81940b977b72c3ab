// The approach mode (seed 000 section 3.2): the eq. 29 cubic to the eq. 28 prediction of the
// platform at t_d, replanned as fixes arrive.
#include <algorithm>

#include <fmt/format.h>

#include "modes/modes.h"

namespace lander::ctl::modes {

// seed 000 eq. 28-29: t_d from the distance at the nominal approach speed.
void ApproachMode::enter(LandingContext& c, const Tick& k, Mode /*from*/, const std::string& reason) {
  const LandingParams& L = c.p.landing;
  const double t_s = k.t_s;
  relative_ = L.approach_frame == "platform";
  if (relative_) {
    plan_relative(c, k);
  } else {
    plan_world(c, k);
  }
  c.diag.approach_planned = true;
  c.diag.approach_t0_s = t_s;
  c.diag.approach_td_s = plan_.td();
  c.diag.replans = 0;
  ++c.decisions.attempts;  // a landing attempt starts with the approach
  c.log_event(t_s, "attempt_started", reason);
}

// approach_frame platform: the cubic from the vehicle's offset to the platform (and its
// relative velocity) to approach_epsilon_m above the top at rest relative to it, over the
// same t_d as eq. 29's; update() flies it on top of the platform's position and velocity.
void ApproachMode::plan_relative(LandingContext& c, const Tick& k) {
  const LandingParams& L = c.p.landing;
  const Eigen::Vector3d rd(0, 0, L.approach_epsilon_m);
  const Eigen::Vector3d r0 = k.nav.p_W_m - c.diag.platform_W_m;
  const double T = std::clamp((r0 - rd).norm() / L.approach_speed_mps, L.approach_min_duration_s,
                              L.approach_max_duration_s);
  Eigen::Vector3d v0 = k.nav.v_W_mps;
  v0.head<2>() -= c.diag.platform_v_W_mps.head<2>();
  plan_ = CubicTrajectory(r0, k.t_s, rd, k.t_s + T, v0, Eigen::Vector3d::Zero());
}

// approach_frame world: seed 000 eq. 29 in W to the eq. 28 prediction of the platform at t_d.
void ApproachMode::plan_world(LandingContext& c, const Tick& k) {
  const LandingParams& L = c.p.landing;
  const double t_s = k.t_s;
  const Eigen::Vector3d eps(0, 0, L.approach_epsilon_m);
  const Eigen::Vector3d goal_now = c.tracker.position_now(t_s) + eps;
  const double T = std::clamp((goal_now - k.nav.p_W_m).norm() / L.approach_speed_mps, L.approach_min_duration_s,
                              L.approach_max_duration_s);
  const double td = t_s + T;
  Eigen::Vector3d v0 = Eigen::Vector3d::Zero(), vd = Eigen::Vector3d::Zero();
  if (L.approach_match_velocities) {
    v0 = k.nav.v_W_mps;
    vd.head<2>() = c.tracker.velocity().head<2>();
  }
  // The goal's height: the platform's height now (from the vision relative vector, see
  // the approach's setpoint below), not the fit's extrapolation of it.
  Eigen::Vector3d goal = c.tracker.predict(td) + eps;
  goal.z() = c.diag.platform_W_m.z() + eps.z();
  plan_ = CubicTrajectory(k.nav.p_W_m, t_s, goal, td, v0, vd);
}

ModeResult ApproachMode::update(LandingContext& c, const Tick& k) {
  if (auto lost = loss_check(c, k)) return {Setpoint{}, lost};
  c.check_reach(k.t_s);
  if (relative_) {
    track_relative(c, k);
    if (auto next = recovery_check(c, k)) return {Setpoint{}, next};
    return ModeResult::stay(relative_setpoint(c, k));
  }
  replan(c, k);
  if (auto next = recovery_check(c, k)) return {Setpoint{}, next};
  // The height as the plan's height above its goal, on top of the platform's height now
  // (nav.p + the vision relative vector): a step of the navigation height (a GPS with
  // metres of vertical error) moves the platform's estimate with it and cancels, as in
  // recovery's clearance servo. Planned in absolute W, a 5 m step of the navigation
  // height during an approach (unseen campaign seed 73129, default-0005) put the goal
  // 5 m below the platform and the vehicle met the top at 1.5 m/s.
  const double eps_z = c.p.landing.approach_epsilon_m;
  Setpoint sp = plan_.setpoint(k.t_s, c.yaw_hold_rad);
  sp.p_W_m.z() = c.diag.platform_W_m.z() + eps_z + (sp.p_W_m.z() - plan_.goal().z());
  return ModeResult::stay(sp);
}

// The target lost: a go-around low over the platform, the search higher up.
std::optional<Transition> ApproachMode::loss_check(LandingContext& c, const Tick& k) const {
  const LandingParams& L = c.p.landing;
  const double t_s = k.t_s;
  if (c.in_view(t_s, L.loss_timeout_s)) return std::nullopt;
  const double loss_age = c.loss_age_s(t_s);
  c.declare_loss(t_s);
  if (c.diag.gear_clearance_m < L.go_around_low_height_m) {
    return Transition{Mode::kGoAround,
                      fmt::format("target lost for {:.2f} s during approach at {:.2f} m above the platform{}",
                                  loss_age, c.diag.gear_clearance_m, c.reach_note()),
                      Exit::kEndAttempt};
  }
  return Transition{Mode::kSearch, fmt::format("target lost for {:.2f} s during approach{}", loss_age, c.reach_note()),
                    Exit::kEndAttempt};
}

// approach_frame platform: the goal is the platform now (no prediction to replan); |Diff|
// is the horizontal distance to it.
void ApproachMode::track_relative(LandingContext& c, const Tick& k) const {
  c.diag.approach_goal_W_m = c.diag.platform_W_m + plan_.goal();
  c.diag.approach_diff_m = horizontal(c.diag.approach_goal_W_m - k.nav.p_W_m);
}

// The relative cubic on top of the platform's position, velocity and (fed forward as
// recovery does, with its deadband) horizontal acceleration now.
Setpoint ApproachMode::relative_setpoint(const LandingContext& c, const Tick& k) const {
  const LandingParams& L = c.p.landing;
  Setpoint sp = plan_.setpoint(k.t_s, c.yaw_hold_rad);
  sp.p_W_m += c.diag.platform_W_m;
  sp.v_W_mps.head<2>() += c.diag.platform_v_W_mps.head<2>();
  const Eigen::Vector2d a_plat = c.tracker.acceleration().head<2>();
  const double share =
      accel_feed_forward_share(a_plat.norm(), L.platform_accel_ff_deadband_mps2, L.platform_accel_ff_full_mps2);
  sp.a_W_mps2.head<2>() += L.platform_accel_ff_gain * share * a_plat;
  return sp;
}

// Replan (seed 000 section 3.2): new fixes -> new prediction of P_d at the same t_d.
void ApproachMode::replan(LandingContext& c, const Tick& k) {
  const LandingParams& L = c.p.landing;
  const Eigen::Vector3d eps(0, 0, L.approach_epsilon_m);
  if (k.t_s < plan_.td() && c.tracker.has_fix() && c.tracker.latest().t_s > c.diag.approach_t0_s) {
    // The goal moves towards the new prediction at a bounded rate.
    Eigen::Vector3d step = c.tracker.predict(plan_.td()) + eps - plan_.goal();
    step.z() = 0.0;  // the height is re-anchored on the platform every step instead
    const double max_step = L.approach_goal_max_rate_mps * k.dt_s;
    if (step.norm() > max_step) step *= max_step / step.norm();
    plan_.set_goal(plan_.goal() + step);
    ++c.diag.replans;
  }
  c.diag.approach_goal_W_m = plan_.goal();
  c.diag.approach_diff_m = horizontal(plan_.goal() - k.nav.p_W_m);
}

// Recovery servos on vision, so it is entered only with a fresh detection; otherwise the
// approach holds P_d until the target is back or the loss timeout fires.
std::optional<Transition> ApproachMode::recovery_check(const LandingContext& c, const Tick& k) const {
  const LandingParams& L = c.p.landing;
  const double t_s = k.t_s;
  if (!(t_s >= plan_.td() && c.in_view(t_s, L.recovery_loss_timeout_s))) return std::nullopt;
  if (c.diag.approach_diff_m < L.approach_switch_error_m) {
    return Transition{Mode::kRecovery, fmt::format("|Diff| = {:.3f} m < {:.3f} m at t >= t_d",
                                                   c.diag.approach_diff_m, L.approach_switch_error_m)};
  }
  if (t_s > plan_.td() + L.approach_settle_timeout_s) {
    return Transition{Mode::kRecovery,
                      fmt::format("|Diff| = {:.3f} m still above {:.3f} m {:.1f} s after t_d; target in view",
                                  c.diag.approach_diff_m, L.approach_switch_error_m, L.approach_settle_timeout_s)};
  }
  return std::nullopt;
}

}  // namespace lander::ctl::modes
