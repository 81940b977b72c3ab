// The search mode (see Mode::kSearch) and the follow point it shares with observe.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "modes/modes.h"

namespace lander::ctl::modes {
namespace {

// Gain of the observe catch-up velocity on the remaining gap near the platform (1/s): below
// the position loop's 1.3 1/s so the follow point does not chase vision noise.
constexpr double kFollowGain_per_s = 1.0;

// Delay of the first search's climb (search_first_climb_rate_mps): a target in view at the
// start is acquired in ~0.15 s (reacquire_frames = 3 keyframes at 30 Hz after the 50 ms
// vision latency); 0.3 s leaves such starts as they were and costs a cart driving off
// little (Search.FirstClimbFindsACartDrivingAwayFromALowStart: acquired at 1.87 s against
// 1.84 s with no delay, 5.8 s with a 1 s delay).
constexpr double kFirstClimbDelay_s = 0.3;

// Outward spiral t_spiral_s after it starts: offset from its centre and velocity relative
// to it (both zero before it starts or with search_spiral_speed_mps = 0).
void spiral_offset(const LandingParams& L, double t_spiral_s, Eigen::Vector2d* off, Eigen::Vector2d* v) {
  off->setZero();
  v->setZero();
  if (L.search_spiral_speed_mps <= 0.0 || t_spiral_s <= 0.0) return;
  // Archimedean spiral r = b theta around the centre, flown at constant speed: the arc
  // length from the centre is ~ b theta^2 / 2, so theta = sqrt(2 s / b). Beyond the maximum
  // radius it goes on around the circle.
  const double b = L.search_spiral_spacing_m / (2.0 * M_PI);
  const double s = L.search_spiral_speed_mps * t_spiral_s;
  const double theta_max = L.search_max_radius_m / b;
  const double s_max = 0.5 * b * theta_max * theta_max;
  double theta = 0.0, r = 0.0;
  if (s < s_max) {
    theta = std::sqrt(2.0 * s / b);
    r = b * theta;
  } else {
    r = L.search_max_radius_m;
    theta = theta_max + (s - s_max) / r;
  }
  const Eigen::Vector2d radial(std::cos(theta), std::sin(theta));
  const Eigen::Vector2d tangential(-std::sin(theta), std::cos(theta));
  *off = r * radial;
  // Velocity along the curve: d/dtheta of r(theta) e_r is b e_r + r e_t (b = 0 on the circle).
  const Eigen::Vector2d dir = (s < s_max ? b : 0.0) * radial + r * tangential;
  if (dir.norm() > 1e-9) *v = L.search_spiral_speed_mps * dir.normalized();
}

}  // namespace

void FollowPoint::start(const NavState& nav, const Eigen::Vector2d& v_plat, const LandingParams& L) {
  p_ = nav.p_W_m;
  catch_v_ = nav.v_W_mps.head<2>() - v_plat;
  // ... bounded by the catch-up speed (a fast entry is braked by the follow, not carried on).
  if (catch_v_.norm() > L.observe_follow_max_speed_mps) {
    catch_v_ *= L.observe_follow_max_speed_mps / catch_v_.norm();
  }
}

void FollowPoint::slew(const Eigen::Vector2d& target, const Eigen::Vector2d& v_plat, double dt,
                       const LandingParams& L) {
  const Eigen::Vector2d gap = target - p_.head<2>();
  const double g = gap.norm();
  Eigen::Vector2d catch_want = Eigen::Vector2d::Zero();
  if (g > 1e-9) {
    const double speed = std::min({L.observe_follow_max_speed_mps, kFollowGain_per_s * g,
                                   std::sqrt(2.0 * L.observe_follow_max_accel_mps2 * g)});
    catch_want = gap * (speed / g);
  }
  Eigen::Vector2d dv = catch_want - catch_v_;
  const double max_dv = L.observe_follow_max_accel_mps2 * dt;
  if (dv.norm() > max_dv) dv *= max_dv / dv.norm();
  catch_v_ += dv;
  p_.head<2>() += (v_plat + catch_v_) * dt;
}

void SearchMode::start(const LandingContext& c, double t_s) {
  yaw0_rad_ = c.yaw_hold_rad;
  t0_s_ = t_s;
  entry_t_s_ = t_s;
}

void SearchMode::enter(LandingContext& c, const Tick& k, Mode /*from*/, const std::string& /*reason*/) {
  start(c, k.t_s);
  // The history is kept: search flies to its prediction of the platform (see
  // search_predict_max_s) and a re-acquisition continues it.
  c.hold_p = k.nav.p_W_m;  // keep_min_height raises it in the search's first step
  climb_z_m_ = -std::numeric_limits<double>::infinity();
  after_loss_ = c.tracker.has_fix();
  t_seen_s_ = after_loss_ ? c.tracker.latest().t_s : k.t_s;
  centre_ = k.nav.p_W_m.head<2>();
  broadcast_arrived_t_s_ = std::numeric_limits<double>::quiet_NaN();
  broadcast_following_ = false;
}

ModeResult SearchMode::update(LandingContext& c, const Tick& k) {
  if (auto next = exit_check(c, k)) return {Setpoint{}, next};
  c.keep_min_height(k.t_s, k.nav);
  // After a loss: fly to where the motion model predicts the platform instead of holding
  // while the cart drives away, then widen the search around it.
  if (after_loss_) return ModeResult::stay(after_loss(c, k.t_s));
  return ModeResult::stay(first_search(c, k));
}

// The target acquired, a route to follow, or a search that found nothing.
std::optional<Transition> SearchMode::exit_check(const LandingContext& c, const Tick& k) const {
  const LandingParams& L = c.p.landing;
  const double t_s = k.t_s;
  if (c.tracker.keyframe_streak() >= L.reacquire_frames && c.in_view(t_s, L.loss_timeout_s)) {
    return Transition{Mode::kObserve,
                      fmt::format("target acquired: {} consecutive keyframes", c.tracker.keyframe_streak())};
  }
  // A painted route in view and the target not (seed 003): follow the route. Never again
  // after its end was reached (the vehicle holds there).
  if (c.p.path.enabled && !c.route_ended && c.route.streak >= c.p.path.enter_frames &&
      t_s - c.route.last_t_s < c.p.path.route_lost_s) {
    return Transition{Mode::kFollowPath,
                      fmt::format("route in view: {} frames with >= {} candidate points, target not acquired",
                                  c.route.streak, c.p.path.enter_min_points)};
  }
  // Bounded search (issue 10): a target not found this long after entering search ends
  // the landing with the reason, instead of a search until the battery runs out.
  if (t_s - entry_t_s_ >= L.search_give_up_s) {
    return Transition{Mode::kAborted,
                      after_loss_ ? fmt::format("target not re-acquired in {:.1f} s of search after the loss "
                                                "(last seen at {:.2f} s)",
                                                t_s - entry_t_s_, t_seen_s_)
                                  : fmt::format("target not found in {:.1f} s of search", t_s - entry_t_s_),
                      Exit::kGiveUp};
  }
  return std::nullopt;
}

// Not acquired yet: to a fix (fewer than reacquire_frames keyframes in a row), to the
// platform's broadcast, or the sweep.
Setpoint SearchMode::first_search(LandingContext& c, const Tick& k) {
  // Not acquired yet, but a fix already: fly to it, as before issue 10 (and sweep afresh
  // once it is too old).
  const bool had_fix = c.tracker.has_fix();
  Eigen::Vector2d p_pred, v_pred;
  // What the search's climb gained is kept: a first fix at the view's edge (not yet
  // acquired) would otherwise take the vehicle back down to where the search began,
  // narrowing the view while it flies to that fix (and the sweep after it would climb
  // again from there). Only with a fix: the climb itself ramps from hold_p's height.
  if (had_fix) c.hold_p.z() = std::max(c.hold_p.z(), climb_z_m_);
  if (c.predict_platform(k.t_s, &p_pred, &v_pred)) {
    c.hold_p.head<2>() = p_pred;
    Setpoint sp = c.hold(c.hold_p);
    sp.v_W_mps.head<2>() = v_pred;
    c.diag.search_centre_W_m = c.hold_p;
    return sp;
  }
  if (had_fix) {
    t0_s_ = k.t_s;
    yaw0_rad_ = c.yaw_hold_rad;
  }
  // The platform's broadcast position, if one is received: fly there.
  if (c.broadcast_platform(k.t_s, &p_pred, &v_pred)) return at_broadcast(c, k, p_pred, v_pred);
  broadcast_following_ = false;
  return sweep(c, k);
}

// Nothing to predict from: heading sweep. The 1280 px image axis is along body y, so turning
// the vehicle scans a circle of radius ~h tan(45 deg) instead of the 29 deg half-angle along
// body x. After search_spiral_after_s, an outward spiral around hold_p.
Setpoint SearchMode::sweep(LandingContext& c, const Tick& k) {
  const LandingParams& L = c.p.landing;
  const double t_s = k.t_s;
  c.yaw_hold_rad = std::remainder(yaw0_rad_ + L.search_yaw_rate_degps * M_PI / 180.0 * (t_s - t0_s_), 2 * M_PI);
  Setpoint sp = c.hold(c.hold_p);
  Eigen::Vector2d off, off_v;
  const double t_spiral = t_s - t0_s_ - L.search_spiral_after_s;
  spiral_offset(L, t_spiral, &off, &off_v);
  sp.p_W_m.head<2>() += off;
  sp.v_W_mps.head<2>() = off_v;
  // With the spiral, a climb for a wider view, as after a loss (never below the height the
  // search started at): a start low over a cart driving away leaves the view before the
  // first sweep ends. With search_first_climb_rate_mps the climb starts with the sweep
  // (it is faster than the spiral's, so it stays above that climb's height throughout).
  // The first climb waits kFirstClimbDelay_s: a target in view at the start is acquired
  // well within it, and such starts fly as without the climb.
  const double t_first_climb = t_s - t0_s_ - kFirstClimbDelay_s;
  if (L.search_first_climb_rate_mps > 0.0 && t_first_climb > 0.0) {
    climb(c, t_first_climb, std::max(L.search_first_climb_rate_mps, L.search_climb_rate_mps), &sp);
  } else if (t_spiral > 0.0) {
    climb(c, t_spiral, L.search_climb_rate_mps, &sp);
  }
  climb_z_m_ = std::max(climb_z_m_, sp.p_W_m.z());
  c.diag.search_centre_W_m = c.hold_p;
  return sp;
}

// Search after a loss (issue 10). The pattern's centre is the motion model's prediction of
// the platform (a turning cart keeps turning, a braking one stops), carried with its velocity
// fed forward, until search_predict_max_s after the last fix; then it stays where the
// prediction led. Until search_expand_after_s after the last fix the vehicle flies to the
// centre with the heading held (the prediction alone usually brings the target back); from
// then on the uncertainty has outgrown the view: an outward spiral around the centre
// (search_spiral_spacing_m, search_spiral_speed_mps relative to it) with the heading sweep,
// and a climb at search_climb_rate_mps to at most search_max_height_m above the top for a
// wider view.
//
// Once the tracker's history is too old to predict from, or while its prediction lies more
// than telemetry_override_m from the platform's broadcast position (a fast platform seen for
// a moment: a velocity from a few fixes puts it tens of metres off within seconds), the
// broadcast carries the centre.
Setpoint SearchMode::after_loss(LandingContext& c, double t_s) {
  const LandingParams& L = c.p.landing;
  Eigen::Vector2d centre_v = Eigen::Vector2d::Zero();
  Eigen::Vector2d pred, pred_v, bc, bc_v;
  const bool predicted = c.predict_platform(t_s, &pred, &pred_v);
  const bool broadcast = c.broadcast_platform(t_s, &bc, &bc_v);
  if (broadcast && (!predicted || (pred - bc).norm() > L.telemetry_override_m)) {
    centre_ = bc;
    centre_v = bc_v;
    ++c.telemetry_search_steps;
  } else if (predicted) {
    centre_ = pred;
    centre_v = pred_v;
  }
  c.diag.search_centre_W_m = Eigen::Vector3d(centre_.x(), centre_.y(), c.platform_z());
  Setpoint sp = c.hold(c.hold_p);
  sp.p_W_m.head<2>() = centre_;
  sp.v_W_mps.head<2>() = centre_v;
  const double t_expand0 = std::max(t0_s_, t_seen_s_ + L.search_expand_after_s);
  if (t_s <= t_expand0) return sp;
  expand(c, t_s - t_expand0, &sp);
  return sp;
}

// The expanding part of a search around a (moving) centre, t_exp_s after it began: the
// outward spiral added to sp, the heading sweep and the climb.
void SearchMode::expand(LandingContext& c, double t_exp_s, Setpoint* sp) {
  const LandingParams& L = c.p.landing;
  Eigen::Vector2d off, off_v;
  spiral_offset(L, t_exp_s, &off, &off_v);
  sp->p_W_m.head<2>() += off;
  sp->v_W_mps.head<2>() += off_v;
  c.yaw_hold_rad = std::remainder(yaw0_rad_ + L.search_yaw_rate_degps * M_PI / 180.0 * t_exp_s, 2 * M_PI);
  sp->yaw_rad = c.yaw_hold_rad;
  climb(c, t_exp_s, L.search_climb_rate_mps, sp);
}

// The first search with the platform's broadcast position and no fix of the target: fly to
// the position at least telemetry_search_height_m above the surface with the heading held, by
// the follow point of observe (the broadcast's velocity fed forward, the gap closed at
// observe_follow_max_speed_mps relative to it with observe_follow_max_accel_mps2: no setpoint
// jump, a few degrees of tilt). The broadcast's error (the two receivers' GNSS errors,
// metres) is about the view's half-width, so the target usually appears on arrival.
// search_expand_after_s after the vehicle first came within telemetry_arrive_radius_m of it,
// the expanding pattern around the moving position.
Setpoint SearchMode::at_broadcast(LandingContext& c, const Tick& k, const Eigen::Vector2d& p,
                                  const Eigen::Vector2d& v) {
  const LandingParams& L = c.p.landing;
  const double t_s = k.t_s;
  ++c.telemetry_search_steps;
  if (!broadcast_following_) {
    follow_.start(k.nav, v, L);
    broadcast_following_ = true;
  }
  follow_.slew(p, v, k.dt_s, L);
  // The search height for a broadcast's error (never lower than the search began at).
  c.hold_p.z() = std::max(c.hold_p.z(), c.z_above_surface(k.nav, L.telemetry_search_height_m));
  if (std::isnan(broadcast_arrived_t_s_) && (k.nav.p_W_m.head<2>() - p).norm() <= L.telemetry_arrive_radius_m) {
    broadcast_arrived_t_s_ = t_s;
  }
  Setpoint sp = c.hold(c.hold_p);
  sp.p_W_m.head<2>() = follow_.position();
  sp.v_W_mps.head<2>() = v + follow_.catch_up_velocity();
  // Where a sweep in place begins should the broadcast stop (see the sweep).
  c.hold_p.head<2>() = p;
  t0_s_ = t_s;
  c.diag.search_centre_W_m = Eigen::Vector3d(p.x(), p.y(), c.platform_z());
  if (std::isnan(broadcast_arrived_t_s_)) return sp;
  const double t_exp = t_s - broadcast_arrived_t_s_ - L.search_expand_after_s;
  if (t_exp > 0.0) expand(c, t_exp, &sp);
  return sp;
}

// The search's climb: from hold_p's height at rate_mps, t_climb_s after it began, to at most
// search_max_height_m above the platform top (never below the height the search started at).
void SearchMode::climb(const LandingContext& c, double t_climb_s, double rate_mps, Setpoint* sp) const {
  const LandingParams& L = c.p.landing;
  const double z_top = c.hold_p.z() + rate_mps * t_climb_s;
  const double z_max = std::max(c.hold_p.z(), c.platform_z() + L.search_max_height_m);
  sp->p_W_m.z() = std::min(z_top, z_max);
  if (sp->p_W_m.z() < z_max && rate_mps > 0) sp->v_W_mps.z() = rate_mps;
}

}  // namespace lander::ctl::modes
