// CameraModel as OpenCV's camera matrix and distortion coefficients (k1, k2, p1, p2, k3), for
// the cv:: calls that take them (projectPoints, undistortPoints, solvePnP, ...), and a pose
// from what solvePnP returns.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "lander/core/types.h"

namespace lander {

inline cv::Mat camera_matrix_cv(const CameraModel& c) {
  return (cv::Mat_<double>(3, 3) << c.fx_px, 0, c.cx_px, 0, c.fy_px, c.cy_px, 0, 0, 1);
}

inline cv::Mat dist_coeffs_cv(const CameraModel& c) {
  return (cv::Mat_<double>(1, 5) << c.k1, c.k2, c.p1, c.p2, c.k3);
}

// The pose X (x_C = X x_P) of OpenCV's rotation vector and translation (solvePnP's rvec, tvec).
inline Eigen::Isometry3d pose_from_cv(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) X.linear()(r, c) = R.at<double>(r, c);
    X.translation()(r) = tvec.at<double>(r);
  }
  return X;
}

}  // namespace lander
