// Internal stages of the ring detector (not part of the public API).
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "lander/estimator/types.h"
#include "lander/estimator/vision_conic.h"
#include "lander/estimator/vision_params.h"

namespace lander::vision_internal {

// An ellipse candidate with its sub-pixel edge points.
struct EllipseCandidate {
  Conic C;                              ///< in undistorted px
  EllipseParams image;                  ///< in raw image px
  EllipseParams undist;                 ///< in undistorted px
  std::vector<Eigen::Vector2d> points;  ///< sub-pixel edge points, undistorted px
  double fit_rms_px{0.0};
};

// Stage 1-2: contours of `grey` inside `roi` -> sub-pixel ellipses (image-wide coordinates).
// `grey` is the full 8-bit frame.
std::vector<EllipseCandidate> find_ellipses(const cv::Mat& grey, const cv::Rect& roi,
                                            const CameraModel& cam, const VisionParams& p);

// Stage 5b: Levenberg-Marquardt on the conic reprojection cost (seed 000 eq. 14-15).
struct ConicObservation {
  Eigen::Vector2d c_P_m;                ///< circle centre in P (m)
  double r_m;                           ///< circle radius (m)
  const std::vector<Eigen::Vector2d>* points;  ///< edge points (undistorted px)
};
struct RefineResult {
  bool ok{false};
  Eigen::Isometry3d X_CP{Eigen::Isometry3d::Identity()};
  Eigen::Matrix<double, 6, 6> cov{Eigen::Matrix<double, 6, 6>::Identity()};
  double rms_px{0.0};
  int iterations{0};
};
RefineResult refine_pose_conics(const Eigen::Matrix3d& K, const Eigen::Isometry3d& X_CP0,
                                const std::vector<ConicObservation>& obs, int points_per_ellipse,
                                int max_iter);

}  // namespace lander::vision_internal
