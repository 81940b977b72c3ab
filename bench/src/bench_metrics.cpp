// View geometry shared by the estimator benchmark's conditions (bench_metrics.h).
#include "bench_metrics.h"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>

#include "lander/estimator/camera_cv.h"

namespace lander::bench::detail {

// Raw-image projections of P points (distortion applied).
std::vector<Eigen::Vector2d> project_P(const CameraModel& cam, const Eigen::Isometry3d& X_CP,
                                       const std::vector<Eigen::Vector2d>& pts_P) {
  std::vector<cv::Point3d> obj;
  for (const auto& p : pts_P) {
    const Eigen::Vector3d q = X_CP * Eigen::Vector3d(p.x(), p.y(), 0);
    obj.emplace_back(q.x(), q.y(), q.z());
  }
  std::vector<cv::Point2d> img;
  cv::projectPoints(obj, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), camera_matrix_cv(cam),
                    dist_coeffs_cv(cam), img);
  std::vector<Eigen::Vector2d> out;
  for (const auto& p : img) out.emplace_back(p.x, p.y);
  return out;
}

// True if any part of the platform top projects into the image in front of the camera.
bool platform_in_view(const CameraModel& cam, const Eigen::Isometry3d& X_CP,
                      const TargetGeometry& g) {
  const double hx = 0.5 * g.platform_size_m.x(), hy = 0.5 * g.platform_size_m.y();
  for (int i = 0; i <= 8; ++i) {
    for (int j = 0; j <= 8; ++j) {
      const Eigen::Vector3d q = X_CP * Eigen::Vector3d(-hx + i * hx / 4, -hy + j * hy / 4, 0);
      if (q.z() <= 0.05) continue;
      const double u = cam.fx_px * q.x() / q.z() + cam.cx_px;
      const double v = cam.fy_px * q.y() / q.z() + cam.cy_px;
      const double m = 0.5 * std::max(cam.width_px, cam.height_px);  // generous margin
      if (u > -m && u < cam.width_px + m && v > -m && v < cam.height_px + m) return true;
    }
  }
  return false;
}

// The smallest extent (px) of any ring set's outer circle in the image: the shortest of the
// projected diameters through its centre in 12 directions (the ellipse's minor axis, closely).
// Infinite-free: a set behind the camera gives 0.
double min_ring_extent_px(const CameraModel& cam, const Eigen::Isometry3d& X_CP,
                          const TargetGeometry& g) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& r : g.rings) {
    std::vector<Eigen::Vector2d> pts;
    for (int k = 0; k < 24; ++k) {
      const double a = M_PI * k / 12;
      pts.push_back(r.centre_P_m + r.outer_radius_m * Eigen::Vector2d(std::cos(a), std::sin(a)));
    }
    for (const auto& p : pts) {
      if ((X_CP * Eigen::Vector3d(p.x(), p.y(), 0)).z() <= 0.05) return 0.0;
    }
    const auto img = project_P(cam, X_CP, pts);
    for (int k = 0; k < 12; ++k) best = std::min(best, (img[k] - img[k + 12]).norm());
  }
  return best;
}

bool target_in_view(const CameraModel& cam, const Eigen::Isometry3d& X_CP, const TargetGeometry& g,
                    const std::vector<Eigen::Vector2d>& corners_P) {
  std::vector<Eigen::Vector2d> pts(corners_P);
  for (const auto& r : g.rings) {
    for (int k = 0; k < 16; ++k) {
      const double a = 2 * M_PI * k / 16;
      pts.push_back(r.centre_P_m + r.outer_radius_m * Eigen::Vector2d(std::cos(a), std::sin(a)));
    }
  }
  for (const auto& q : pts) {
    if ((X_CP * Eigen::Vector3d(q.x(), q.y(), 0)).z() <= 0.05) return false;
  }
  for (const auto& u : project_P(cam, X_CP, pts)) {
    if (u.x() < 1 || u.y() < 1 || u.x() > cam.width_px - 2 || u.y() > cam.height_px - 2) return false;
  }
  return true;
}

}  // namespace lander::bench::detail
