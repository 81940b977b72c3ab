#include "lander/estimator/types.h"

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

Eigen::Isometry3d CameraMount::X_BC() const {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = R_from_rpy(rpy_BC_deg * M_PI / 180.0);
  X.translation() = p_BC_m;
  return X;
}

}  // namespace lander
