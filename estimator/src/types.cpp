#include "lander/estimator/types.h"

#include <cmath>

namespace lander {

Eigen::Isometry3d CameraMount::X_BC() const {
  const Eigen::Vector3d rpy = rpy_BC_deg * M_PI / 180.0;
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = R;
  X.translation() = p_BC_m;
  return X;
}

}  // namespace lander
