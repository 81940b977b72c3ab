// CameraModel as OpenCV's camera matrix and distortion coefficients (k1, k2, p1, p2, k3), for
// the cv:: calls that take them (projectPoints, undistortPoints, solvePnP, ...), and a pose
// from what solvePnP returns.
#pragma once

#include <algorithm>
#include <vector>

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

// The image's border as camera rays at unit depth (x, y, 1), undistorted with the
// calibration (the border bows under distortion): kBorderSamples points an edge. Depends on
// the camera alone: computed once per camera.
inline std::vector<Eigen::Vector3d> image_border_rays(const CameraModel& cam) {
  constexpr int kBorderSamples = 9;
  const double W = cam.width_px - 1.0, H = cam.height_px - 1.0;
  std::vector<cv::Point2d> border;
  for (int i = 0; i < kBorderSamples; ++i) {
    const double s = static_cast<double>(i) / (kBorderSamples - 1);
    border.insert(border.end(), {{s * W, 0.0}, {s * W, H}, {0.0, s * H}, {W, s * H}});
  }
  std::vector<cv::Point2d> undistorted;
  cv::undistortPoints(border, undistorted, camera_matrix_cv(cam), dist_coeffs_cv(cam));
  std::vector<Eigen::Vector3d> rays;
  rays.reserve(undistorted.size());
  for (const cv::Point2d& r : undistorted) rays.emplace_back(r.x, r.y, 1.0);
  return rays;
}

// The least depth along the optical axis (m) at which a horizontal plane `height_m` below the
// camera appears in its image, the camera at R_WC (W's z up): over a plane the depth of a
// pixel's point is height_m over its ray's downward component (the ray at unit depth). That
// component is linear in the undistorted pixel, so its largest value over the image is on the
// image's border (`border_rays`, image_border_rays()). 0 when height_m is not positive or the
// plane is not in view.
inline double least_plane_depth_m(const std::vector<Eigen::Vector3d>& border_rays, const Eigen::Matrix3d& R_WC,
                                  double height_m) {
  if (!(height_m > 0.0)) return 0.0;
  double max_down = 0.0;
  for (const Eigen::Vector3d& r : border_rays) max_down = std::max(max_down, -(R_WC * r).z());
  return max_down > 0.0 ? height_m / max_down : 0.0;
}

// The same for a camera whose border rays are not kept.
inline double least_plane_depth_m(const CameraModel& cam, const Eigen::Matrix3d& R_WC, double height_m) {
  return least_plane_depth_m(image_border_rays(cam), R_WC, height_m);
}

}  // namespace lander
