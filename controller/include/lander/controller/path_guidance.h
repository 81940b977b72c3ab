// Image-based path following (seed 003 section 4): the guidance law that turns the candidate
// points of the route's centre line (the estimator's path stage, eq. 6-9) into a navigation
// setpoint. Pure functions (unit-tested on hand-made point sets) and the parameters of the
// controller's follow_path mode (landing_controller.h). No OpenCV, no MuJoCo.
//
// The law, per frame:
//   eq. 10  keep the candidates p_i with r1 < |p_i - U| < r2 (U: the vehicle's image point,
//           the image of the ground point straight below it; r2 < min(w, h) / 2);
//   eq. 11  T_i = p_i - U;
//   eq. 12  the target is the T_i with the smallest angle to v, the image projection of the
//           velocity (the farthest on ties within tie_deg);
//   eq. 13-16 the target's image point to a ground offset from the vehicle in W: either the
//           paper's constant scale k (metres per pixel measured at one height, rotated by the
//           heading only) or the exact intersection of its ray with the ground (attitude,
//           calibration and fused height);
//   eq. 17  the setpoint: towards that ground point at constant height and constant yaw.
// At the start (speed below min_speed_mps) v is the projection of the kept travel direction
// (the scenario's, or the cart's last seen motion); at a dead end no candidate lies within
// max_turn_deg of v once the points of the flown trail are set aside: the law reports the end.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "lander/core/params_io.h"

namespace lander::ctl {

struct PathGuidanceParams {
  bool enabled{true};                ///< follow_path may be entered at all
  std::string guidance{"min_angle"};  ///< min_angle (seed 003 eq. 10-17) | pixel_distribution
                                     ///< (the paper's Table 1 baseline: moves along body x only,
                                     ///< turning towards the distribution of route pixels)
  std::string projection{"ray"};     ///< ray (exact ray-ground intersection) | constant_k
  double r1_px{60.0};                ///< eq. 10 inner radius (px, undistorted image)
  double r2_px{300.0};               ///< eq. 10 outer radius (px), < min(w, h) / 2
  double tie_rad{3.0 * M_PI / 180};  ///< eq. 12: angles within this of the best tie (rad);
                                     ///< YAML tie_deg
  double k_m_per_px{0.00625};        ///< constant_k: metres per pixel (4 m / 640 px)
  double height_m{4.0};              ///< follow height above the ground (m)
  bool direction_given{false};       ///< the travel direction is given (direction_deg)
  double direction_rad{0.0};         ///< that direction, from W x (rad); YAML direction_deg
  double speed_mps{1.0};             ///< speed along the route (m/s)
  double min_speed_mps{0.3};         ///< below this the velocity gives no direction (m/s)
  int enter_frames{3};               ///< consecutive frames with a route before following
  int enter_min_points{3};           ///< candidates a frame needs to count
  double route_lost_s{2.0};          ///< no route this long: back to search (s)
  double end_after_s{2.0};           ///< no candidate ahead this long: the route's end (s)
  double max_turn_rad{150.0 * M_PI / 180};  ///< a candidate beyond this from v is behind
                                     ///< (rad); YAML max_turn_deg: 15 deg more than the
                                     ///< sharpest corner the law turns (135 deg, an acute
                                     ///< corner of 45 deg)
  double trail_radius_m{0.5};        ///< candidates this close to the flown trail are behind
                                     ///< (m): the cross-track error's p95 (0.2 m) plus the
                                     ///< paint's width and margin
  double trail_skip_m{0.25};         ///< the trail's last metres are not used (m): less
                                     ///< than r1 on the ground, so that at a dead end the
                                     ///< candidates behind all lie on the used trail
  double baseline_yaw_rate_degps{20.0};  ///< pixel_distribution: turn rate (deg/s)
  double baseline_align_deg{10.0};   ///< pixel_distribution: moves only when aligned within
  void validate() const;
};

template <class V>
void visit_fields(V& v, PathGuidanceParams& p) {
  v("enabled", p.enabled, range::any, "", "follow_path may be entered at all");
  v("guidance", p.guidance, range::any, "", "min_angle | pixel_distribution");
  v("projection", p.projection, range::any, "", "ray (exact ray-ground intersection) | constant_k");
  v("r1_px", p.r1_px, range::any, "px", "eq. 10 inner radius (px, undistorted image)");
  v("r2_px", p.r2_px, range::any, "px", "eq. 10 outer radius");
  v("tie_deg", p.tie_rad, range::any, "deg",
    "eq. 12: angles within this of the best tie", M_PI / 180.0);
  v("k_m_per_px", p.k_m_per_px, range::open(0, 1), "px",
    "constant_k: metres per pixel (4 m / 640 px)");
  v("height_m", p.height_m, range::closed(1, 50), "m", "follow height above the ground");
  v("direction_given", p.direction_given, range::any, "",
    "the travel direction is given (direction_deg)");
  v("direction_deg", p.direction_rad, range::any, "deg", "that direction, from W x", M_PI / 180.0);
  v("speed_mps", p.speed_mps, range::open_closed(0, 5), "m/s", "speed along the route");
  v("min_speed_mps", p.min_speed_mps, range::any, "m/s",
    "below this the velocity gives no direction");
  v("enter_frames", p.enter_frames, range::at_least(1), "",
    "consecutive frames with a route before following");
  v("enter_min_points", p.enter_min_points, range::at_least(1), "",
    "candidates a frame needs to count");
  v("route_lost_s", p.route_lost_s, range::positive, "s", "no route this long");
  v("end_after_s", p.end_after_s, range::positive, "s", "no candidate ahead this long");
  v("max_turn_deg", p.max_turn_rad, range::any, "deg",
    "a candidate beyond this from v is behind", M_PI / 180.0);
  v("trail_radius_m", p.trail_radius_m, range::non_negative, "m",
    "candidates this close to the flown trail are behind");
  v("trail_skip_m", p.trail_skip_m, range::non_negative, "m",
    "the trail's last metres are not used");
  v("baseline_yaw_rate_degps", p.baseline_yaw_rate_degps, range::open_closed(0, 180), "deg/s",
    "pixel_distribution");
  v("baseline_align_deg", p.baseline_align_deg, range::open(0, 90), "deg", "pixel_distribution");
}

// A frame's candidate points as the controller receives them (from the estimator's path
// stage): undistorted pixels and the pinhole intrinsics they are in.
struct PathPoints {
  double t_s{0.0};                         ///< mid-exposure time (s)
  std::vector<Eigen::Vector2d> points_px;  ///< candidates (px, undistorted)
  double fx{0}, fy{0}, cx{0}, cy{0};       ///< intrinsics (px)
};

// eq. 10-12 on image points. Returns the index of the target, or nothing when no candidate
// lies in the annulus within max_turn of v. `excluded` (same size as points, optional) sets
// candidates aside (the flown trail). v must be non-zero.
std::optional<std::size_t> select_target(const std::vector<Eigen::Vector2d>& points_px,
                                         const Eigen::Vector2d& U, const Eigen::Vector2d& v,
                                         double r1_px, double r2_px, double tie_rad,
                                         double max_turn_rad,
                                         const std::vector<bool>* excluded = nullptr);

// The camera's view of the ground for eq. 13-16: its attitude and position relative to the
// vehicle, the vehicle's height above the ground and the intrinsics.
struct GroundView {
  Eigen::Matrix3d R_WB{Eigen::Matrix3d::Identity()};
  Eigen::Matrix3d R_BC{Eigen::Matrix3d::Identity()};
  Eigen::Vector3d t_BC_m{Eigen::Vector3d::Zero()};  ///< camera position in B (m)
  double h_B_m{4.0};                                ///< vehicle height above the ground (m)
  double fx{640}, fy{640}, cx{639.5}, cy{359.5};
};

// The image point of a ground point given as its offset from the point below the vehicle (W
// xy, m); nothing when it lies behind the camera.
std::optional<Eigen::Vector2d> ground_to_image(const GroundView& g, const Eigen::Vector2d& offset_W_m);
// U: the image of the ground point straight below the vehicle (the principal point when it
// is not in front of the camera).
Eigen::Vector2d vehicle_image_point(const GroundView& g);
// eq. 13-16, exact: the ray of image point p to the ground; the offset (W xy, m) of where it
// meets the ground from the point below the vehicle; nothing when the ray does not descend.
std::optional<Eigen::Vector2d> image_to_ground_ray(const GroundView& g, const Eigen::Vector2d& p_px);
// eq. 13-16 as in the paper: k metres per pixel of (p - U), image axes to body axes by the
// mount, then to W by the heading only (tilt and height ignored).
Eigen::Vector2d image_to_ground_k(const GroundView& g, const Eigen::Vector2d& p_px,
                                  const Eigen::Vector2d& U, double k_m_per_px);

}  // namespace lander::ctl
