// The services the landing modes share (context.h).
#include "modes/context.h"

#include <algorithm>
#include <iterator>
#include <limits>

#include <fmt/format.h>

namespace lander::ctl::modes {
namespace {

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

}  // namespace

LandingContext::LandingContext(const ControllerParams& params, const CameraMount& mount_in)
    : p(params),
      mount(mount_in),
      cascade(params.vehicle, params.cascade),
      tracker(params.tracker, mount_in),
      deck(params.deck.predictor) {}

void InertialHeight::update(double t_s, const NavState& nav, const ImuSample& imu, double gravity_mps2) {
  if (!started_) {
    started_ = true;
    t_s_ = t_s;
    v_mps_ = nav.v_W_mps.z();
  }
  const double dt = t_s - t_s_;
  if (!(dt > 0.0)) return;
  const double a_z = (nav.q_WB * imu.accel_B_mps2).z() - gravity_mps2;
  z_m_ += v_mps_ * dt;
  v_mps_ += (a_z + (nav.v_W_mps.z() - v_mps_) / kLeak_s) * dt;
  t_s_ = t_s;
  history_.emplace_back(t_s, z_m_);
  while (history_.size() > 2 && history_.front().first < t_s - kHistory_s) history_.pop_front();
}

double InertialHeight::at(double t_s) const {
  if (history_.empty() || t_s < history_.front().first) return std::numeric_limits<double>::quiet_NaN();
  if (t_s >= history_.back().first) return history_.back().second + v_mps_ * (t_s - history_.back().first);
  auto hi = std::lower_bound(history_.begin(), history_.end(), t_s,
                             [](const std::pair<double, double>& e, double t) { return e.first < t; });
  auto lo = std::prev(hi);
  const double u = (t_s - lo->first) / (hi->first - lo->first);
  return lo->second + u * (hi->second - lo->second);
}

void LandingContext::feed_deck(const PlatformFix& fix) {
  if (!p.deck.enabled || fix.p_BP_W_m.norm() > p.deck.sample_max_range_m) return;
  const double z_vehicle = inertial_height.at(fix.t_s);
  if (!std::isfinite(z_vehicle)) return;
  // The normal n = R e_z of R = Ry(pitch) Rx(roll): (sin p cos r, -sin r, cos p cos r).
  const Eigen::Vector3d n = fix.n_W.normalized();
  const double roll = -std::asin(std::clamp(n.y(), -1.0, 1.0)), pitch = std::atan2(n.x(), n.z());
  deck.add({fix.t_s, z_vehicle + fix.p_BP_W_m.z(), roll, pitch});
}

// Moving by the fit; or, on a deck expected to move, while the predictor cannot yet say it
// is still (deck.expected).
bool LandingContext::deck_moving() const {
  if (!p.deck.enabled) return false;
  if (p.deck.expected && !deck.ready()) return true;
  return deck.moving();
}

// A quiescent period that the last centimetres, begun now, meet: the descent from the
// current clearance takes lead_s (clearance / deck.descent_rate_mps), so the period is
// looked for within lead_s + window_s, and taken once the planned contact (now + lead_s)
// falls in it: the descent starts before a period that begins later, and the contact comes
// at its start, its window_s of margin left for a descent slower than planned.
bool LandingContext::deck_quiescent(double t_s, double lead_s, std::string* why, QuiescentWindow* window) const {
  const DeckTimingParams& D = p.deck;
  if (!deck.ready()) {
    *why = fmt::format("deck motion not yet predictable ({:.1f} s of fixes)", deck.history_s());
    return false;
  }
  const double t_contact = t_s + lead_s;
  const auto w = deck.next_quiescent(t_s, lead_s + D.window_s, D.max_vz_mps, D.max_tilt_rad, D.window_s);
  const DeckState s = deck.predict(t_s);
  // The planned contact in the period with half of it to spare (a descent slower than
  // planned, the cut's fall).
  if (!w || w->start_s > t_contact + D.predictor.quiescent_step_s || t_contact + 0.5 * D.window_s > w->end_s) {
    *why = fmt::format("no quiescent period of {:.1f} s at the contact planned in {:.2f} s: deck vertical speed "
                       "{:.2f} m/s, tilt {:.1f} deg now",
                       D.window_s, lead_s, s.vz_mps, s.tilt_rad * 180.0 / M_PI);
    return false;
  }
  if (window) *window = *w;
  *why = fmt::format("deck quiescent {:.2f}-{:.2f} s by its prediction, contact planned at {:.2f} s (vertical speed "
                     "{:.2f} m/s, tilt {:.1f} deg now)",
                     w->start_s, w->end_s, t_contact, s.vz_mps, s.tilt_rad * 180.0 / M_PI);
  return true;
}

double LandingContext::platform_z() const {
  return tracker.has_fix() ? tracker.latest().p_W_m.z() : last_platform_z_;
}

double LandingContext::z_above_surface(const NavState& nav, double h_m) const {
  if (!altitude.valid) return h_m;
  const double by_fusion = nav.p_W_m.z() + (h_m - altitude.h_surface_m);
  if (!std::isfinite(altitude.clearance_m)) return by_fusion;
  return std::max(by_fusion, nav.p_W_m.z() + (h_m - altitude.clearance_m));
}

double LandingContext::search_min_z(const NavState& nav) const {
  return z_above_surface(nav, p.landing.search_min_height_m);
}

// A fused height metres off (a degraded GPS taken in at the start, wandering with its error)
// once held the search 1 m over the ground while it believed 4.5 m: the floor is re-applied
// every step, and the ultrasonic's own clearance takes part in it.
void LandingContext::keep_min_height(double t_s, const NavState& nav) {
  const double z_min = search_min_z(nav);
  if (hold_p.z() >= z_min) return;
  if (!low_clearance_logged && std::isfinite(altitude.clearance_m) &&
      altitude.clearance_m < p.landing.search_min_height_m &&
      altitude.clearance_m < altitude.h_surface_m) {
    low_clearance_logged = true;
    log_event(t_s, "low_clearance",
              fmt::format("ultrasonic clearance {:.2f} m (fused height above the surface {:.2f} m) "
                          "under search_min_height_m {:.2f} m in {}: climbing",
                          altitude.clearance_m, altitude.h_surface_m,
                          p.landing.search_min_height_m, to_string(mode)));
  }
  hold_p.z() = z_min;
}

Setpoint LandingContext::hold(const Eigen::Vector3d& at) const {
  Setpoint sp;
  sp.p_W_m = at;
  sp.yaw_rad = yaw_hold_rad;
  return sp;
}

bool LandingContext::predict_platform(double t_s, Eigen::Vector2d* pos, Eigen::Vector2d* vel) {
  if (!tracker.has_fix()) return false;
  if (t_s - tracker.latest().t_s > p.landing.search_predict_max_s) {
    // Too old to predict from: forget it (a re-acquisition starts a fresh history).
    tracker.clear();
    return false;
  }
  const PlatformMotion m = tracker.motion();
  *pos = m.position_at(t_s).head<2>();
  *vel = m.velocity_at(t_s).head<2>();
  return true;
}

bool LandingContext::broadcast_platform(double t_s, Eigen::Vector2d* pos, Eigen::Vector2d* vel) const {
  const double max_age = p.landing.telemetry_max_age_s;
  if (!broadcast || max_age <= 0.0) return false;
  const double age = t_s - broadcast->t_s;
  if (age < 0.0 || age > max_age) return false;
  *vel = broadcast->v_W_mps.head<2>();
  *pos = broadcast->p_W_m.head<2>() + age * *vel;
  return true;
}

void LandingContext::log_event(double t_s, const std::string& what, const std::string& reason) {
  decisions.events.push_back({t_s, decisions.attempts, what, reason});
}

void LandingContext::decide(double t_s, const std::string& decision, const std::string& reason) {
  decisions.decision = decision;
  decisions.reason = reason;
  decisions.t_s = t_s;
  log_event(t_s, decision, reason);
}

void LandingContext::declare_loss(double t_s) {
  Reacquisition r;
  r.t_last_seen_s = tracker.last_detection_t();
  r.t_lost_s = t_s;
  r.lost_in = mode;
  reacquisitions.push_back(r);
  loss_motion_ = tracker.motion();
}

bool LandingContext::check_reach(double t_s) {
  if (tracker.num_fixes() < kMinFixesForFeedForward) return true;
  const double speed = horizontal(tracker.velocity());
  const VehicleLimits& lim = cascade.limits();
  if (speed + kMinClosingSpeed_mps <= lim.max_speed_xy_mps) return true;
  if (out_of_reach_speed_mps_ <= 0.0) {
    out_of_reach_speed_mps_ = speed;
    log_event(t_s, "out_of_reach",
              fmt::format("the platform at {:.2f} m/s leaves less than {:.1f} m/s to close with "
                          "under this vehicle's {:.2f} m/s speed limit ({})",
                          speed, kMinClosingSpeed_mps, lim.max_speed_xy_mps, lim.speed_source()));
  }
  return false;
}

std::string LandingContext::reach_note() const {
  if (out_of_reach_speed_mps_ <= 0.0) return "";
  return fmt::format("; the platform ({:.2f} m/s) was beyond this vehicle's {:.2f} m/s speed "
                     "limit ({})",
                     out_of_reach_speed_mps_, cascade.limits().max_speed_xy_mps,
                     cascade.limits().speed_source());
}

void LandingContext::check_reacquired(double t_s) {
  if (reacquisitions.empty()) return;
  Reacquisition& r = reacquisitions.back();
  if (!std::isnan(r.t_reacquired_s)) return;
  if (tracker.last_detection_t() <= r.t_last_seen_s) return;
  if (tracker.keyframe_streak() < p.landing.reacquire_frames || !in_view(t_s, p.landing.loss_timeout_s)) {
    return;
  }
  r.t_reacquired_s = t_s;
  if (!loss_motion_.valid) return;
  // The first fix after the loss against where the model of the loss put the platform then.
  for (const PlatformFix& f : tracker.fixes()) {
    if (f.t_s <= r.t_last_seen_s) continue;
    r.prediction_error_m = horizontal(f.p_W_m - loss_motion_.position_at(f.t_s));
    break;
  }
}

// A moving deck's height since the last fix: the tracker's straight line (its vertical
// velocity at the fix, carried on) over a fresh fix's latency, held beyond it. Carried on, a
// deck falling at 0.4 m/s when vision lost it for 1.2 s was believed 0.5 m lower than it had
// risen, and the vehicle descended into it at 0.8 m/s; the predicted heave in its place
// (tried) once moved the believed deck 0.6 m in 0.4 s. Held, the error is the deck's own
// motion during the loss, and recovery backs off to deck.unpredicted_gap_m meanwhile.
double LandingContext::deck_height_since_fix(double t_s) const {
  constexpr double kFreshFixAge_s = 0.1;  // a fresh fix's age in the loop (frame period + latency)
  const double beyond = t_s - tracker.latest().t_s - kFreshFixAge_s;
  return beyond > 0.0 ? -diag.platform_v_W_mps.z() * beyond : 0.0;
}

void LandingContext::update_platform_diagnostics(double t_s, const NavState& nav) {
  const LandingParams& L = p.landing;
  diag.num_fixes = tracker.num_fixes();
  diag.keyframe_streak = tracker.keyframe_streak();
  diag.platform_known = tracker.has_fix();
  if (!tracker.has_fix()) return;
  last_platform_z_ = tracker.latest().p_W_m.z();
  // The platform now, from the relative vector (navigation drift cancels), in W.
  diag.platform_W_m = nav.p_W_m + tracker.relative_now(t_s);
  diag.platform_v_W_mps = tracker.velocity();
  diag.horizontal_error_m = horizontal(diag.platform_W_m - nav.p_W_m);
  if (mode == Mode::kRecovery && deck_moving()) diag.platform_W_m.z() += deck_height_since_fix(t_s);
  diag.gear_clearance_m = nav.p_W_m.z() - diag.platform_W_m.z() - L.gear_height_m;
  // The platform's normal in body axes now: the last fix's normal (vision's relative
  // attitude, put in W with the navigation attitude of that frame) brought back with the
  // navigation attitude now, so the attitude's own error cancels but for its change since.
  const Eigen::Vector3d n_B = nav.q_WB.conjugate() * tracker.latest().n_W;
  diag.skid_drop_m = skid_drop_m(n_B.normalized(), L);
}

}  // namespace lander::ctl::modes
