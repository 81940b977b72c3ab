// Ring-target pose estimator (seed 000 section 2): one camera frame + the target geometry +
// the camera calibration -> the platform pose X_CP, or the reason there is none.
//
// Pipeline (each stage cites the seed's equation it implements):
//  1. grey, Gaussian, Otsu (or adaptive) threshold, [Canny], morphological close, contours;
//  2. per contour: ellipse, then sub-pixel edge points along the normal (mid-level crossing of
//     the grey profile), undistorted (cv::undistortPoints) and refitted (least squares);
//  3. concentric pairs by eq. (1); projected centre by the harmonic-ratio recursion eq. (2)-(8);
//  4. ring identity by the cross-ratio eq. (9), non-matching curves rejected;
//  5. initial pose by IPPE (planar PnP), then Levenberg-Marquardt (Ceres) on the conic
//     reprojection cost eq. (14)-(15) over every identified ellipse, with a covariance;
//  6. keyframe selection eq. (17)-(18); reprojection error eq. (30).
// Close range (RingDetection::source says which observations gave the pose):
//  7. the code map (seed 001, vision_code.h) is searched whenever its cells can be read
//     (no ring pose, or a ring/tracked pose putting the 2.5 cm cells at >= code_min_cell_px);
//  8. with fewer than min_rings sets but the central pair identified: normal, centre and
//     depth in closed form from the pair (pole-polar of the projected centre), yaw from
//     another identified set, else the code, else the tracked pose (as a prior), then the
//     conic cost over every identified ellipse (plus the code corners when they agree);
//  9. with >= min_rings sets and the code: conics and code corners refined together if the
//     two poses agree (combine_max_*), else the ring pose alone (reason says so).
// All image geometry after step 2 is in undistorted pixels of the pinhole K.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "lander/core/state.h"
#include "lander/estimator/target.h"
#include "lander/core/types.h"
#include "lander/estimator/vision_code.h"
#include "lander/estimator/vision_conic.h"
#include "lander/estimator/vision_params.h"

namespace lander {

// Why a frame gave no pose (Detected when it did).
enum class VisionStatus {
  Detected,
  EmptyImage,           ///< no pixels
  UnsupportedImage,     ///< pixel type other than 8/16-bit, 1/3/4 channels
  ImageSizeMismatch,    ///< image size differs from the camera calibration
  NoEllipses,           ///< no contour passed the ellipse tests
  NoConcentricPairs,    ///< ellipses, but no concentric pair (eq. 1)
  NoRingIdentified,     ///< pairs, but no cross-ratio (eq. 9) matched a ring set
  TooFewRings,          ///< fewer identified ring sets than params.min_rings
  PoseFailed,           ///< PnP or refinement failed, or centres inconsistent with the layout
  ReprojectionTooLarge  ///< pose found but eq. (30) or the conic residual exceeds its gate
};
const char* to_string(VisionStatus s);

enum class KeyframeStatus {
  NotDetected,  ///< no pose in this frame
  First,        ///< no previous keyframe: accepted
  Accepted,     ///< rho <= rho_max (eq. 18)
  Rejected,     ///< rho > rho_max: unreliable (e.g. motion blur), reported, not used
  Restarted     ///< accepted after keyframe_reset_after consecutive rejections
};
const char* to_string(KeyframeStatus s);

// Which observations gave the pose of a detection.
enum class PoseSource {
  None,        ///< no pose
  Rings,       ///< >= min_rings identified ring sets (IPPE + conic refinement, seed 000)
  CentreRing,  ///< the central set's concentric pair (closed-form normal and centre) with
               ///< the yaw from another set or the tracked pose, refined on the conics
  Code,        ///< the code map alone (seed 001, vision_code.h)
  Combined     ///< ring conics and code corners refined together
};
const char* to_string(PoseSource s);

// One fitted ellipse (for overlays and diagnostics).
struct DetectedEllipse {
  Conic C;                 ///< conic in undistorted pixels (interior negative)
  EllipseParams image;     ///< ellipse in raw image pixels (before undistortion)
  int ring_id{-1};         ///< ring set it belongs to, -1 = unidentified
  bool outer{false};       ///< outer circle of its ring set
  double fit_rms_px{0.0};  ///< RMS Sampson distance of its sub-pixel edge points
};

// One identified ring-set centre.
struct IdentifiedCentre {
  int ring_id{-1};
  Eigen::Vector2d centre_px{Eigen::Vector2d::Zero()};        ///< undistorted px (eq. 2-8)
  Eigen::Vector2d centre_image_px{Eigen::Vector2d::Zero()};  ///< raw image px (distorted)
  double radius_ratio{0.0};  ///< measured r/R from the cross-ratio (eq. 9)
  int outer_index{-1}, inner_index{-1};  ///< into RingDetection::ellipses
  int harmonic_iterations{0};
};

struct RingDetection {
  bool detected{false};
  VisionStatus status{VisionStatus::EmptyImage};
  std::string reason;  ///< human-readable why (or a summary when detected)
  PoseSource source{PoseSource::None};  ///< which observations gave X_CP

  // Code-map result (seed 001) when the code was searched: code.detected, its own pose,
  // cells and corners; code.reason says why not. code_searched is false when the ring pose
  // showed the code cells too small to read.
  bool code_searched{false};
  CodeDetection code;
  /// Where the code was searched: around its projection from this frame's ring pose or the
  /// track (the region of the frame the result comes from), empty for the whole frame.
  cv::Rect code_region;

  Eigen::Isometry3d X_CP{Eigen::Isometry3d::Identity()};  ///< platform pose in camera frame
  /// Covariance of [angle-axis of R_CP (rad); p_CP (m)] from the conic-cost Jacobian,
  /// scaled by the residual variance.
  Eigen::Matrix<double, 6, 6> cov{Eigen::Matrix<double, 6, 6>::Identity()};
  std::vector<IdentifiedCentre> centres;
  std::vector<DetectedEllipse> ellipses;
  double reproj_err_px{0.0};        ///< sqrt(eq. 30 / N): RMS centre reprojection error (px);
                                    ///< for a code-only pose the RMS corner error (px)
  double reproj_err_sum_px2{0.0};   ///< eq. (30) as written: sum of squared errors (px^2)
  double edge_rms_px{0.0};          ///< RMS conic-cost residual after refinement (px)
  /// The gates this pose passed (px): max_reproj_err_px and max_edge_residual_px, each grown
  /// with the sets' extent in the image by max_reproj_fraction; for a code-only pose the code's
  /// corner gate (and 0 for the conic one). reproj_err_px <= reproj_gate_px for every pose.
  /// Without a pose: the gates the last pose tried failed (0 when none was tried).
  double reproj_gate_px{0.0};
  double edge_gate_px{0.0};
  int refine_iterations{0};

  bool keyframe{false};
  KeyframeStatus keyframe_status{KeyframeStatus::NotDetected};
  double rho{0.0};  ///< eq. (18) against the last keyframe (0 for the first)

  bool used_roi{false};          ///< found in the predicted region (tracking)
  /// The rings' full-frame passes (or those after the whole frame's global segmentation) were
  /// not run: close range, the code map gave the pose, searched first because the track showed
  /// no ring set wholly in the frame, or because the global segmentation gave no pose under a
  /// track with readable code cells (code_first_close_range).
  bool rings_skipped{false};
  bool deblurred{false};         ///< the pose came from the frame deconvolved for the
                                 ///< predicted blur (detect()'s blur_px)
  bool unfiltered{false};        ///< the pose came from the unfiltered pass (no Gaussian
                                 ///< pre-filter: small, far or grazing ring sets)
  bool zoomed{false};            ///< the pose came from the zoomed pass (a small target's
                                 ///< region magnified twice)
  bool by_layout{false};         ///< its ring sets were identified by the layout
                                 ///< (vision_layout.h), not ratio by ratio
  bool by_platform{false};       ///< the pose came from the platform pass (the sets' places
                                 ///< predicted from the platform top's outline)
  cv::Rect roi;                  ///< region searched last (full frame if no ROI)
  double time_ms{0.0};           ///< wall time of detect() (ms)
  /// Where detect()'s wall time went (ms): the predicted region, the rings' fallback passes,
  /// the code map, and the poses combined and checked (tracking and keyframe included).
  struct StageTimes {
    double region_ms{0.0}, passes_ms{0.0}, code_ms{0.0}, checks_ms{0.0};
    StageTimes& operator+=(const StageTimes& o) {
      region_ms += o.region_ms;
      passes_ms += o.passes_ms;
      code_ms += o.code_ms;
      checks_ms += o.checks_ms;
      return *this;
    }
  } stage_ms;
};

// Reliability of a new pose against the last keyframe, seed 000 eq. (17)-(18):
// P = [rotation vector of R_CP; p_CP], I = P / |P|, rho = 1 - |I_old . I_new|.
double keyframe_rho(const Eigen::Isometry3d& X_CP_old, const Eigen::Isometry3d& X_CP_new);

// Single frame, no tracking, no keyframe history (keyframe_status First when detected).
// `blur_px`: as RingTargetDetector::detect().
RingDetection detect_ring_target(const cv::Mat& image, const CameraModel& camera,
                                 const TargetGeometry& target, const VisionParams& params,
                                 const Eigen::Vector2d& blur_px = Eigen::Vector2d::Zero());

// Stateful estimator for an image stream: tracking ROI and keyframe history.
class RingTargetDetector {
 public:
  // Throws ConfigError if the camera, target or params are invalid.
  RingTargetDetector(CameraModel camera, TargetGeometry target, VisionParams params = {});

  // Processes one frame (BGR/BGRA/grey, 8 or 16 bit). Never throws for bad image content.
  // `blur_px`: the image motion the caller predicts over the frame's exposure (px, x right,
  // y down; the blur's length and direction, e.g. from the vehicle's rates and velocity and
  // the exposure time), zero when unknown. When the plain passes give no pose and the blur is
  // at least deblur_min_px, the frame is searched again deconvolved with it.
  // `min_depth_m`: the least depth along the optical axis at which the target's plane can be
  // in this frame (m), from the caller's own height and attitude estimate; 0 when unknown.
  // Without a pose or a track, the code map is not searched where its cells would be smaller
  // than code_min_cell_px at that depth (it cannot be read there).
  RingDetection detect(const cv::Mat& image, const Eigen::Vector2d& blur_px = Eigen::Vector2d::Zero(),
                       double min_depth_m = 0.0);
  // Forgets the prediction and the last keyframe.
  void reset();

  const CameraModel& camera() const { return camera_; }
  const TargetGeometry& target() const { return target_; }
  const VisionParams& params() const { return params_; }

 private:
  CameraModel camera_;
  TargetGeometry target_;
  VisionParams params_;
  bool have_prediction_{false};
  Eigen::Isometry3d X_CP_pred_{Eigen::Isometry3d::Identity()};
  int misses_{0};
  bool have_keyframe_{false};
  Eigen::Isometry3d X_CP_key_{Eigen::Isometry3d::Identity()};
  int rejections_{0};
};

// The controller's view of a detection (state.h), stamped with the frame's mid-exposure time.
PlatformObservation to_platform_observation(const RingDetection& d, double t_s);

// The detection as a JSON object (pose as p_CP_m and q_CP_wxyz, centres, ellipses, ...).
std::string to_json(const RingDetection& d);

// Loads a camera calibration YAML (the CameraModel keys at the top level, e.g.
// models/camera_default.yaml); throws ConfigError naming the file and field.
CameraModel load_camera_model(const std::string& path);

}  // namespace lander
