// The follow_path mode (seed 003): follow a painted route (path_guidance.h) until the target
// is acquired, the route is lost or it ends.
#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>

#include "modes/modes.h"

namespace lander::ctl::modes {
namespace {

// The flown trail, a point every kTrailSpacing_m (the last kTrailMaxPoints: 100 m).
constexpr double kTrailSpacing_m = 0.1;
constexpr std::size_t kTrailMaxPoints = 1000;

}  // namespace

void FollowPathMode::enter(LandingContext& c, const Tick& k, Mode /*from*/, const std::string& /*reason*/) {
  const PathGuidanceParams& P = c.p.path;
  const NavState& nav = k.nav;
  // The travel direction: the given one, else the cart's last seen motion, else the
  // vehicle's own; none: the first target decides (the farthest candidate).
  dir_known_ = true;
  if (P.direction_given) {
    dir_W_ = Eigen::Vector2d(std::cos(P.direction_rad), std::sin(P.direction_rad));
  } else if (c.tracker.has_fix() && c.tracker.velocity().head<2>().norm() > P.min_speed_mps) {
    dir_W_ = c.tracker.velocity().head<2>().normalized();
  } else if (nav.v_W_mps.head<2>().norm() > P.min_speed_mps) {
    dir_W_ = nav.v_W_mps.head<2>().normalized();
  } else {
    dir_known_ = false;
  }
  // Constant height: guide() servos it on the fused height above the ground; without one
  // the vehicle keeps the height it is at.
  z_ = nav.p_W_m.z();
  trail_.clear();
  dr_ = nav.p_W_m.head<2>();
  dr_t_ = k.t_s;
  last_target_t_ = k.t_s;
  c.hold_p = nav.p_W_m;
}

ModeResult FollowPathMode::update(LandingContext& c, const Tick& k) {
  const double t_s = k.t_s;
  if (c.tracker.keyframe_streak() >= c.p.landing.reacquire_frames && c.in_view(t_s, c.p.landing.loss_timeout_s)) {
    return ModeResult::go(Mode::kObserve, fmt::format("target acquired while following the route: {} consecutive "
                                                      "keyframes",
                                                      c.tracker.keyframe_streak()));
  }
  if (c.route_ended) return ModeResult::stay(c.hold(c.hold_p));  // the end of the route: hold and report
  if (t_s - c.route.last_t_s > c.p.path.route_lost_s) {
    return ModeResult::go(Mode::kSearch,
                          fmt::format("route lost: no candidate point for {:.2f} s", t_s - c.route.last_t_s));
  }
  return ModeResult::stay(guide(c, k));
}

// One outer step of follow_path (seed 003 eq. 10-17, see path_guidance.h).
Setpoint FollowPathMode::guide(LandingContext& c, const Tick& k) {
  const PathGuidanceParams& P = c.p.path;
  const NavState& nav = k.nav;
  ++steps_;
  const Eigen::Vector2d here = nav.p_W_m.head<2>();
  extend_trail(k);
  // Constant height above the ground: servoed on the fused height above the surface (the
  // navigation's height drifts with the barometer's bias until GPS and vision settle it).
  if (c.altitude.valid) z_ = nav.p_W_m.z() + (P.height_m - c.altitude.h_surface_m);
  const GroundView g = ground_view(c, nav);
  // U: the paper's image centre with the constant scale; the image of the point below the
  // vehicle with the exact projection.
  const Eigen::Vector2d below = vehicle_image_point(g);
  const Eigen::Vector2d U = P.projection == "constant_k" ? Eigen::Vector2d(g.cx, g.cy) : below;
  // v: the velocity's image projection; the kept direction while slow or turning hard.
  const Eigen::Vector2d dir = travel_direction(P, nav);
  Eigen::Vector2d v_img = Eigen::Vector2d::Zero();
  if (const auto a = ground_to_image(g, dir)) v_img = *a - below;
  std::vector<Eigen::Vector2d> ground;
  std::vector<bool> excluded;
  classify(c, nav, g, U, &ground, &excluded);
  const std::vector<Eigen::Vector2d>& points = c.route.points.points_px;
  if (P.guidance == "pixel_distribution") {
    // The baseline sees the same candidates, with the flown trail set aside (its dead end).
    std::vector<Eigen::Vector2d> fresh;
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (!excluded[i]) fresh.push_back(points[i]);
    }
    return pixel_distribution(c, k, g, U, v_img, fresh);
  }
  const std::optional<std::size_t> pick = pick_target(c, U, v_img, &excluded);
  c.diag.path_target_valid = pick.has_value();
  if (!pick) return no_target(c, k.t_s, here);
  return fly_to_target(c, k, ground[*pick]);
}

// The flown trail in a dead-reckoned frame (the integral of the navigation velocity): the
// navigation position jumps with GPS corrections (0.4 m within 2 s in wind), which made
// points just flown over look new; the integral drifts only slowly.
void FollowPathMode::extend_trail(const Tick& k) {
  const double dt_dr = std::clamp(k.t_s - dr_t_, 0.0, 0.2);
  dr_t_ = k.t_s;
  dr_ += k.nav.v_W_mps.head<2>() * dt_dr;
  if (trail_.empty() || (dr_ - trail_.back()).norm() >= kTrailSpacing_m) {
    trail_.push_back(dr_);
    if (trail_.size() > kTrailMaxPoints) trail_.erase(trail_.begin());
  }
}

// The camera's view of the ground now: attitude, mount, height and the frame's intrinsics.
GroundView FollowPathMode::ground_view(const LandingContext& c, const NavState& nav) const {
  GroundView g;
  g.R_WB = nav.q_WB.toRotationMatrix();
  const Eigen::Isometry3d X_BC = c.mount.X_BC();
  g.R_BC = X_BC.linear();
  g.t_BC_m = X_BC.translation();
  g.h_B_m = c.altitude.valid ? c.altitude.h_surface_m : c.p.path.height_m;
  g.fx = c.route.points.fx;
  g.fy = c.route.points.fy;
  g.cx = c.route.points.cx;
  g.cy = c.route.points.cy;
  return g;
}

Eigen::Vector2d FollowPathMode::travel_direction(const PathGuidanceParams& P, const NavState& nav) const {
  const Eigen::Vector2d v_W = nav.v_W_mps.head<2>();
  if (v_W.norm() > P.min_speed_mps && (!dir_known_ || v_W.normalized().dot(dir_W_) > 0.5)) {
    return v_W.normalized();
  }
  return dir_W_;
}

// Candidates on the flown trail (all but its last trail_skip_m) are behind: set aside.
void FollowPathMode::classify(const LandingContext& c, const NavState& nav, const GroundView& g,
                              const Eigen::Vector2d& U, std::vector<Eigen::Vector2d>* ground,
                              std::vector<bool>* excluded) const {
  const PathGuidanceParams& P = c.p.path;
  const std::vector<Eigen::Vector2d>& points = c.route.points.points_px;
  const bool const_k = P.projection == "constant_k";
  const Eigen::Vector2d here = nav.p_W_m.head<2>();
  ground->assign(points.size(), Eigen::Vector2d::Zero());
  excluded->assign(points.size(), false);
  const int skip = static_cast<int>(std::ceil(P.trail_skip_m / kTrailSpacing_m));
  const int trail_n = static_cast<int>(trail_.size()) - skip;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto off = const_k ? image_to_ground_k(g, points[i], U, P.k_m_per_px) : image_to_ground_ray(g, points[i]);
    if (!off) {
      (*excluded)[i] = true;
      continue;
    }
    (*ground)[i] = here + *off;
    const Eigen::Vector2d g_dr = dr_ + *off;  // the same point in the trail's frame
    for (int j = 0; j < trail_n && !(*excluded)[i]; ++j) {
      (*excluded)[i] = (trail_[j] - g_dr).norm() < P.trail_radius_m;
    }
  }
}

// The target point (seed 003 eq. 10-16); with no direction yet the farthest candidate in the
// annulus decides it.
std::optional<std::size_t> FollowPathMode::pick_target(const LandingContext& c, const Eigen::Vector2d& U,
                                                       const Eigen::Vector2d& v_img,
                                                       std::vector<bool>* excluded) const {
  const PathGuidanceParams& P = c.p.path;
  const std::vector<Eigen::Vector2d>& points = c.route.points.points_px;
  std::optional<std::size_t> pick;
  if (!dir_known_) {
    double best_r = -1;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const double r = (points[i] - U).norm();
      if (!(*excluded)[i] && r > P.r1_px && r < P.r2_px && r > best_r) {
        best_r = r;
        pick = i;
      }
    }
  } else if (v_img.norm() > 1e-6) {
    pick = select_target(points, U, v_img, P.r1_px, P.r2_px, P.tie_rad, P.max_turn_rad, excluded);
  }
  return pick;
}

// eq. 17: towards the target point at the route speed, constant height and yaw.
Setpoint FollowPathMode::fly_to_target(LandingContext& c, const Tick& k, const Eigen::Vector2d& target) {
  const Eigen::Vector2d here = k.nav.p_W_m.head<2>();
  ++target_steps_;
  last_target_t_ = k.t_s;
  const Eigen::Vector2d off = target - here;
  if (off.norm() < 1e-6) return c.hold(Eigen::Vector3d(here.x(), here.y(), z_));
  dir_W_ = off.normalized();
  dir_known_ = true;
  c.diag.path_dir_W = dir_W_;
  c.diag.path_target_W_m = target;
  c.hold_p = Eigen::Vector3d(here.x(), here.y(), z_);
  Setpoint sp = c.hold(c.hold_p);
  sp.v_W_mps.head<2>() = c.p.path.speed_mps * dir_W_;
  return sp;
}

// follow_path without a target point this step (either guidance): hold where the last one
// was, at the follow height; none for end_after_s is the route's end, held for good and
// reported.
Setpoint FollowPathMode::no_target(LandingContext& c, double t_s, const Eigen::Vector2d& here) {
  const double waited = t_s - last_target_t_;
  if (waited > c.p.path.end_after_s) {
    c.route_ended = true;
    c.route_end_t_s = t_s;
    c.hold_p = Eigen::Vector3d(here.x(), here.y(), z_);
    c.log_event(t_s, "route_end",
                fmt::format("no route candidate ahead for {:.1f} s ({} guidance): the end of the route; "
                            "holding at ({:.2f}, {:.2f})",
                            waited, c.p.path.guidance, here.x(), here.y()));
  }
  return c.hold(Eigen::Vector3d(c.hold_p.x(), c.hold_p.y(), z_));
}

// The paper's baseline (its Table 1): the route pixels' distribution (their principal axis
// and centroid) turns the heading; the vehicle moves along its body x only, and only while
// the heading is within baseline_align_deg of the route.
Setpoint FollowPathMode::pixel_distribution(LandingContext& c, const Tick& k, const GroundView& g,
                                            const Eigen::Vector2d& U, const Eigen::Vector2d& v_img,
                                            const std::vector<Eigen::Vector2d>& candidates) {
  const PathGuidanceParams& P = c.p.path;
  const Eigen::Vector2d here = k.nav.p_W_m.head<2>();
  std::vector<Eigen::Vector2d> pts;
  for (const Eigen::Vector2d& p : candidates) {
    const double r = (p - U).norm();
    if (r > P.r1_px && r < P.r2_px) pts.push_back(p);
  }
  c.diag.path_target_valid = pts.size() >= 2;
  if (pts.size() < 2 || v_img.norm() < 1e-6) return no_target(c, k.t_s, here);
  ++target_steps_;
  last_target_t_ = k.t_s;
  // Principal axis of the points ahead of the vehicle (those on the side of v), centroid.
  std::vector<Eigen::Vector2d> ahead;
  for (const Eigen::Vector2d& p : pts) {
    if ((p - U).dot(v_img) > 0) ahead.push_back(p);
  }
  if (ahead.size() < 2) ahead = pts;
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& p : ahead) centroid += p;
  centroid /= static_cast<double>(ahead.size());
  Eigen::Matrix2d C = Eigen::Matrix2d::Zero();
  for (const Eigen::Vector2d& p : ahead) C += (p - centroid) * (p - centroid).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(C);
  Eigen::Vector2d axis = es.eigenvectors().col(1);
  // The axis points along the route away from the vehicle: towards the points' centroid
  // (at a corner the points left are the new leg's), along v when they surround U.
  const Eigen::Vector2d away = centroid - U;
  const Eigen::Vector2d sense = away.norm() > 0.5 * P.r1_px ? away : v_img;
  if (axis.dot(sense) < 0) axis = -axis;
  // Aim at the centroid pushed along the axis: the heading to that ground point.
  const auto a = image_to_ground_ray(g, centroid + 100.0 * axis);
  if (!a || a->norm() < 1e-6) return c.hold(Eigen::Vector3d(c.hold_p.x(), c.hold_p.y(), z_));
  const double want = std::atan2(a->y(), a->x());
  const double err = std::remainder(want - c.yaw_hold_rad, 2 * M_PI);
  const double max_step = P.baseline_yaw_rate_degps * M_PI / 180.0 * (1.0 / c.p.cascade.outer_rate_hz);
  c.yaw_hold_rad = std::remainder(c.yaw_hold_rad + std::clamp(err, -max_step, max_step), 2 * M_PI);
  dir_W_ = Eigen::Vector2d(std::cos(c.yaw_hold_rad), std::sin(c.yaw_hold_rad));
  dir_known_ = true;
  c.diag.path_dir_W = dir_W_;
  c.hold_p = Eigen::Vector3d(here.x(), here.y(), z_);
  Setpoint sp = c.hold(c.hold_p);
  if (std::abs(err) < P.baseline_align_deg * M_PI / 180.0) sp.v_W_mps.head<2>() = P.speed_mps * dir_W_;
  return sp;
}

}  // namespace lander::ctl::modes
