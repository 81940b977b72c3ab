// Mode machine of seed 000 section 3 with search / re-acquisition / go-around (see header).
#include "lander/controller/landing_controller.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>

namespace lander::ctl {
namespace {

double yaw_of(const Eigen::Quaterniond& q_WB) {
  const Eigen::Vector3d x = q_WB * Eigen::Vector3d::UnitX();
  return std::atan2(x.y(), x.x());
}

double horizontal(const Eigen::Vector3d& v) { return v.head<2>().norm(); }

std::string ordinal(int n) {
  switch (n) {
    case 1: return "first";
    case 2: return "second";
    case 3: return "third";
    default: return fmt::format("{}th", n);
  }
}

// How far the lowest skid end lies below the level gear (<= 0, m), for a vehicle tilted
// relative to the platform: n_B is the platform's normal in body axes. The skid ends
// c = (+-Lx, +-Ly, -gear_h) lie n_B . c from the CoM along the normal, the lowest at
// -Lx |n_x| - Ly |n_y| - gear_h n_z; a level vehicle's at -gear_h. At 3.7 deg of pitch a
// 0.21 m skid end is 1.4 cm below the level gear: the skids meet the top while the
// clearance of the CoM minus gear_h still reads 1.3 cm (envelope default-0011 sat on the top
// like that for 0.8 s with 3.5 cm of error, never cut, and was dragged off by the braking cart).
double skid_drop_m(const Eigen::Vector3d& n_B, const LandingParams& L) {
  return L.gear_height_m * (1.0 - std::abs(n_B.z())) - L.skid_half_length_m * std::abs(n_B.x()) -
         L.skid_half_spread_m * std::abs(n_B.y());
}

// Band around the go-around altitude that counts as reached (m): the position loop settles
// within a few centimetres; 0.3 m avoids waiting for the last exponential tail.
constexpr double kGoAroundReachedBand_m = 0.3;
// Below this horizontal distance the bearing to the platform is dominated by vision noise and
// the platform is near the image centre anyway: the heading is no longer aligned (m).
constexpr double kAlignMinDistance_m = 1.5;
// Fixes before the platform velocity is fed forward in observe: the velocity filter starts
// at zero with 1 m/s of uncertainty, and 6 fixes (0.2 s at 30 Hz) keep its first noisy
// updates out of the follow. A 1 m/s cart acquired at the edge of the view leaves it within
// ~1 s unless the follow starts at once, so this must stay small.
constexpr int kMinFixesForFeedForward = 6;
// In recovery the clearance setpoint stays at most this far below the current clearance (m):
// bounds the descent speed near the top after a pause of the descent (1.5 1/s * 0.5 m).
constexpr double kMaxClearanceStepDown_m = 0.5;
// Gain of the observe catch-up velocity on the remaining gap near the platform (1/s): below
// the position loop's 1.3 1/s so the follow point does not chase vision noise.
constexpr double kFollowGain_per_s = 1.0;
// Time constant of the low-pass on the platform's vertical velocity fed forward in recovery
// (s): longer than the velocity filter's noise (tenths of a second), shorter than the drift
// of the navigation's vertical velocity error (seconds).
constexpr double kPlatformVzFilter_s = 0.5;

// Delay of the first search's climb (search_first_climb_rate_mps): a target in view at the
// start is acquired in ~0.15 s (reacquire_frames = 3 keyframes at 30 Hz after the 50 ms
// vision latency); 0.3 s leaves such starts as they were and costs a cart driving off
// little (Search.FirstClimbFindsACartDrivingAwayFromALowStart: acquired at 1.87 s against
// 1.84 s with no delay, 5.8 s with a 1 s delay).
constexpr double kFirstClimbDelay_s = 0.3;

}  // namespace

double accel_feed_forward_share(double a_mps2, double deadband_mps2, double full_mps2) {
  if (!(a_mps2 > deadband_mps2)) return 0.0;
  if (a_mps2 >= full_mps2) return 1.0;
  return (a_mps2 - deadband_mps2) / (full_mps2 - deadband_mps2);
}

const char* to_string(Mode m) {
  switch (m) {
    case Mode::kSearch: return "search";
    case Mode::kObserve: return "observe";
    case Mode::kApproach: return "approach";
    case Mode::kRecovery: return "recovery";
    case Mode::kTouchdown: return "touchdown";
    case Mode::kLanded: return "landed";
    case Mode::kGoAround: return "go_around";
    case Mode::kFollowPath: return "follow_path";
    case Mode::kAborted: return "aborted";
  }
  return "unknown";
}

LandingController::LandingController(const ControllerParams& params, const CameraMount& mount)
    : p_(params), mount_(mount), cascade_(params.vehicle, params.cascade), tracker_(params.tracker, mount) {
  p_.validate();
  mount.validate();
  decisions_.wide_gate_m = p_.landing.wide_gate_m();
}

void LandingController::on_vision(const PlatformObservation& obs) {
  if (!plausible_observation(obs)) {
    ++rejected_inputs_;
    return;
  }
  pending_.push_back(obs);
}

void LandingController::on_path(const PathPoints& pts) {
  bool finite = std::isfinite(pts.t_s) && std::isfinite(pts.fx) && std::isfinite(pts.fy) &&
                std::isfinite(pts.cx) && std::isfinite(pts.cy) && pts.fx > 0 && pts.fy > 0;
  for (const Eigen::Vector2d& p : pts.points_px) finite = finite && p.allFinite();
  if (!finite) {
    ++rejected_inputs_;
    return;
  }
  if (have_path_ && pts.t_s < path_.t_s) return;  // out of order: keep the newer
  path_ = pts;
  have_path_ = true;
  const int n = static_cast<int>(pts.points_px.size());
  path_streak_ = n >= p_.path.enter_min_points ? path_streak_ + 1 : 0;
  if (n > 0) last_path_t_ = pts.t_s;
}

void LandingController::on_platform_telemetry(const GpsSample& g) {
  if (!g.valid) return;  // the platform's receiver had no fix
  if (!std::isfinite(g.t_s) || !g.p_W_m.allFinite() || !g.v_W_mps.allFinite()) {
    ++rejected_inputs_;
    return;
  }
  if (broadcast_ && g.t_s <= broadcast_->t_s) return;  // out of order: keep the newer
  broadcast_ = g;
  ++telemetry_received_;
}

void LandingController::on_altitude(const AltitudeEstimate& alt) {
  if (!std::isfinite(alt.z_W_m) || !std::isfinite(alt.vz_W_mps) ||
      !std::isfinite(alt.h_surface_m)) {
    ++rejected_inputs_;
    return;
  }
  if (alt.valid) altitude_ = alt;
}

bool LandingController::in_view(double t_s, double timeout_s) const {
  return t_s - tracker_.last_detection_t() <= timeout_s;
}

double LandingController::platform_z() const {
  return tracker_.has_fix() ? tracker_.latest().p_W_m.z() : last_platform_z_;
}

bool LandingController::predict_platform(double t_s, Eigen::Vector2d* p, Eigen::Vector2d* v) {
  const LandingParams& L = p_.landing;
  if (!tracker_.has_fix()) return false;
  if (t_s - tracker_.latest().t_s > L.search_predict_max_s) {
    // Too old to predict from: forget it (a re-acquisition starts a fresh history).
    tracker_.clear();
    return false;
  }
  const PlatformMotion m = tracker_.motion();
  *p = m.position_at(t_s).head<2>();
  *v = m.velocity_at(t_s).head<2>();
  return true;
}

void LandingController::spiral_offset(double t_spiral_s, Eigen::Vector2d* off,
                                      Eigen::Vector2d* v) const {
  const LandingParams& L = p_.landing;
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

void LandingController::start_follow_point(const NavState& nav, const Eigen::Vector2d& v_plat) {
  const LandingParams& L = p_.landing;
  follow_p_ = nav.p_W_m;
  follow_catch_v_ = nav.v_W_mps.head<2>() - v_plat;
  // ... bounded by the catch-up speed (a fast entry is braked by the follow, not carried on).
  if (follow_catch_v_.norm() > L.observe_follow_max_speed_mps) {
    follow_catch_v_ *= L.observe_follow_max_speed_mps / follow_catch_v_.norm();
  }
}

void LandingController::slew_follow_point(const Eigen::Vector2d& target, const Eigen::Vector2d& v_plat,
                                          double dt) {
  const LandingParams& L = p_.landing;
  const Eigen::Vector2d gap = target - follow_p_.head<2>();
  const double g = gap.norm();
  Eigen::Vector2d catch_want = Eigen::Vector2d::Zero();
  if (g > 1e-9) {
    const double speed = std::min({L.observe_follow_max_speed_mps, kFollowGain_per_s * g,
                                   std::sqrt(2.0 * L.observe_follow_max_accel_mps2 * g)});
    catch_want = gap * (speed / g);
  }
  Eigen::Vector2d dv = catch_want - follow_catch_v_;
  const double max_dv = L.observe_follow_max_accel_mps2 * dt;
  if (dv.norm() > max_dv) dv *= max_dv / dv.norm();
  follow_catch_v_ += dv;
  follow_p_.head<2>() += (v_plat + follow_catch_v_) * dt;
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
// Once the tracker's history is too old to predict from, the platform's broadcast position
// (when one is received) carries the centre instead of leaving it where the prediction led.
Setpoint LandingController::search_after_loss(double t_s) {
  const LandingParams& L = p_.landing;
  Eigen::Vector2d centre_v = Eigen::Vector2d::Zero();
  Eigen::Vector2d pred;
  if (predict_platform(t_s, &pred, &centre_v)) {
    search_centre_ = pred;
  } else if (broadcast_platform(t_s, &pred, &centre_v)) {
    search_centre_ = pred;
    ++telemetry_search_steps_;
  }
  diag_.search_centre_W_m = Eigen::Vector3d(search_centre_.x(), search_centre_.y(), platform_z());
  Setpoint sp = hold(hold_p_);
  sp.p_W_m.head<2>() = search_centre_;
  sp.v_W_mps.head<2>() = centre_v;
  const double t_expand0 = std::max(search_t0_, search_t_seen_ + L.search_expand_after_s);
  if (t_s <= t_expand0) return sp;
  expand_search(t_s - t_expand0, &sp);
  return sp;
}

void LandingController::expand_search(double t_exp_s, Setpoint* sp) {
  const LandingParams& L = p_.landing;
  Eigen::Vector2d off, off_v;
  spiral_offset(t_exp_s, &off, &off_v);
  sp->p_W_m.head<2>() += off;
  sp->v_W_mps.head<2>() += off_v;
  yaw_hold_ = std::remainder(search_yaw0_ + L.search_yaw_rate_degps * M_PI / 180.0 * t_exp_s,
                             2 * M_PI);
  sp->yaw_rad = yaw_hold_;
  climb(t_exp_s, L.search_climb_rate_mps, sp);
}

bool LandingController::broadcast_platform(double t_s, Eigen::Vector2d* p,
                                           Eigen::Vector2d* v) const {
  const double max_age = p_.landing.telemetry_max_age_s;
  if (!broadcast_ || max_age <= 0.0) return false;
  const double age = t_s - broadcast_->t_s;
  if (age < 0.0 || age > max_age) return false;
  *v = broadcast_->v_W_mps.head<2>();
  *p = broadcast_->p_W_m.head<2>() + age * *v;
  return true;
}

// The first search with the platform's broadcast position and no fix of the target: fly to
// the position at least telemetry_search_height_m above the surface with the heading held, by the follow point of observe
// (the broadcast's velocity fed forward, the gap closed at observe_follow_max_speed_mps
// relative to it with observe_follow_max_accel_mps2: no setpoint jump, a few degrees of
// tilt). The broadcast's error (the two receivers' GNSS errors, metres) is about the view's
// half-width, so the target usually appears on arrival. search_expand_after_s after the
// vehicle first came within telemetry_arrive_radius_m of it, the expanding pattern around the
// moving position.
Setpoint LandingController::search_at_broadcast(double t_s, double dt, const NavState& nav,
                                                const Eigen::Vector2d& p,
                                                const Eigen::Vector2d& v) {
  const LandingParams& L = p_.landing;
  ++telemetry_search_steps_;
  if (!broadcast_following_) {
    start_follow_point(nav, v);
    broadcast_following_ = true;
  }
  slew_follow_point(p, v, dt);
  // The search height for a broadcast's error (never lower than the search began at).
  hold_p_.z() = std::max(hold_p_.z(), z_above_surface(nav, L.telemetry_search_height_m));
  if (std::isnan(broadcast_arrived_t_) &&
      (nav.p_W_m.head<2>() - p).norm() <= L.telemetry_arrive_radius_m) {
    broadcast_arrived_t_ = t_s;
  }
  Setpoint sp = hold(hold_p_);
  sp.p_W_m.head<2>() = follow_p_.head<2>();
  sp.v_W_mps.head<2>() = v + follow_catch_v_;
  // Where a sweep in place begins should the broadcast stop (see the search case).
  hold_p_.head<2>() = p;
  search_t0_ = t_s;
  diag_.search_centre_W_m = Eigen::Vector3d(p.x(), p.y(), platform_z());
  if (std::isnan(broadcast_arrived_t_)) return sp;
  const double t_exp = t_s - broadcast_arrived_t_ - L.search_expand_after_s;
  if (t_exp > 0.0) expand_search(t_exp, &sp);
  return sp;
}

// The search's climb: from hold_p_'s height at rate_mps, t_climb_s after it began, to at
// most search_max_height_m above the platform top (never below the height the search
// started at).
void LandingController::climb(double t_climb_s, double rate_mps, Setpoint* sp) const {
  const LandingParams& L = p_.landing;
  const double z_top = hold_p_.z() + rate_mps * t_climb_s;
  const double z_max = std::max(hold_p_.z(), platform_z() + L.search_max_height_m);
  sp->p_W_m.z() = std::min(z_top, z_max);
  if (sp->p_W_m.z() < z_max && rate_mps > 0) sp->v_W_mps.z() = rate_mps;
}

void LandingController::give_up(double t_s, const std::string& why, const NavState& nav) {
  decide(t_s, "aborted", why);
  switch_to(t_s, Mode::kAborted, why, nav);
}

void LandingController::log_event(double t_s, const std::string& what,
                                  const std::string& reason) {
  decisions_.events.push_back({t_s, decisions_.attempts, what, reason});
}

void LandingController::decide(double t_s, const std::string& decision,
                               const std::string& reason) {
  decisions_.decision = decision;
  decisions_.reason = reason;
  decisions_.t_s = t_s;
  log_event(t_s, decision, reason);
}

void LandingController::end_attempt(double t_s, Mode next, const std::string& why,
                                    const NavState& nav) {
  const LandingParams& L = p_.landing;
  if (decisions_.attempts >= L.max_landing_attempts) {
    give_up(t_s,
            fmt::format("{}; {} of {} landing attempts used: abort", why, decisions_.attempts,
                        L.max_landing_attempts),
            nav);
    return;
  }
  decide(t_s, next == Mode::kGoAround ? "go_around" : "lost", why);
  switch_to(t_s, next, why, nav);
}

void LandingController::declare_loss(double t_s) {
  Reacquisition r;
  r.t_last_seen_s = tracker_.last_detection_t();
  r.t_lost_s = t_s;
  r.lost_in = mode_;
  reacquisitions_.push_back(r);
  loss_motion_ = tracker_.motion();
}

void LandingController::check_reacquired(double t_s) {
  if (reacquisitions_.empty()) return;
  Reacquisition& r = reacquisitions_.back();
  if (!std::isnan(r.t_reacquired_s)) return;
  if (tracker_.last_detection_t() <= r.t_last_seen_s) return;
  if (tracker_.keyframe_streak() < p_.landing.reacquire_frames ||
      !in_view(t_s, p_.landing.loss_timeout_s)) {
    return;
  }
  r.t_reacquired_s = t_s;
  if (!loss_motion_.valid) return;
  // The first fix after the loss against where the model of the loss put the platform then.
  for (const PlatformFix& f : tracker_.fixes()) {
    if (f.t_s <= r.t_last_seen_s) continue;
    r.prediction_error_m = horizontal(f.p_W_m - loss_motion_.position_at(f.t_s));
    break;
  }
}

double LandingController::z_above_surface(const NavState& nav, double h_m) const {
  if (!altitude_.valid) return h_m;
  const double by_fusion = nav.p_W_m.z() + (h_m - altitude_.h_surface_m);
  if (!std::isfinite(altitude_.clearance_m)) return by_fusion;
  return std::max(by_fusion, nav.p_W_m.z() + (h_m - altitude_.clearance_m));
}

double LandingController::search_min_z(const NavState& nav) const {
  return z_above_surface(nav, p_.landing.search_min_height_m);
}

// A fused height metres off (a degraded GPS taken in at the start, wandering with its error)
// once held the search 1 m over the ground while it believed 4.5 m: the floor is re-applied
// every step, and the ultrasonic's own clearance takes part in it.
void LandingController::keep_min_height(double t_s, const NavState& nav) {
  const double z_min = search_min_z(nav);
  if (hold_p_.z() >= z_min) return;
  if (!low_clearance_logged_ && std::isfinite(altitude_.clearance_m) &&
      altitude_.clearance_m < p_.landing.search_min_height_m &&
      altitude_.clearance_m < altitude_.h_surface_m) {
    low_clearance_logged_ = true;
    log_event(t_s, "low_clearance",
              fmt::format("ultrasonic clearance {:.2f} m (fused height above the surface {:.2f} m) "
                          "under search_min_height_m {:.2f} m in {}: climbing",
                          altitude_.clearance_m, altitude_.h_surface_m,
                          p_.landing.search_min_height_m, to_string(mode_)));
  }
  hold_p_.z() = z_min;
}

Setpoint LandingController::hold(const Eigen::Vector3d& p) const {
  Setpoint sp;
  sp.p_W_m = p;
  sp.yaw_rad = yaw_hold_;
  return sp;
}

void LandingController::switch_to(double t_s, Mode to, const std::string& reason,
                                  const NavState& nav) {
  transitions_.push_back({t_s, mode_, to, reason});
  const LandingParams& L = p_.landing;
  low_clearance_logged_ = false;
  // Entry actions.
  switch (to) {
    case Mode::kSearch: {
      search_t0_ = t_s;
      search_entry_t_ = t_s;
      search_yaw0_ = yaw_hold_;
      // The history is kept: search flies to its prediction of the platform (see
      // search_predict_max_s) and a re-acquisition continues it.
      hold_p_ = nav.p_W_m;  // keep_min_height raises it in the search's first step
      search_climb_z_ = -std::numeric_limits<double>::infinity();
      search_after_loss_ = tracker_.has_fix();
      search_t_seen_ = search_after_loss_ ? tracker_.latest().t_s : t_s;
      search_centre_ = nav.p_W_m.head<2>();
      broadcast_arrived_t_ = std::numeric_limits<double>::quiet_NaN();
      broadcast_following_ = false;
      break;
    }
    case Mode::kObserve:
      observe_entry_t_ = t_s;
      // Start the follow point with the vehicle's own velocity relative to the platform
      // estimate (zero without one): no jump in the velocity feed-forward.
      start_follow_point(nav, tracker_.num_fixes() >= kMinFixesForFeedForward
                                  ? Eigen::Vector2d(tracker_.velocity().head<2>())
                                  : Eigen::Vector2d::Zero());
      hold_p_ = nav.p_W_m;  // observe height: where the target was acquired
      observe_above_platform_m_ = tracker_.has_fix()
                                      ? nav.p_W_m.z() - diag_.platform_W_m.z()
                                      : std::numeric_limits<double>::quiet_NaN();
      break;
    case Mode::kApproach: {
      // seed 000 eq. 28-29: t_d from the distance at the nominal approach speed.
      const Eigen::Vector3d eps(0, 0, L.approach_epsilon_m);
      const Eigen::Vector3d goal_now = tracker_.position_now(t_s) + eps;
      const double T = std::clamp((goal_now - nav.p_W_m).norm() / L.approach_speed_mps,
                                  L.approach_min_duration_s, L.approach_max_duration_s);
      const double td = t_s + T;
      Eigen::Vector3d v0 = Eigen::Vector3d::Zero(), vd = Eigen::Vector3d::Zero();
      if (L.approach_match_velocities) {
        v0 = nav.v_W_mps;
        vd.head<2>() = tracker_.velocity().head<2>();
      }
      // The goal's height: the platform's height now (from the vision relative vector, see
      // the approach's setpoint below), not the fit's extrapolation of it.
      Eigen::Vector3d goal = tracker_.predict(td) + eps;
      goal.z() = diag_.platform_W_m.z() + eps.z();
      approach_ = CubicTrajectory(nav.p_W_m, t_s, goal, td, v0, vd);
      diag_.approach_planned = true;
      diag_.approach_t0_s = t_s;
      diag_.approach_td_s = td;
      diag_.replans = 0;
      ++decisions_.attempts;  // a landing attempt starts with the approach
      log_event(t_s, "attempt_started", reason);
      break;
    }
    case Mode::kRecovery:
      recovery_h_sp_ = diag_.gear_clearance_m;
      servo_int_.setZero();
      platform_vz_lp_ = diag_.platform_v_W_mps.z();
      final_t0_ = std::numeric_limits<double>::quiet_NaN();
      recovery_t0_ = t_s;
      wide_committed_ = false;
      wide_departures_ = 0;
      wide_left_t_ = std::numeric_limits<double>::quiet_NaN();
      break;
    case Mode::kTouchdown:
      cut_t_ = t_s;
      contact_accum_s_ = 0.0;
      if (!wide_committed_) decide(t_s, "committed_nominal", reason);
      log_event(t_s, "cut", reason);
      break;
    case Mode::kLanded:
      diag_.contact = true;
      diag_.contact_t_s = t_s;
      log_event(t_s, "landed", reason);
      break;
    case Mode::kGoAround:
      hold_p_ = nav.p_W_m;
      hold_p_.z() = std::max(nav.p_W_m.z(), platform_z() + L.go_around_height_m);
      // The history is kept: the climb follows the predicted platform horizontally so the
      // moving cart stays below (the fixes are measurements; only the plan failed).
      if (mode_ == Mode::kTouchdown) cascade_.reset();  // motors restart from idle
      break;
    case Mode::kFollowPath: {
      const PathGuidanceParams& P = p_.path;
      // The travel direction: the given one, else the cart's last seen motion, else the
      // vehicle's own; none: the first target decides (the farthest candidate).
      path_dir_known_ = true;
      if (P.direction_given) {
        path_dir_W_ = Eigen::Vector2d(std::cos(P.direction_rad), std::sin(P.direction_rad));
      } else if (tracker_.has_fix() && tracker_.velocity().head<2>().norm() > P.min_speed_mps) {
        path_dir_W_ = tracker_.velocity().head<2>().normalized();
      } else if (nav.v_W_mps.head<2>().norm() > P.min_speed_mps) {
        path_dir_W_ = nav.v_W_mps.head<2>().normalized();
      } else {
        path_dir_known_ = false;
      }
      // Constant height: follow_path_step servos it on the fused height above the ground;
      // without one the vehicle keeps the height it is at.
      path_z_ = nav.p_W_m.z();
      path_trail_.clear();
      path_dr_ = nav.p_W_m.head<2>();
      path_dr_t_ = t_s;
      last_target_t_ = t_s;
      hold_p_ = nav.p_W_m;
      break;
    }
    case Mode::kAborted: {
      // Straight up from here to the go-around height above the top, then hold.
      // (keep_min_height adds the search's minimum height in the mode's first step.)
      hold_p_ = nav.p_W_m;
      hold_p_.z() = std::max(nav.p_W_m.z(), platform_z() + L.go_around_height_m);
      if (mode_ == Mode::kTouchdown) cascade_.reset();  // motors restart from idle
      break;
    }
  }
  diag_.wide_committed = wide_committed_;
  mode_ = to;
}

void LandingController::detect_contact(double t_s, const ImuSample& imu, const NavState& nav) {
  const LandingParams& L = p_.landing;
  const double dt = std::max(0.0, t_s - last_inner_t_);
  const double since_cut = t_s - cut_t_;
  // After the rotors spun down (free fall reads ~0), a specific force near +g along z_B means
  // the vehicle rests on something.
  const double f_z = imu.accel_B_mps2.z();
  if (since_cut >= L.contact_min_time_s && f_z > L.contact_accel_frac * p_.vehicle.gravity_mps2) {
    contact_accum_s_ += dt;
  } else {
    contact_accum_s_ = 0.0;
  }
  if (contact_accum_s_ >= L.contact_confirm_s && since_cut >= L.contact_min_time_s) {
    switch_to(t_s, Mode::kLanded,
              fmt::format("contact: specific force z {:.2f} m/s^2 for {:.3f} s, {:.2f} s after the cut", f_z,
                  contact_accum_s_, since_cut),
              nav);
  } else if (since_cut > L.contact_timeout_s) {
    switch_to(t_s, Mode::kGoAround, fmt::format("no contact {:.2f} s after the motor cut", since_cut), nav);
  }
}

Setpoint LandingController::run_mode_machine(double t_s, const NavState& nav) {
  const LandingParams& L = p_.landing;
  const double dt = std::clamp(t_s - last_outer_t_, 0.0, 0.2);
  last_outer_t_ = t_s;
  diag_.num_fixes = tracker_.num_fixes();
  diag_.keyframe_streak = tracker_.keyframe_streak();
  diag_.platform_known = tracker_.has_fix();
  if (tracker_.has_fix()) {
    last_platform_z_ = tracker_.latest().p_W_m.z();
    // The platform now, from the relative vector (navigation drift cancels), in W.
    diag_.platform_W_m = nav.p_W_m + tracker_.relative_now(t_s);
    diag_.platform_v_W_mps = tracker_.velocity();
    diag_.horizontal_error_m = horizontal(diag_.platform_W_m - nav.p_W_m);
    diag_.gear_clearance_m = nav.p_W_m.z() - diag_.platform_W_m.z() - L.gear_height_m;
    // The platform's normal in body axes now: the last fix's normal (vision's relative
    // attitude, put in W with the navigation attitude of that frame) brought back with the
    // navigation attitude now, so the attitude's own error cancels but for its change since.
    const Eigen::Vector3d n_B = nav.q_WB.conjugate() * tracker_.latest().n_W;
    diag_.skid_drop_m = skid_drop_m(n_B.normalized(), L);
  }
  const double loss_age = t_s - tracker_.last_detection_t();
  check_reacquired(t_s);
  diag_.final_stage_s = 0.0;  // recovery sets it

  switch (mode_) {
    case Mode::kSearch: {
      if (tracker_.keyframe_streak() >= L.reacquire_frames && in_view(t_s, L.loss_timeout_s)) {
        switch_to(t_s, Mode::kObserve,
                  fmt::format("target acquired: {} consecutive keyframes", tracker_.keyframe_streak()),
                  nav);
        return run_mode_machine(t_s, nav);
      }
      // A painted route in view and the target not (seed 003): follow the route. Never again
      // after its end was reached (the vehicle holds there).
      if (p_.path.enabled && !route_ended_ && path_streak_ >= p_.path.enter_frames &&
          t_s - last_path_t_ < p_.path.route_lost_s) {
        switch_to(t_s, Mode::kFollowPath,
                  fmt::format("route in view: {} frames with >= {} candidate points, target not acquired",
                              path_streak_, p_.path.enter_min_points),
                  nav);
        return run_mode_machine(t_s, nav);
      }
      // Bounded search (issue 10): a target not found this long after entering search ends
      // the landing with the reason, instead of a search until the battery runs out.
      if (t_s - search_entry_t_ >= L.search_give_up_s) {
        give_up(t_s,
                search_after_loss_
                    ? fmt::format("target not re-acquired in {:.1f} s of search after the loss "
                                  "(last seen at {:.2f} s)",
                                  t_s - search_entry_t_, search_t_seen_)
                    : fmt::format("target not found in {:.1f} s of search", t_s - search_entry_t_),
                nav);
        return run_mode_machine(t_s, nav);
      }
      keep_min_height(t_s, nav);
      // After a loss: fly to where the motion model predicts the platform instead of holding
      // while the cart drives away, then widen the search around it.
      if (search_after_loss_) return search_after_loss(t_s);
      // Not acquired yet, but a fix already (fewer than reacquire_frames keyframes in a row):
      // fly to it, as before issue 10 (and sweep afresh once it is too old).
      const bool had_fix = tracker_.has_fix();
      Eigen::Vector2d p_pred, v_pred;
      // What the search's climb gained is kept: a first fix at the view's edge (not yet
      // acquired) would otherwise take the vehicle back down to where the search began,
      // narrowing the view while it flies to that fix (and the sweep after it would climb
      // again from there). Only with a fix: the climb itself ramps from hold_p_'s height.
      if (had_fix) hold_p_.z() = std::max(hold_p_.z(), search_climb_z_);
      if (predict_platform(t_s, &p_pred, &v_pred)) {
        hold_p_.head<2>() = p_pred;
        Setpoint sp = hold(hold_p_);
        sp.v_W_mps.head<2>() = v_pred;
        diag_.search_centre_W_m = hold_p_;
        return sp;
      }
      if (had_fix) {
        search_t0_ = t_s;
        search_yaw0_ = yaw_hold_;
      }
      // The platform's broadcast position, if one is received: fly there.
      if (broadcast_platform(t_s, &p_pred, &v_pred)) return search_at_broadcast(t_s, dt, nav, p_pred, v_pred);
      broadcast_following_ = false;
      // Nothing to predict from: heading sweep. The 1280 px image axis is along body y, so
      // turning the vehicle scans a circle of radius ~h tan(45 deg) instead of the 29 deg
      // half-angle along body x. After search_spiral_after_s, an outward spiral around hold_p_.
      yaw_hold_ = std::remainder(
          search_yaw0_ + L.search_yaw_rate_degps * M_PI / 180.0 * (t_s - search_t0_), 2 * M_PI);
      Setpoint sp = hold(hold_p_);
      Eigen::Vector2d off, off_v;
      const double t_spiral = t_s - search_t0_ - L.search_spiral_after_s;
      spiral_offset(t_spiral, &off, &off_v);
      sp.p_W_m.head<2>() += off;
      sp.v_W_mps.head<2>() = off_v;
      // With the spiral, a climb for a wider view, as after a loss (never below the height the
      // search started at): a start low over a cart driving away leaves the view before the
      // first sweep ends. With search_first_climb_rate_mps the climb starts with the sweep
      // (it is faster than the spiral's, so it stays above that climb's height throughout).
      // The first climb waits kFirstClimbDelay_s: a target in view at the start is acquired
      // well within it, and such starts fly as without the climb.
      const double t_first_climb = t_s - search_t0_ - kFirstClimbDelay_s;
      if (L.search_first_climb_rate_mps > 0.0 && t_first_climb > 0.0) {
        climb(t_first_climb, std::max(L.search_first_climb_rate_mps, L.search_climb_rate_mps), &sp);
      } else if (t_spiral > 0.0) {
        climb(t_spiral, L.search_climb_rate_mps, &sp);
      }
      search_climb_z_ = std::max(search_climb_z_, sp.p_W_m.z());
      diag_.search_centre_W_m = hold_p_;
      return sp;
    }

    case Mode::kObserve: {
      if (!in_view(t_s, L.loss_timeout_s)) {
        declare_loss(t_s);
        switch_to(t_s, Mode::kSearch, fmt::format("target lost for {:.2f} s while observing", loss_age),
                  nav);
        return run_mode_machine(t_s, nav);
      }
      const bool close = L.approach_entry_max_error_m <= 0.0 || !tracker_.has_fix() ||
                         diag_.horizontal_error_m <= L.approach_entry_max_error_m;
      const bool waited = t_s - observe_entry_t_ >= L.approach_entry_wait_s;
      if (tracker_.total_fixes() >= L.observe_frames && (close || waited)) {
        std::string why =
            fmt::format("{} keyframes observed (>= {})", tracker_.total_fixes(), L.observe_frames);
        if (!close) {
          why += fmt::format("; {:.2f} m off the platform after {:.1f} s of observing "
                             "(approach_entry_wait_s)",
                             diag_.horizontal_error_m, t_s - observe_entry_t_);
        }
        switch_to(t_s, Mode::kApproach, why, nav);
        return run_mode_machine(t_s, nav);
      }
      // Follow the platform horizontally at the observe height to keep it centred: the
      // follow point moves with the platform's velocity (fed forward) and closes the rest of
      // the gap at a bounded catch-up speed on top (no setpoint jumps). Between detections
      // position_now() carries the last fix on with that velocity.
      Setpoint sp = hold(hold_p_);
      // The height is held above the platform's height now (navigation + vision relative
      // vector), as the approach's: a step of the navigation height (a degraded GPS) cancels
      // in it, where a hold in absolute W moved the vehicle by the whole step.
      if (tracker_.has_fix() && std::isfinite(observe_above_platform_m_)) {
        sp.p_W_m.z() = diag_.platform_W_m.z() + observe_above_platform_m_;
      }
      if (tracker_.has_fix()) {
        const Eigen::Vector3d target = tracker_.position_now(t_s);
        // Velocity feed-forward only once the fit has enough fixes (far away, a few noisy
        // fixes make a velocity of metres per second out of centimetres of noise).
        Eigen::Vector2d v_plat = Eigen::Vector2d::Zero();
        if (tracker_.num_fixes() >= kMinFixesForFeedForward) {
          v_plat = tracker_.velocity().head<2>();
        }
        // Catch-up velocity relative to the platform: proportional near it, bounded by the
        // speed that can still stop within the gap at the follow acceleration, and by the
        // catch-up speed. Its changes are acceleration-limited: accelerating tilts the camera
        // (fixed under the body) away from a platform ahead, and a hard start loses it.
        slew_follow_point(target.head<2>(), v_plat, dt);
        sp.p_W_m.head<2>() = follow_p_.head<2>();
        sp.v_W_mps.head<2>() = v_plat + follow_catch_v_;
        // Turn the wide image axis (body y) towards the platform while it is off to the side,
        // so an acquisition near the image corner does not lose it again.
        const Eigen::Vector2d to_plat = target.head<2>() - nav.p_W_m.head<2>();
        if (to_plat.norm() > kAlignMinDistance_m) {
          const double bearing = std::atan2(to_plat.y(), to_plat.x());
          const double yaw_a = std::remainder(bearing - M_PI / 2, 2 * M_PI);
          const double yaw_b = std::remainder(bearing + M_PI / 2, 2 * M_PI);
          const double cur = yaw_of(nav.q_WB);
          yaw_hold_ = std::abs(std::remainder(yaw_a - cur, 2 * M_PI)) <
                              std::abs(std::remainder(yaw_b - cur, 2 * M_PI))
                          ? yaw_a
                          : yaw_b;
          sp.yaw_rad = yaw_hold_;
        }
      }
      return sp;
    }

    case Mode::kApproach: {
      if (!in_view(t_s, L.loss_timeout_s)) {
        declare_loss(t_s);
        if (diag_.gear_clearance_m < L.go_around_low_height_m) {
          end_attempt(t_s, Mode::kGoAround,
                      fmt::format("target lost for {:.2f} s during approach at {:.2f} m above the platform",
                          loss_age, diag_.gear_clearance_m),
                      nav);
        } else {
          end_attempt(t_s, Mode::kSearch,
                      fmt::format("target lost for {:.2f} s during approach", loss_age), nav);
        }
        return run_mode_machine(t_s, nav);
      }
      // Replan (seed 000 section 3.2): new fixes -> new prediction of P_d at the same t_d.
      const Eigen::Vector3d eps(0, 0, L.approach_epsilon_m);
      if (t_s < approach_.td() && tracker_.has_fix() &&
          tracker_.latest().t_s > diag_.approach_t0_s) {
        // The goal moves towards the new prediction at a bounded rate.
        Eigen::Vector3d step = tracker_.predict(approach_.td()) + eps - approach_.goal();
        step.z() = 0.0;  // the height is re-anchored on the platform every step instead
        const double max_step = L.approach_goal_max_rate_mps * dt;
        if (step.norm() > max_step) step *= max_step / step.norm();
        approach_.set_goal(approach_.goal() + step);
        ++diag_.replans;
      }
      diag_.approach_goal_W_m = approach_.goal();
      diag_.approach_diff_m = horizontal(approach_.goal() - nav.p_W_m);
      // Recovery servos on vision, so it is entered only with a fresh detection; otherwise
      // the approach holds P_d until the target is back or the loss timeout fires.
      if (t_s >= approach_.td() && in_view(t_s, L.recovery_loss_timeout_s)) {
        if (diag_.approach_diff_m < L.approach_switch_error_m) {
          switch_to(t_s, Mode::kRecovery,
                    fmt::format("|Diff| = {:.3f} m < {:.3f} m at t >= t_d", diag_.approach_diff_m,
                        L.approach_switch_error_m),
                    nav);
          return run_mode_machine(t_s, nav);
        }
        if (t_s > approach_.td() + L.approach_settle_timeout_s) {
          switch_to(t_s, Mode::kRecovery,
                    fmt::format("|Diff| = {:.3f} m still above {:.3f} m {:.1f} s after t_d; target in view",
                        diag_.approach_diff_m, L.approach_switch_error_m,
                        L.approach_settle_timeout_s),
                    nav);
          return run_mode_machine(t_s, nav);
        }
      }
      // The height as the plan's height above its goal, on top of the platform's height now
      // (nav.p + the vision relative vector): a step of the navigation height (a GPS with
      // metres of vertical error) moves the platform's estimate with it and cancels, as in
      // recovery's clearance servo. Planned in absolute W, a 5 m step of the navigation
      // height during an approach (unseen campaign seed 73129, default-0005) put the goal
      // 5 m below the platform and the vehicle met the top at 1.5 m/s.
      Setpoint sp = approach_.setpoint(t_s, yaw_hold_);
      sp.p_W_m.z() = diag_.platform_W_m.z() + eps.z() + (sp.p_W_m.z() - approach_.goal().z());
      return sp;
    }

    case Mode::kRecovery: {
      if (!in_view(t_s, L.recovery_loss_timeout_s)) {
        declare_loss(t_s);
        end_attempt(t_s, Mode::kGoAround,
                    fmt::format("target lost for {:.2f} s in recovery at {:.2f} m above the platform",
                        loss_age, diag_.gear_clearance_m),
                    nav);
        return run_mode_machine(t_s, nav);
      }
      const double e_xy = diag_.horizontal_error_m;
      const double h = diag_.gear_clearance_m;
      // A large error matters close to the cart (the gear could catch its edge); higher up
      // the servo holds height and catches up.
      if (e_xy > L.go_around_error_m && h < L.near_height_m) {
        end_attempt(t_s, Mode::kGoAround,
                    fmt::format("horizontal error {:.2f} m > {:.2f} m in recovery", e_xy, L.go_around_error_m),
                    nav);
        return run_mode_machine(t_s, nav);
      }
      // Horizontal speed relative to the platform, straight from vision (the rate of the
      // relative vector); infinite while there are too few fixes for it.
      Eigen::Vector3d v_rel_vision;
      const double rel_speed = tracker_.relative_velocity(&v_rel_vision)
                                   ? horizontal(v_rel_vision)
                                   : std::numeric_limits<double>::infinity();
      const bool fresh = in_view(t_s, L.descent_stale_s);
      // Bounded decision (issue 10). The timer starts the first time below the final hold
      // height in this recovery. final_decision_after_s later, if the nominal gate has still
      // not led to a cut, the gate widens over final_decision_window_s, linearly from the
      // nominal (final_descent_error_m, final_descent_rel_speed_mps) to the wide one
      // (wide_gate_m(), max_touchdown_rel_speed_mps):
      //   f = (waited - final_decision_after_s) / final_decision_window_s in [0, 1],
      //   gate = nominal + f (wide - nominal),
      // so the commit comes at the first moment the disturbance lets the error below it (the
      // smallest error it offers, not the first within the wide gate). Within it the vehicle
      // commits and descends into contact; not within it by the end of the window: go-around
      // (or abort).
      const double wide_gate = L.wide_gate_m();
      if (std::isnan(final_t0_) && h < L.final_hold_height_m) {
        final_t0_ = t_s;
        log_event(t_s, "final_stage",
                  fmt::format("below the final hold height {:.2f} m: decision in {:.1f} s",
                              L.final_hold_height_m, L.final_decision_after_s));
      } else if (std::isnan(final_t0_) && t_s - recovery_t0_ >= L.recovery_decision_after_s) {
        // The descent gates not met for this long (gusts): the bounded decision starts here,
        // higher up, as if the final stage had begun.
        final_t0_ = t_s;
        log_event(t_s, "final_stage",
                  fmt::format("{:.1f} s in recovery without going below the final hold height "
                              "{:.2f} m (clearance {:.2f} m, error {:.3f} m): decision in {:.1f} s",
                              t_s - recovery_t0_, L.final_hold_height_m, h, e_xy,
                              L.final_decision_after_s));
      }
      const double waited = std::isnan(final_t0_) ? 0.0 : t_s - final_t0_;
      diag_.final_stage_s = waited;
      if (!std::isnan(final_t0_) && !wide_committed_ && waited >= L.final_decision_after_s) {
        const double f =
            L.final_decision_window_s > 0.0
                ? std::min(1.0, (waited - L.final_decision_after_s) / L.final_decision_window_s)
                : 1.0;
        const double gate_now =
            L.final_descent_error_m + f * (wide_gate - L.final_descent_error_m);
        const double rel_now =
            L.final_descent_rel_speed_mps +
            f * (L.max_touchdown_rel_speed_mps - L.final_descent_rel_speed_mps);
        if (fresh && e_xy < gate_now && rel_speed < rel_now) {
          wide_committed_ = true;
          diag_.wide_committed = true;
          decide(t_s, "committed_wide",
                 fmt::format("nominal gate ({:.3f} m, {:.2f} m/s) not met {:.1f} s into the final "
                             "stage; error {:.3f} m < {:.3f} m, relative speed {:.2f} m/s < {:.2f} m/s "
                             "(gate widening to {:.3f} m, {:.2f} m/s)",
                             L.final_descent_error_m, L.final_descent_rel_speed_mps, waited,
                             e_xy, gate_now, rel_speed, rel_now, wide_gate,
                             L.max_touchdown_rel_speed_mps));
        } else if (waited >= L.final_decision_after_s + L.final_decision_window_s) {
          end_attempt(t_s, Mode::kGoAround,
                      fmt::format("final gate not met in {:.1f} s of the final stage and not the wide "
                                  "gate ({:.3f} m, {:.2f} m/s) in {:.1f} s more: error {:.3f} m, relative "
                                  "speed {:.2f} m/s",
                                  L.final_decision_after_s, wide_gate,
                                  L.max_touchdown_rel_speed_mps, L.final_decision_window_s, e_xy,
                                  rel_speed),
                      nav);
          return run_mode_machine(t_s, nav);
        }
      }
      // Committed wide: leaving the wide gate (the safe one) is a balked descent, not yet a
      // go-around: the vehicle climbs back to the final hold height and descends again once
      // within the gate (a stop-and-go cart that sets off under a committed vehicle is
      // matched again within a second or two, where a go-around costs a new approach: envelope
      // default-0107 left the gate by 6 mm and was still in its second approach at 60 s). The
      // (max_wide_departures + 1)-th departure, or final_decision_window_s outside, ends the
      // attempt.
      if (wide_committed_ && e_xy > wide_gate) {
        if (std::isnan(wide_left_t_)) {
          ++wide_departures_;
          if (wide_departures_ > L.max_wide_departures) {
            end_attempt(t_s, Mode::kGoAround,
                        fmt::format("committed within the wide gate, but the error {:.3f} m left it "
                                    "({:.3f} m) for the {} time",
                                    e_xy, wide_gate, ordinal(wide_departures_)),
                        nav);
            return run_mode_machine(t_s, nav);
          }
          wide_left_t_ = t_s;
          log_event(t_s, "wide_gate_left",
                    fmt::format("error {:.3f} m left the wide gate ({:.3f} m) at clearance {:.2f} m: "
                                "back to the final hold height {:.2f} m until within it again",
                                e_xy, wide_gate, h, L.final_hold_height_m));
        } else if (t_s - wide_left_t_ > L.final_decision_window_s) {
          end_attempt(t_s, Mode::kGoAround,
                      fmt::format("committed within the wide gate; the error left it and was not back "
                                  "within {:.3f} m in {:.1f} s (now {:.3f} m)",
                                  wide_gate, L.final_decision_window_s, e_xy),
                      nav);
          return run_mode_machine(t_s, nav);
        }
        recovery_h_sp_ = std::max(recovery_h_sp_, L.final_hold_height_m);
      } else if (wide_committed_) {
        wide_left_t_ = std::numeric_limits<double>::quiet_NaN();
      }
      const double cut_gate = wide_committed_ ? wide_gate : L.touchdown_error_m;
      // Touchdown test (seed 000 section 3.3): small horizontal error, steady platform, plus
      // low and slow relative to the platform.
      const Eigen::Vector3d v_rel = nav.v_W_mps - diag_.platform_v_W_mps;
      std::string unsteady;
      // The fused altitude (ultrasonic, vision, baro; seed 004) must agree that the skids are
      // at the top: once vision's clearance read 0.7 cm with the truth 3.4 cm (blurred frames
      // near the top) and the cut dropped the vehicle at 0.72 m/s. Should the fused estimate
      // read high, the descent simply goes on into contact at the final rate.
      const double h_fused = altitude_.valid ? altitude_.h_surface_m - L.gear_height_m : h;
      // Low enough for the cut: the level gear within cut_height_m of the top (the fall the
      // cut was made for), or the lowest skid end (skid_drop_m) already at the top, within
      // kSkidTouch_m, by both clearances: a tilted vehicle stands on a skid end before its
      // level gear gets there.
      const double h_low = h + diag_.skid_drop_m, h_fused_low = h_fused + diag_.skid_drop_m;
      const bool level_gear_low = h < L.cut_height_m && h_fused < L.cut_height_m;
      const bool skid_end_down =
          h_low < LandingParams::kSkidTouch_m && h_fused_low < LandingParams::kSkidTouch_m;
      if (fresh && (level_gear_low || skid_end_down) &&
          e_xy < cut_gate && v_rel.norm() < L.max_touchdown_rel_speed_mps &&
          tracker_.steady(L.steady_window_s, L.steady_tilt_deg, L.max_platform_tilt_deg,
                          &unsteady)) {
        switch_to(t_s, Mode::kTouchdown,
                  fmt::format("cut: horizontal error {:.3f} m, clearance {:.3f} m (fused {:.3f} m), lowest "
                      "skid end {:.3f} m (fused {:.3f} m), relative speed {:.2f} m/s, platform steady",
                      e_xy, h, h_fused, h_low, h_fused_low, v_rel.norm()),
                  nav);
        return hold(nav.p_W_m);
      }
      // Visual servo: horizontal setpoint on the platform now, its velocity fed forward;
      // descend at the controlled rate only while the horizontal error is small.
      const bool near = h < L.near_height_m;
      const double gate = wide_committed_ ? wide_gate
                          : near          ? L.descent_gate_near_m
                                          : L.descent_gate_m;
      // Below the final hold height the slowest rate: the cut happens from it (soft contact).
      const double rate = h < L.final_hold_height_m ? L.descent_rate_final_mps
                          : near                    ? L.descent_rate_near_mps
                                                    : L.descent_rate_mps;
      // Final decimetres: below final_hold_height_m go on into contact only while within
      // final_descent_error_m and moving with the platform (the skids may meet the top
      // before the cut, and the error at first contact is the landing's); otherwise wait low (final_wait_gap_m), so the dash
      // into contact once aligned is short (a stop-and-go cart is steady for ~2 s); climb
      // back to final_hold_height_m when the error exceeds twice the touchdown criterion.
      // Committed wide: the wide gate and the cut's relative speed instead.
      const bool aligned =
          wide_committed_
              ? e_xy < wide_gate && rel_speed < L.max_touchdown_rel_speed_mps
              : e_xy < L.final_descent_error_m && rel_speed < L.final_descent_rel_speed_mps;
      // The height is servoed like the horizontal position: on the gear clearance measured by
      // vision (h_sp - h), so steps of the navigation height (baro / GPS) cancel.
      const double h_floor = (aligned || h > L.final_hold_height_m) ? L.final_hover_gap_m
                                                                   : L.final_wait_gap_m;
      if (!wide_committed_ && e_xy > 2.0 * L.touchdown_error_m) {
        recovery_h_sp_ = std::max(recovery_h_sp_, L.final_hold_height_m);
      }
      double vz_ff = 0.0;
      if (fresh && e_xy < gate && recovery_h_sp_ > h_floor) {
        recovery_h_sp_ -= rate * dt;
        vz_ff = -rate;
      }
      if (recovery_h_sp_ <= h_floor) {
        recovery_h_sp_ = h_floor;
        vz_ff = 0.0;
      }
      // Never command the setpoint far below the vehicle (limits the descent speed near the
      // top even after a pause of the descent).
      recovery_h_sp_ = std::max(recovery_h_sp_, h - kMaxClearanceStepDown_m);
      // Visual-servo integral: the horizontal error between the platform and the vehicle
      // is integrated (only once roughly aligned, so the entry transient does not wind it up)
      // and added to the setpoint; it removes the bias of the lagging velocity feed-forward
      // on curved or accelerating cart paths.
      // It learns only while the platform is not accelerating: a cart's start or stop is a
      // transient the acceleration feed-forward below meets, not a bias.
      const Eigen::Vector2d e_vec = diag_.platform_W_m.head<2>() - nav.p_W_m.head<2>();
      const Eigen::Vector2d a_plat = tracker_.acceleration().head<2>();
      if (e_xy < L.descent_gate_m && a_plat.norm() < L.servo_int_max_platform_accel_mps2) {
        servo_int_ += L.servo_ki * e_vec * dt;
        const double n = servo_int_.norm();
        if (n > L.servo_max_correction_m) servo_int_ *= L.servo_max_correction_m / n;
      }
      Setpoint sp = hold(diag_.platform_W_m);
      sp.p_W_m.head<2>() += servo_int_;
      // Carrot: the horizontal setpoint stays within recovery_max_carrot_m of the vehicle, so
      // a large error is closed at a bounded relative speed on top of the platform velocity.
      Eigen::Vector2d carrot = sp.p_W_m.head<2>() - nav.p_W_m.head<2>();
      if (carrot.norm() > L.recovery_max_carrot_m) carrot *= L.recovery_max_carrot_m / carrot.norm();
      sp.p_W_m.head<2>() = nav.p_W_m.head<2>() + carrot;
      sp.p_W_m.z() = nav.p_W_m.z() + (recovery_h_sp_ - h);
      // The platform velocity is fed forward on all three axes: it is estimated against the
      // dead-reckoned vehicle, so it carries the navigation velocity's error, which then
      // cancels in the velocity loop (a baro/GPS-corrected vertical velocity 0.1 m/s slow made
      // the last 30 cm of descent twice the commanded rate without the vertical term). The
      // vertical part is low-passed: a cart's top does not move vertically, what is left is
      // that slowly changing navigation error, and the filter's noise would reach the thrust.
      platform_vz_lp_ += (diag_.platform_v_W_mps.z() - platform_vz_lp_) *
                         std::min(1.0, dt / kPlatformVzFilter_s);
      sp.v_W_mps = Eigen::Vector3d(diag_.platform_v_W_mps.x(), diag_.platform_v_W_mps.y(),
                                   platform_vz_lp_ + vz_ff);
      // The platform's horizontal acceleration fed forward (platform_accel_ff_gain, on by
      // default): a stop-and-go cart's 0.6 m/s^2 is otherwise met only by the velocity loop,
      // ~0.35 s behind the cart: 10-20 cm of error at every start and stop. Nothing of it below
      // platform_accel_ff_deadband_mps2, because the raw acceleration of the fit is noisy (fed
      // forward whole at a constant cart speed it landed about 1 cm wider), all of it from
      // platform_accel_ff_full_mps2 on, a share rising linearly between; the direction kept.
      if (L.platform_accel_ff_gain > 0.0 && fresh) {
        const double share = accel_feed_forward_share(
            a_plat.norm(), L.platform_accel_ff_deadband_mps2, L.platform_accel_ff_full_mps2);
        sp.a_W_mps2.head<2>() = L.platform_accel_ff_gain * share * a_plat;
      }
      return sp;
    }

    case Mode::kTouchdown:
    case Mode::kLanded:
      return hold(nav.p_W_m);

    case Mode::kAborted:
      keep_min_height(t_s, nav);
      return hold(hold_p_);

    case Mode::kFollowPath: {
      if (tracker_.keyframe_streak() >= L.reacquire_frames && in_view(t_s, L.loss_timeout_s)) {
        switch_to(t_s, Mode::kObserve,
                  fmt::format("target acquired while following the route: {} consecutive keyframes",
                              tracker_.keyframe_streak()),
                  nav);
        return run_mode_machine(t_s, nav);
      }
      if (route_ended_) return hold(hold_p_);  // the end of the route: hold and report
      if (t_s - last_path_t_ > p_.path.route_lost_s) {
        switch_to(t_s, Mode::kSearch,
                  fmt::format("route lost: no candidate point for {:.2f} s", t_s - last_path_t_), nav);
        return run_mode_machine(t_s, nav);
      }
      return follow_path_step(t_s, nav);
    }

    case Mode::kGoAround: {
      keep_min_height(t_s, nav);
      if (std::abs(nav.p_W_m.z() - hold_p_.z()) < kGoAroundReachedBand_m) {
        if (tracker_.keyframe_streak() >= L.reacquire_frames && in_view(t_s, L.loss_timeout_s)) {
          switch_to(t_s, Mode::kObserve, "go-around altitude reached, target in view", nav);
        } else {
          // Out of view after a go-around for another cause: a loss too (recorded once).
          if (reacquisitions_.empty() || !std::isnan(reacquisitions_.back().t_reacquired_s)) {
            declare_loss(t_s);
          }
          switch_to(t_s, Mode::kSearch, "go-around altitude reached, target not in view", nav);
        }
        return run_mode_machine(t_s, nav);
      }
      // Keep the moving cart below while climbing.
      Setpoint sp = hold(hold_p_);
      Eigen::Vector2d p, v;
      if (predict_platform(t_s, &p, &v)) {
        hold_p_.head<2>() = p;
        sp.p_W_m.head<2>() = p;
        sp.v_W_mps.head<2>() = v;
      }
      return sp;
    }
  }
  return hold(nav.p_W_m);
}

// follow_path without a target point this step (either guidance): hold where the last one
// was, at the follow height; none for end_after_s is the route's end, held for good and
// reported.
Setpoint LandingController::no_path_target(double t_s, const Eigen::Vector2d& here) {
  const double waited = t_s - last_target_t_;
  if (waited > p_.path.end_after_s) {
    route_ended_ = true;
    route_end_t_ = t_s;
    hold_p_ = Eigen::Vector3d(here.x(), here.y(), path_z_);
    log_event(t_s, "route_end",
              fmt::format("no route candidate ahead for {:.1f} s ({} guidance): the end of the route; "
                          "holding at ({:.2f}, {:.2f})",
                          waited, p_.path.guidance, here.x(), here.y()));
  }
  return hold(Eigen::Vector3d(hold_p_.x(), hold_p_.y(), path_z_));
}

// One outer step of follow_path (seed 003 eq. 10-17, see path_guidance.h).
Setpoint LandingController::follow_path_step(double t_s, const NavState& nav) {
  const PathGuidanceParams& P = p_.path;
  ++path_steps_;
  const Eigen::Vector2d here = nav.p_W_m.head<2>();
  // The flown trail, a point every kTrailSpacing_m (the last kTrailMaxPoints: 100 m), in a
  // dead-reckoned frame (the integral of the navigation velocity): the navigation position
  // jumps with GPS corrections (0.4 m within 2 s in wind), which made points just flown over
  // look new; the integral drifts only slowly.
  constexpr double kTrailSpacing_m = 0.1;
  constexpr std::size_t kTrailMaxPoints = 1000;
  const double dt_dr = std::clamp(t_s - path_dr_t_, 0.0, 0.2);
  path_dr_t_ = t_s;
  path_dr_ += nav.v_W_mps.head<2>() * dt_dr;
  if (path_trail_.empty() || (path_dr_ - path_trail_.back()).norm() >= kTrailSpacing_m) {
    path_trail_.push_back(path_dr_);
    if (path_trail_.size() > kTrailMaxPoints) path_trail_.erase(path_trail_.begin());
  }
  // Constant height above the ground: servoed on the fused height above the surface (the
  // navigation's height drifts with the barometer's bias until GPS and vision settle it).
  if (altitude_.valid) path_z_ = nav.p_W_m.z() + (P.height_m - altitude_.h_surface_m);
  GroundView g;
  g.R_WB = nav.q_WB.toRotationMatrix();
  const Eigen::Isometry3d X_BC = mount_.X_BC();
  g.R_BC = X_BC.linear();
  g.t_BC_m = X_BC.translation();
  g.h_B_m = altitude_.valid ? altitude_.h_surface_m : P.height_m;
  g.fx = path_.fx;
  g.fy = path_.fy;
  g.cx = path_.cx;
  g.cy = path_.cy;
  const bool const_k = P.projection == "constant_k";
  // U: the paper's image centre with the constant scale; the image of the point below the
  // vehicle with the exact projection.
  const Eigen::Vector2d below = vehicle_image_point(g);
  const Eigen::Vector2d U = const_k ? Eigen::Vector2d(g.cx, g.cy) : below;
  // v: the velocity's image projection; the kept direction while slow or turning hard.
  Eigen::Vector2d dir = path_dir_W_;
  const Eigen::Vector2d v_W = nav.v_W_mps.head<2>();
  if (v_W.norm() > P.min_speed_mps && (!path_dir_known_ || v_W.normalized().dot(path_dir_W_) > 0.5)) {
    dir = v_W.normalized();
  }
  Eigen::Vector2d v_img = Eigen::Vector2d::Zero();
  if (const auto a = ground_to_image(g, dir)) v_img = *a - below;
  auto to_ground = [&](const Eigen::Vector2d& p_px) -> std::optional<Eigen::Vector2d> {
    if (const_k) return image_to_ground_k(g, p_px, U, P.k_m_per_px);
    return image_to_ground_ray(g, p_px);
  };

  // Candidates on the flown trail (all but its last trail_skip_m) are behind: set aside.
  std::vector<Eigen::Vector2d> ground(path_.points_px.size(), Eigen::Vector2d::Zero());
  std::vector<bool> excluded(path_.points_px.size(), false);
  const int skip = static_cast<int>(std::ceil(P.trail_skip_m / kTrailSpacing_m));
  const int trail_n = static_cast<int>(path_trail_.size()) - skip;
  for (std::size_t i = 0; i < path_.points_px.size(); ++i) {
    const auto off = to_ground(path_.points_px[i]);
    if (!off) {
      excluded[i] = true;
      continue;
    }
    ground[i] = here + *off;
    const Eigen::Vector2d g_dr = path_dr_ + *off;  // the same point in the trail's frame
    for (int k = 0; k < trail_n && !excluded[i]; ++k) {
      excluded[i] = (path_trail_[k] - g_dr).norm() < P.trail_radius_m;
    }
  }
  if (P.guidance == "pixel_distribution") {
    // The baseline sees the same candidates, with the flown trail set aside (its dead end).
    std::vector<Eigen::Vector2d> fresh;
    for (std::size_t i = 0; i < path_.points_px.size(); ++i) {
      if (!excluded[i]) fresh.push_back(path_.points_px[i]);
    }
    return pixel_distribution_step(t_s, nav, g, U, v_img, fresh);
  }
  std::optional<std::size_t> pick;
  if (!path_dir_known_) {
    // No direction yet: the farthest candidate in the annulus decides it.
    double best_r = -1;
    for (std::size_t i = 0; i < path_.points_px.size(); ++i) {
      const double r = (path_.points_px[i] - U).norm();
      if (!excluded[i] && r > P.r1_px && r < P.r2_px && r > best_r) {
        best_r = r;
        pick = i;
      }
    }
  } else if (v_img.norm() > 1e-6) {
    pick = select_target(path_.points_px, U, v_img, P.r1_px, P.r2_px, P.tie_rad, P.max_turn_rad, &excluded);
  }
  diag_.path_target_valid = pick.has_value();
  if (!pick) {
    return no_path_target(t_s, here);
  }
  ++path_target_steps_;
  last_target_t_ = t_s;
  const Eigen::Vector2d off = ground[*pick] - here;
  if (off.norm() < 1e-6) return hold(Eigen::Vector3d(here.x(), here.y(), path_z_));
  path_dir_W_ = off.normalized();
  path_dir_known_ = true;
  diag_.path_dir_W = path_dir_W_;
  diag_.path_target_W_m = ground[*pick];
  // eq. 17: towards the target point at the route speed, constant height and yaw.
  hold_p_ = Eigen::Vector3d(here.x(), here.y(), path_z_);
  Setpoint sp = hold(hold_p_);
  sp.v_W_mps.head<2>() = P.speed_mps * path_dir_W_;
  return sp;
}

// The paper's baseline (its Table 1): the route pixels' distribution (their principal axis
// and centroid) turns the heading; the vehicle moves along its body x only, and only while
// the heading is within baseline_align_deg of the route.
Setpoint LandingController::pixel_distribution_step(double t_s, const NavState& nav, const GroundView& g,
                                                    const Eigen::Vector2d& U, const Eigen::Vector2d& v_img,
                                                    const std::vector<Eigen::Vector2d>& candidates) {
  const PathGuidanceParams& P = p_.path;
  const Eigen::Vector2d here = nav.p_W_m.head<2>();
  std::vector<Eigen::Vector2d> pts;
  for (const Eigen::Vector2d& p : candidates) {
    const double r = (p - U).norm();
    if (r > P.r1_px && r < P.r2_px) pts.push_back(p);
  }
  diag_.path_target_valid = pts.size() >= 2;
  if (pts.size() < 2 || v_img.norm() < 1e-6) return no_path_target(t_s, here);
  ++path_target_steps_;
  last_target_t_ = t_s;
  // Principal axis of the points ahead of the vehicle (those on the side of v), centroid.
  std::vector<Eigen::Vector2d> ahead;
  for (const Eigen::Vector2d& p : pts) {
    if ((p - U).dot(v_img) > 0) ahead.push_back(p);
  }
  if (ahead.size() < 2) ahead = pts;
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& p : ahead) c += p;
  c /= static_cast<double>(ahead.size());
  Eigen::Matrix2d C = Eigen::Matrix2d::Zero();
  for (const Eigen::Vector2d& p : ahead) C += (p - c) * (p - c).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(C);
  Eigen::Vector2d axis = es.eigenvectors().col(1);
  // The axis points along the route away from the vehicle: towards the points' centroid
  // (at a corner the points left are the new leg's), along v when they surround U.
  const Eigen::Vector2d away = c - U;
  const Eigen::Vector2d sense = away.norm() > 0.5 * P.r1_px ? away : v_img;
  if (axis.dot(sense) < 0) axis = -axis;
  // Aim at the centroid pushed along the axis: the heading to that ground point.
  const auto a = image_to_ground_ray(g, c + 100.0 * axis);
  if (!a || a->norm() < 1e-6) return hold(Eigen::Vector3d(hold_p_.x(), hold_p_.y(), path_z_));
  const double want = std::atan2(a->y(), a->x());
  const double err = std::remainder(want - yaw_hold_, 2 * M_PI);
  const double max_step = P.baseline_yaw_rate_degps * M_PI / 180.0 * (1.0 / p_.cascade.outer_rate_hz);
  yaw_hold_ = std::remainder(yaw_hold_ + std::clamp(err, -max_step, max_step), 2 * M_PI);
  path_dir_W_ = Eigen::Vector2d(std::cos(yaw_hold_), std::sin(yaw_hold_));
  path_dir_known_ = true;
  diag_.path_dir_W = path_dir_W_;
  hold_p_ = Eigen::Vector3d(here.x(), here.y(), path_z_);
  Setpoint sp = hold(hold_p_);
  if (std::abs(err) < P.baseline_align_deg * M_PI / 180.0) sp.v_W_mps.head<2>() = P.speed_mps * path_dir_W_;
  return sp;
}

RotorCommand LandingController::step(double t_s, const NavState& nav, const ImuSample& imu) {
  const bool finite_input = std::isfinite(t_s) && nav.q_WB.coeffs().allFinite() &&
                            nav.p_W_m.allFinite() && nav.v_W_mps.allFinite() &&
                            nav.omega_B_radps.allFinite() && imu.gyro_B_radps.allFinite() &&
                            imu.accel_B_mps2.allFinite();
  if (!finite_input) {  // hold the last command rather than feed NaN to the cascade
    ++rejected_inputs_;
    return last_cmd_;
  }
  RotorCommand cmd;
  cmd.t_s = t_s;
  if (nav.valid) {
    tracker_.add_nav(nav);
    if (!started_) {
      started_ = true;
      yaw_hold_ = yaw_of(nav.q_WB);
      search_yaw0_ = yaw_hold_;
      search_t0_ = t_s;
      search_entry_t_ = t_s;
      hold_p_ = nav.p_W_m;
      last_outer_t_ = t_s;
      last_inner_t_ = t_s;
    }
  }
  // Vision results in time order, each with the nav state of its own frame time.
  if (started_ && !pending_.empty()) {
    std::sort(pending_.begin(), pending_.end(),
              [](const PlatformObservation& a, const PlatformObservation& b) {
                return a.t_s < b.t_s;
              });
    for (const PlatformObservation& obs : pending_) tracker_.add_observation(obs);
    pending_.clear();
  }

  if (started_ && mode_ == Mode::kTouchdown) detect_contact(t_s, imu, nav);

  if (started_ && nav.valid && cascade_.outer_due(t_s)) {
    last_sp_ = run_mode_machine(t_s, nav);
    const bool tracking =
        mode_ == Mode::kObserve || mode_ == Mode::kApproach || mode_ == Mode::kRecovery;
    cascade_.set_tilt_limit_deg(tracking ? p_.landing.track_max_tilt_deg
                                         : p_.cascade.max_tilt_deg);
    // Descent speed near the platform (recovery): bounded whatever the clearance servo asks.
    double descent_limit = p_.cascade.max_vel_down_mps;
    if (mode_ == Mode::kRecovery && diag_.gear_clearance_m < p_.landing.final_hold_height_m) {
      descent_limit = p_.landing.max_descent_final_mps;
    } else if (mode_ == Mode::kRecovery && diag_.gear_clearance_m < p_.landing.near_height_m) {
      descent_limit = p_.landing.max_descent_near_mps;
    }
    cascade_.set_descent_limit_mps(descent_limit);
    cascade_.update_outer(t_s, last_sp_, nav);
    diag_.setpoint = last_sp_;
  }
  diag_.mode = mode_;
  last_inner_t_ = t_s;

  const bool cut = mode_ == Mode::kTouchdown || mode_ == Mode::kLanded;
  diag_.motors_cut = cut;
  cmd.motors_cut = cut;
  if (cut) {
    cmd.w_radps.fill(0.0);
    last_cmd_ = cmd;
    return cmd;
  }
  const MixerOutput out = cascade_.update_inner(t_s, nav, imu);
  cmd.w_radps = out.w_radps;
  last_cmd_ = cmd;
  return cmd;
}

}  // namespace lander::ctl
