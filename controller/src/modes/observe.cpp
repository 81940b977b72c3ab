// The observe mode (seed 000 section 3.1): the target in view, fixes collected while the
// vehicle follows the platform horizontally.
#include <cmath>

#include <fmt/format.h>

#include "modes/modes.h"

namespace lander::ctl::modes {
namespace {

// Below this horizontal distance the bearing to the platform is dominated by vision noise and
// the platform is near the image centre anyway: the heading is no longer aligned (m).
constexpr double kAlignMinDistance_m = 1.5;

// The heading that turns the wide image axis (body y) towards a platform off to the side: of
// the two headings with body y along the bearing, the one nearer the current heading.
double wide_axis_heading(const Eigen::Vector2d& to_plat, double current_yaw_rad) {
  const double bearing = std::atan2(to_plat.y(), to_plat.x());
  const double yaw_a = std::remainder(bearing - M_PI / 2, 2 * M_PI);
  const double yaw_b = std::remainder(bearing + M_PI / 2, 2 * M_PI);
  return std::abs(std::remainder(yaw_a - current_yaw_rad, 2 * M_PI)) <
                 std::abs(std::remainder(yaw_b - current_yaw_rad, 2 * M_PI))
             ? yaw_a
             : yaw_b;
}

}  // namespace

void ObserveMode::enter(LandingContext& c, const Tick& k, Mode /*from*/, const std::string& /*reason*/) {
  entry_t_s_ = k.t_s;
  c.reset_reach();
  // Start the follow point with the vehicle's own velocity relative to the platform
  // estimate (zero without one): no jump in the velocity feed-forward.
  follow_.start(k.nav,
                c.tracker.num_fixes() >= kMinFixesForFeedForward ? Eigen::Vector2d(c.tracker.velocity().head<2>())
                                                                  : Eigen::Vector2d::Zero(),
                c.p.landing);
  c.hold_p = k.nav.p_W_m;  // observe height: where the target was acquired
  above_platform_m_ = c.tracker.has_fix() ? k.nav.p_W_m.z() - c.diag.platform_W_m.z()
                                          : std::numeric_limits<double>::quiet_NaN();
}

ModeResult ObserveMode::update(LandingContext& c, const Tick& k) {
  const LandingParams& L = c.p.landing;
  const double t_s = k.t_s;
  if (!c.in_view(t_s, L.loss_timeout_s)) {
    c.declare_loss(t_s);
    return ModeResult::go(Mode::kSearch, fmt::format("target lost for {:.2f} s while observing{}",
                                                     c.loss_age_s(t_s), c.reach_note()));
  }
  c.check_reach(t_s);
  const bool close = L.approach_entry_max_error_m <= 0.0 || !c.tracker.has_fix() ||
                     c.diag.horizontal_error_m <= L.approach_entry_max_error_m;
  const bool waited = t_s - entry_t_s_ >= L.approach_entry_wait_s;
  if (c.tracker.total_fixes() >= L.observe_frames && (close || waited)) {
    std::string why = fmt::format("{} keyframes observed (>= {})", c.tracker.total_fixes(), L.observe_frames);
    if (!close) {
      why += fmt::format("; {:.2f} m off the platform after {:.1f} s of observing "
                         "(approach_entry_wait_s)",
                         c.diag.horizontal_error_m, t_s - entry_t_s_);
    }
    return ModeResult::go(Mode::kApproach, why);
  }
  Setpoint sp = c.hold(c.hold_p);
  // The height is held above the platform's height now (navigation + vision relative
  // vector), as the approach's: a step of the navigation height (a degraded GPS) cancels
  // in it, where a hold in absolute W moved the vehicle by the whole step.
  if (c.tracker.has_fix() && std::isfinite(above_platform_m_)) {
    sp.p_W_m.z() = c.diag.platform_W_m.z() + above_platform_m_;
  }
  if (c.tracker.has_fix()) follow(c, k, &sp);
  return ModeResult::stay(sp);
}

// Follow the platform horizontally at the observe height to keep it centred: the follow
// point moves with the platform's velocity (fed forward) and closes the rest of the gap at a
// bounded catch-up speed on top (no setpoint jumps). Between detections position_now()
// carries the last fix on with that velocity.
void ObserveMode::follow(LandingContext& c, const Tick& k, Setpoint* sp) {
  const Eigen::Vector3d target = c.tracker.position_now(k.t_s);
  // Velocity feed-forward only once the fit has enough fixes (far away, a few noisy fixes
  // make a velocity of metres per second out of centimetres of noise).
  Eigen::Vector2d v_plat = Eigen::Vector2d::Zero();
  if (c.tracker.num_fixes() >= kMinFixesForFeedForward) v_plat = c.tracker.velocity().head<2>();
  // Catch-up velocity relative to the platform: proportional near it, bounded by the speed
  // that can still stop within the gap at the follow acceleration, and by the catch-up
  // speed. Its changes are acceleration-limited: accelerating tilts the camera (fixed under
  // the body) away from a platform ahead, and a hard start loses it.
  follow_.slew(target.head<2>(), v_plat, k.dt_s, c.p.landing);
  sp->p_W_m.head<2>() = follow_.position();
  sp->v_W_mps.head<2>() = v_plat + follow_.catch_up_velocity();
  // Turn the wide image axis (body y) towards the platform while it is off to the side, so
  // an acquisition near the image corner does not lose it again.
  const Eigen::Vector2d to_plat = target.head<2>() - k.nav.p_W_m.head<2>();
  if (to_plat.norm() > kAlignMinDistance_m) {
    c.yaw_hold_rad = wide_axis_heading(to_plat, yaw_of(k.nav.q_WB));
    sp->yaw_rad = c.yaw_hold_rad;
  }
}

}  // namespace lander::ctl::modes
