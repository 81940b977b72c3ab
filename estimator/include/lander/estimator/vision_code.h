// Close-range localisation on the target's code map (seed 001 section 3): the cell grid is
// found in the image, the cell values are read, the observed cells are placed in the globally
// unique code map (every b x b window unique, also under 90-degree rotations; target.h), and
// the platform pose X_CP follows from all matched grid corners by planar PnP.
//
// Pipeline (seed 001 uses Canny + Hough lines and the four corners of one 5 x 5 window; we
// use the same grid idea with more points, so partial and tilted views work):
//  1. adaptive threshold, contours of the dark cells, polygon vertices (grid corners) and
//     polygon sides (grid line segments);
//  2. the sides split into two line families; their vanishing points give an affine
//     rectification in which the grid is a lattice; vertices get lattice labels, then a
//     homography lattice -> image is fitted and iterated (inliers relabelled);
//  3. every lattice cell in view is read (mean grey of its inner half, two-class threshold);
//  4. all 4 rotations x all offsets of the read cells in the map are scored over every read
//     cell (consistency of all neighbours, not one window); the best placement must contain a
//     full b x b window, have almost no disagreeing cell and beat the runner-up clearly;
//  5. every map corner with an L or X pattern is refined to sub-pixel (cv::cornerSubPix) and
//     the pose comes from IPPE + cv::solvePnPRefineLM, with a covariance from the Jacobian.
// All geometry after the contour stage is in undistorted pixels of the pinhole K.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "lander/estimator/target.h"
#include "lander/core/types.h"
#include "lander/estimator/vision_params.h"

namespace lander {

// Where a set of read cells lies in the code map.
struct CodePlacement {
  bool found{false};
  int rotation{0};       ///< quarter turns q: map (col, row) = rot_q(a, b) + offset
  int col_offset{0}, row_offset{0};
  int compared{0};       ///< read cells compared with the map (inside it or on known background)
  int mismatched{0};     ///< of those, disagreeing cells
  int runner_up_mismatched{0};  ///< mismatches of the best other placement (-1 if none)
  bool full_window{false};      ///< the compared cells contain a full b x b window
  std::string reason;           ///< why not found
};

// One observed cell: lattice coordinates (a, b) (a along image-column-like direction, b along
// row-like, same handedness as the code map's (col, row)) and its value (1 = dark).
struct ObservedCell {
  int a{0}, b{0};
  std::uint8_t dark{0};
};

// Rotates lattice coordinates by q quarter turns: (a, b) -> (-b, a) for q = 1, etc.
Eigen::Vector2i rotate_lattice(int a, int b, int q);

// Places observed cells in the code map (step 4). Cells outside the map but inside the
// central ring's inner circle are known background (light) and are compared too.
CodePlacement place_code_cells(const std::vector<ObservedCell>& cells, const TargetGeometry& g,
                               const std::vector<std::uint8_t>& map, const VisionParams& p);

struct CodeDetection {
  bool detected{false};
  std::string reason;  ///< why not (or a summary)
  Eigen::Isometry3d X_CP{Eigen::Isometry3d::Identity()};  ///< platform pose in camera frame
  /// Covariance of [rotation vector of R_CP (rad); p_CP (m)], sigma^2 (J^T J)^-1.
  Eigen::Matrix<double, 6, 6> cov{Eigen::Matrix<double, 6, 6>::Identity()};
  CodePlacement placement;
  int cells_read{0};                ///< lattice cells read (dark or light)
  bool local_white{false};          ///< placed with the cells read against their local white
                                    ///< (a shadow across the code; code_local_white)
  double cell_px{0.0};              ///< median cell side in the image (px)
  std::vector<Eigen::Vector2d> corners_px;   ///< matched sub-pixel corners (undistorted px)
  std::vector<Eigen::Vector2d> corners_P_m;  ///< the same corners in P (m), z = 0
  double reproj_rms_px{0.0};        ///< RMS corner reprojection error after refinement (px)
  double reproj_gate_px{0.0};       ///< the corner gate it was held to (px): the larger of
                                    ///< code_max_reproj_px and code_max_reproj_fraction x the
                                    ///< corners' RMS spread
};

// Runs steps 1-5 on an 8-bit grey frame of `camera`'s size. Never throws for image content.
// `X_CP_prior` (optional: a pose from the rings or a track) predicts the directions of the
// map's grid lines, so that straight clutter is not taken for them.
CodeDetection detect_code_pattern(const cv::Mat& grey, const CameraModel& camera,
                                  const TargetGeometry& target, const VisionParams& p,
                                  const Eigen::Isometry3d* X_CP_prior = nullptr);

// The same, searching only `region` of the frame (clipped to it): for a frame whose pose is
// known, around the code map's projection. The threshold is the whole frame's wherever its
// block lies inside the region; corners_px are in the frame's pixels. `X_CP_prior` (that
// pose, optional) predicts the directions of the map's grid lines, so that straight clutter
// in the region is not taken for them.
CodeDetection detect_code_pattern(const cv::Mat& grey, const CameraModel& camera,
                                  const TargetGeometry& target, const VisionParams& p,
                                  const cv::Rect& region,
                                  const Eigen::Isometry3d* X_CP_prior = nullptr);

}  // namespace lander
