// Pose errors against the truth, shared by the test folders (the estimator's synthetic views,
// the peer detectors' bench, the sim's renders).
#pragma once

#include <Eigen/Geometry>

namespace lander::test {

// Rotation angle between two poses' rotations (rad).
inline double rotation_error_rad(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
}

// Distance between two poses' positions (m).
inline double position_error_m(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm();
}

}  // namespace lander::test
