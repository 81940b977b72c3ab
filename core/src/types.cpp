#include "lander/core/types.h"

#include <algorithm>
#include <cmath>

namespace lander {

Eigen::Matrix3d R_from_rpy(const Eigen::Vector3d& rpy) {
  return (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Vector3d rpy_from_R(const Eigen::Matrix3d& R) {
  return {std::atan2(R(2, 1), R(2, 2)), std::asin(-std::clamp(R(2, 0), -1.0, 1.0)),
          std::atan2(R(1, 0), R(0, 0))};
}

Eigen::Vector2d CameraModel::distort_px(const Eigen::Vector2d& u) const {
  if (!has_distortion()) return u;
  const double x = (u.x() - cx_px) / fx_px, y = (u.y() - cy_px) / fy_px;
  const double r2 = x * x + y * y;
  const double radial = 1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
  const double xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
  const double yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
  return {fx_px * xd + cx_px, fy_px * yd + cy_px};
}

Eigen::Isometry3d CameraMount::X_BC() const {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = R_from_rpy(rpy_BC_deg * M_PI / 180.0);
  X.translation() = p_BC_m;
  return X;
}

}  // namespace lander
