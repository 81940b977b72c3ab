// Vision altitude (seed 004 sec. 2.2.3): height of the camera above the target plane from the
// image length of a known target dimension, and from a full target pose.
#pragma once

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "lander/core/types.h"

namespace lander {

// Seed 004 eq. 7: h = f L / l cos(theta) cos(phi).
//   f_px      focal length (px), L_m physical length of the target feature (m),
//   l_px      its length in the image (px), pitch_rad theta and roll_rad phi of the body.
// Eq. 6 (h = f L / l) is the pinhole range along the optical axis for a fronto-parallel
// target; the cosines project it onto the vertical for a tilted vehicle. Throws
// std::invalid_argument for non-positive f, L or l.
inline double vision_altitude_m(double f_px, double L_m, double l_px, double pitch_rad,
                                double roll_rad) {
  if (!(f_px > 0) || !(L_m > 0) || !(l_px > 0)) {
    throw std::invalid_argument("vision_altitude_m: f_px, L_m and l_px must be > 0");
  }
  return f_px * L_m / l_px * std::cos(pitch_rad) * std::cos(roll_rad);  // eq. 7
}

// Height of B's origin above the target plane from the ring-target pose X_CP (platform in
// camera, e.g. PlatformObservation::X_CP) and the camera mount X_BC: the z coordinate of B in
// P, X_PB = X_CP^-1 X_BC^-1. Exact for any attitude; P's z is the plane normal.
inline double height_above_target_m(const Eigen::Isometry3d& X_CP, const Eigen::Isometry3d& X_BC) {
  const Eigen::Isometry3d X_PB = X_CP.inverse() * X_BC.inverse();
  return X_PB.translation().z();
}

// Roll phi and pitch theta (rad) of q_WB in the z-y-x (yaw-pitch-roll) convention, for eq. 7.
inline void roll_pitch_rad(const Eigen::Quaterniond& q_WB, double* roll, double* pitch) {
  const Eigen::Vector3d rpy = rpy_from_R(q_WB.toRotationMatrix());
  *roll = rpy.x();
  *pitch = rpy.y();
}

}  // namespace lander
