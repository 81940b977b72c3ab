// Peer fiducial detectors for the side-by-side benchmark of issue 3 (seed 000 Table 1):
// AprilTag tag36h11 (libapriltag 3.3) and OpenCV 4.6 ArUco, each followed by
// cv::solvePnP(SOLVEPNP_IPPE_SQUARE); the marker textures they are rendered from; and a
// synthetic platform view (exact homography warp) for tests and renderer-free runs.
//
// Marker layout (both markers): a 12 x 12 cell grid filling the platform texture (the same
// outer size as the ring target's texture); the black-bordered marker is the central 8 x 8
// cells (tag36h11: 6 x 6 data cells + 1 black border cell; ArUco DICT_6X6_250 the same),
// surrounded by a white margin of two cells, which ArUco needs to detect reliably.
// With the 1.8 m platform: 0.15 m cells, a 1.2 m black square centred on the P origin.
#pragma once

#include <array>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "lander/estimator/target.h"
#include "lander/core/types.h"

namespace lander::bench {

enum class MarkerKind { Rings, AprilTag, Aruco };
const char* to_string(MarkerKind k);

constexpr int kMarkerGridCells = 12;    ///< texture side in cells
constexpr int kMarkerBlackCells = 8;    ///< black square side in cells
constexpr int kMarkerId = 0;            ///< id drawn and expected

// Side of the black square (m) for a platform texture of `g`'s size.
double marker_side_m(const TargetGeometry& g);

// Corners of the black square in P (m), in the order of cv::SOLVEPNP_IPPE_SQUARE and of ArUco:
// (-s/2, +s/2), (+s/2, +s/2), (+s/2, -s/2), (-s/2, -s/2) (texture top-left first, clockwise
// as seen in the texture).
std::array<Eigen::Vector2d, 4> marker_corners_P(const TargetGeometry& g);

// Platform texture (BGR 8-bit, g.texture_px square, texture convention of target.h) for the
// marker kind; Rings returns render_target_texture(g). Cells drawn with exact area coverage.
cv::Mat render_marker_texture(MarkerKind kind, const TargetGeometry& g);

// One square-marker detection followed by IPPE_SQUARE.
struct PeerDetection {
  bool detected{false};
  std::string reason;
  std::array<Eigen::Vector2d, 4> corners_px{};  ///< raw image px, OpenCV convention, in
                                                ///< marker_corners_P order
  Eigen::Isometry3d X_CP{Eigen::Isometry3d::Identity()};
  double reproj_err_px{0.0};  ///< RMS corner reprojection error after PnP (eq. 30 analogue)
  double time_ms{0.0};        ///< detection + PnP wall time (one thread)
};

// AprilTag tag36h11 (libapriltag 3.3, one thread, quad_decimate 1, refine_edges on). The
// library's corners are 0.5 px off OpenCV's pixel-centre convention; this subtracts it.
class AprilTagDetector {
 public:
  AprilTagDetector();
  ~AprilTagDetector();
  AprilTagDetector(const AprilTagDetector&) = delete;
  AprilTagDetector& operator=(const AprilTagDetector&) = delete;
  PeerDetection detect(const cv::Mat& image, const CameraModel& cam, const TargetGeometry& g);

 private:
  void* td_;   // apriltag_detector_t*
  void* fam_;  // apriltag_family_t*
};

// OpenCV 4.6 ArUco DICT_6X6_250; `subpix` selects CORNER_REFINE_SUBPIX (default: none).
PeerDetection detect_aruco(const cv::Mat& image, const CameraModel& cam, const TargetGeometry& g,
                           bool subpix);

// Synthetic view of a platform texture: the texture warped by K [r1 r2 t] composed with the
// texture -> platform map (target.h), supersampled and box-filtered; outside the platform,
// uniform ground. No lens distortion. Keeps a texture pyramid to avoid aliasing at range.
class SyntheticPlatformView {
 public:
  SyntheticPlatformView(const cv::Mat& texture_bgr, const TargetGeometry& g);
  // BGR frame of `cam` (distortion ignored) with the platform at X_CP; motion blur of
  // `blur_px` along `blur_angle_deg`.
  cv::Mat render(const CameraModel& cam, const Eigen::Isometry3d& X_CP, double blur_px = 0.0,
                 double blur_angle_deg = 0.0, int supersample = 3, double ground_grey = 0.45) const;

 private:
  std::vector<cv::Mat> levels_;  // grey float pyramid
  TargetGeometry g_;
};

// Linear motion blur of `length_px` along `angle_deg` (image u axis = 0), in place.
void apply_motion_blur(cv::Mat& img, double length_px, double angle_deg);

}  // namespace lander::bench
