// CameraModel as OpenCV's camera matrix and distortion coefficients (k1, k2, p1, p2, k3), for
// the cv:: calls that take them (projectPoints, undistortPoints, solvePnP, ...).
#pragma once

#include <opencv2/core.hpp>

#include "lander/estimator/types.h"

namespace lander {

inline cv::Mat camera_matrix_cv(const CameraModel& c) {
  return (cv::Mat_<double>(3, 3) << c.fx_px, 0, c.cx_px, 0, c.fy_px, c.cy_px, 0, 0, 1);
}

inline cv::Mat dist_coeffs_cv(const CameraModel& c) {
  return (cv::Mat_<double>(1, 5) << c.k1, c.k2, c.p1, c.p2, c.k3);
}

}  // namespace lander
