#include "lander/controller/path_guidance.h"

#include <cmath>

namespace lander::ctl {

void PathGuidanceParams::validate() const {
  check_fields(*this);
  require(guidance == "min_angle" || guidance == "pixel_distribution", "guidance",
          "must be min_angle or pixel_distribution (got '" + guidance + "')");
  require(projection == "ray" || projection == "constant_k", "projection",
          "must be ray or constant_k (got '" + projection + "')");
  require(r1_px >= 0 && r2_px > r1_px && r2_px <= 2000, "r2_px", "needs 0 <= r1_px < r2_px <= 2000");
  require(tie_rad >= 0 && tie_rad < M_PI / 4, "tie_deg", "must be in [0, 45) deg");
  require(std::isfinite(direction_rad), "direction_deg", "must be finite");
  require(min_speed_mps >= 0 && min_speed_mps < speed_mps, "min_speed_mps", "must be in [0, speed_mps)");
  require(max_turn_rad > 0 && max_turn_rad <= M_PI, "max_turn_deg", "must be in (0, 180] deg");
}

std::optional<std::size_t> select_target(const std::vector<Eigen::Vector2d>& points_px,
                                         const Eigen::Vector2d& U, const Eigen::Vector2d& v,
                                         double r1_px, double r2_px, double tie_rad,
                                         double max_turn_rad, const std::vector<bool>* excluded) {
  struct Cand {
    std::size_t i;
    double angle, r;
  };
  std::vector<Cand> in;
  for (std::size_t i = 0; i < points_px.size(); ++i) {
    if (excluded && i < excluded->size() && (*excluded)[i]) continue;
    const Eigen::Vector2d T = points_px[i] - U;  // eq. 11
    const double r = T.norm();
    if (!(r > r1_px && r < r2_px)) continue;  // eq. 10
    // eq. 12: the angle between T_i and v.
    const double angle = std::abs(std::atan2(v.x() * T.y() - v.y() * T.x(), v.dot(T)));
    if (angle > max_turn_rad) continue;
    in.push_back({i, angle, r});
  }
  if (in.empty()) return std::nullopt;
  double best = M_PI;
  for (const Cand& c : in) best = std::min(best, c.angle);
  // Ties: the farthest of those within tie_rad of the smallest angle.
  const Cand* pick = nullptr;
  for (const Cand& c : in) {
    if (c.angle <= best + tie_rad && (!pick || c.r > pick->r)) pick = &c;
  }
  return pick->i;
}

namespace {
Eigen::Vector3d camera_offset_W(const GroundView& g) { return g.R_WB * g.t_BC_m; }
}  // namespace

std::optional<Eigen::Vector2d> ground_to_image(const GroundView& g, const Eigen::Vector2d& off) {
  const Eigen::Vector3d c = camera_offset_W(g);
  // Ground point relative to the camera, in W: below the vehicle by h_B, offset horizontally.
  const Eigen::Vector3d d_W(off.x() - c.x(), off.y() - c.y(), -g.h_B_m - c.z());
  const Eigen::Vector3d d_C = (g.R_WB * g.R_BC).transpose() * d_W;
  if (d_C.z() <= 1e-6) return std::nullopt;
  return Eigen::Vector2d(g.fx * d_C.x() / d_C.z() + g.cx, g.fy * d_C.y() / d_C.z() + g.cy);
}

Eigen::Vector2d vehicle_image_point(const GroundView& g) {
  const auto p = ground_to_image(g, Eigen::Vector2d::Zero());
  return p ? *p : Eigen::Vector2d(g.cx, g.cy);
}

std::optional<Eigen::Vector2d> image_to_ground_ray(const GroundView& g, const Eigen::Vector2d& p) {
  const Eigen::Vector3d ray_C((p.x() - g.cx) / g.fx, (p.y() - g.cy) / g.fy, 1.0);
  const Eigen::Vector3d ray_W = g.R_WB * g.R_BC * ray_C;
  if (ray_W.z() > -1e-3) return std::nullopt;
  const Eigen::Vector3d c = camera_offset_W(g);
  const double h_C = g.h_B_m + c.z();  // camera height above the ground
  if (h_C <= 0) return std::nullopt;
  const double lambda = h_C / -ray_W.z();
  return Eigen::Vector2d(c.x() + lambda * ray_W.x(), c.y() + lambda * ray_W.y());
}

Eigen::Vector2d image_to_ground_k(const GroundView& g, const Eigen::Vector2d& p,
                                  const Eigen::Vector2d& U, double k) {
  const Eigen::Vector3d off_C(k * (p.x() - U.x()), k * (p.y() - U.y()), 0.0);
  const Eigen::Vector3d off_B = g.R_BC * off_C;
  const Eigen::Vector3d x_W = g.R_WB * Eigen::Vector3d::UnitX();
  const double yaw = std::atan2(x_W.y(), x_W.x());
  const Eigen::Rotation2Dd R(yaw);
  return R * Eigen::Vector2d(off_B.x(), off_B.y());
}

}  // namespace lander::ctl
