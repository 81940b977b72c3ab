// Internal stages of the ring detector (not part of the public API).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "lander/estimator/target.h"
#include "lander/core/types.h"
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
  bool two_lights{false};               ///< its edge profiles show two illuminations (a
                                        ///< shadow's edge crosses it)
};

// Stage 1-2: contours of `grey` inside `roi` -> sub-pixel ellipses (image-wide coordinates).
// `grey` is the full 8-bit frame.
// `blurred_out`, if given, receives the pre-filtered ROI for refine_candidate().
// `shadow`: the shadow-tolerant segmentation (contours at the levels p.shadow_levels of the
// white reference, edge levels per illumination) instead of the global one.
std::vector<EllipseCandidate> find_ellipses(const cv::Mat& grey, const cv::Rect& roi,
                                            const CameraModel& cam, const VisionParams& p,
                                            cv::Mat* blurred_out = nullptr, bool shadow = false);

// Sub-pixel edge points around the ellipse guess `e0` (raw image px) searched within
// +-search_px along the normals, refitted; nullopt if too few edges or a poor fit.
// `blurred` is the pre-filtered ROI whose origin is `off` in the full image.
// `split_light`: edge levels per illumination where a shadow's edge crosses the ellipse.
std::optional<EllipseCandidate> refine_candidate(const cv::Mat& blurred, const cv::Point2f& off,
                                                 const EllipseParams& e0, double search_px,
                                                 const CameraModel& cam, const VisionParams& p,
                                                 bool split_light = false);

// The brightest grey level that at least `pixels` pixels of the 8-bit `grey` reach (a white
// reference: the shadow pass's 99.5th percentile, the platform pass's brightest small area).
int bright_level(const cv::Mat& grey, double pixels);

// Sub-pixel ellipses from guesses instead of contours: `roi` of `grey` pre-filtered as
// find_ellipses does (into `blurred_out`), each guess (raw image px) refined by
// refine_candidate within +-search_px, duplicates dropped.
std::vector<EllipseCandidate> refine_guesses(const cv::Mat& grey, const cv::Rect& roi,
                                             const std::vector<EllipseParams>& guesses,
                                             double search_px, const CameraModel& cam,
                                             const VisionParams& p, cv::Mat* blurred_out);

// The platform pass (platform.cpp; issue 12: far and grazing views). A bright convex
// quadrilateral that may be the platform's top: corners in raw image px, in cyclic order.
struct PlatformQuad {
  std::array<Eigen::Vector2d, 4> corners;
  double area{0.0};  ///< its contour's area (px^2)
};
// The frame's bright quadrilaterals (largest first, at most p.platform_max_quads).
std::vector<PlatformQuad> platform_quads(const cv::Mat& grey, const VisionParams& p);
// The ring sets' outer circles (and the central set's inner circle) predicted through the
// homography of `q` to the top's corners, for `placement` 0 or 1 (the hexagon's two possible
// places in a square seen up to its turns), as ellipses in raw image px.
std::vector<EllipseParams> platform_set_guesses(const PlatformQuad& q, int placement,
                                                const CameraModel& cam,
                                                const TargetGeometry& target);
// What the platform pass hands the ring search: the guessed ellipses and the outline.
struct PlatformGuesses {
  std::vector<EllipseParams> ellipses;
  PlatformQuad quad;
};
// The largest distance (raw px) between the top's corners projected with X_CP and the
// corners of `q`, under the best pairing of the two cycles: a pose must put the top where its
// outline is (a wrong identity of the sets turns the pose by a multiple of 60 deg, which moves
// the square's corners; only the hexagon's 180 deg turn keeps them).
double platform_corner_error_px(const PlatformQuad& q, const Eigen::Isometry3d& X_CP,
                                const CameraModel& cam, const TargetGeometry& target);
// The largest corner error (platform_corner_error_px) a platform-pass pose may have on `q`.
double platform_corner_gate_px(const PlatformQuad& q);

// The ring identities checked on the outer sets' radial profiles (rotation_check.cpp): the
// pose's own identities against every turn of the layout that maps it onto itself.
struct RotationCheck {
  bool checked{false};  ///< enough outer sets wholly in view to compare
  bool passed{true};    ///< not checked, or the pose's own identities fit best by the margin
  int discs{0};         ///< outer sets wholly in view
  std::string verdict;  ///< the scores, for the detection's reason
};
// Bilinear grey value of the 8-bit image `g` at (x, y), clamped to the image (code.cpp).
double bilinear(const cv::Mat& g, double x, double y);
// `grey_of(r)`: the frame's 8-bit grey, converted at least in r (full-frame coordinates).
RotationCheck check_set_rotation(const cv::Size& frame,
                                 const std::function<cv::Mat(const cv::Rect&)>& grey_of,
                                 const CameraModel& cam, const TargetGeometry& g,
                                 const Eigen::Isometry3d& X_CP, double margin);

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
// Point correspondences (code-map corners) refined together with the conics: residual is the
// reprojection error (px) of the P point c_P_m against the undistorted pixel px.
struct PointObservation {
  Eigen::Vector2d c_P_m;
  Eigen::Vector2d px;
};
// Prior on the rotation about the platform normal (yaw) when nothing else fixes it (a lone
// concentric pair): residual = (yaw offset from R_prior, rad) / sigma_rad, in units of one
// pixel of the other residuals.
struct YawPrior {
  Eigen::Matrix3d R_CP;
  double sigma_rad{0.05};
};
// Otsu's two-class split of values sorted ascending: the first k in [1, n) maximising the
// between-class variance k (n - k) (m_lo - m_hi)^2, with the two classes' means. k = -1 when
// n < 2.
struct OtsuSplit {
  int k{-1};
  double mean_lo{0.0}, mean_hi{0.0};
};
OtsuSplit otsu_split_sorted(const std::vector<double>& sorted);

// A computed pixel or lattice coordinate as an int, or nullopt when it is not finite or lies
// beyond +-kMaxIntCoord: a degenerate homography or pose (hostile images do make them) can
// send a point anywhere, and converting such a double to int is undefined behaviour.
constexpr double kMaxIntCoord = 16777216.0;  // 2^24: far outside any image, exact in double
// The 8-bit grey frame `grey` deconvolved (Wiener) with a motion blur that moved the image by
// `blur_px` over the exposure (a uniform line PSF centred on the frame's mid-exposure
// position): G conj(H) / (|H|^2 + k), computed with one DFT of the frame (edges replicated).
cv::Mat wiener_deblur(const cv::Mat& grey, const Eigen::Vector2d& blur_px, double k);

// The camera of `region` magnified `s` times: pixel centres at integers in both images, so
// u_zoom = s (u - x0 + 0.5) - 0.5; the distortion acts on normalised coordinates and stays.
inline CameraModel zoomed_camera(const CameraModel& cam, const cv::Rect& region, int s) {
  CameraModel z = cam;
  z.width_px = region.width * s;
  z.height_px = region.height * s;
  z.fx_px = cam.fx_px * s;
  z.fy_px = cam.fy_px * s;
  z.cx_px = s * (cam.cx_px - region.x + 0.5) - 0.5;
  z.cy_px = s * (cam.cy_px - region.y + 0.5) - 0.5;
  return z;
}

inline std::optional<int> to_int_coord(double v) {
  if (!(std::abs(v) <= kMaxIntCoord)) return std::nullopt;  // also false for NaN
  return static_cast<int>(v);
}
// v limited to [-kMaxIntCoord, kMaxIntCoord], NaN to -kMaxIntCoord (for clamped lookups).
inline double clamp_coord(double v) {
  return v >= -kMaxIntCoord ? std::min(v, kMaxIntCoord) : -kMaxIntCoord;
}

// The gates that grow with the target's size in the image (issue 10/12: one rule for every pose
// source). A relative calibration error (pixel aspect, focal length, distortion) stretches the
// image about the principal point, and the residual no pose explains grows in proportion to
// the target's extent in the frame: a gate in absolute pixels refuses exactly the close views
// the landing needs. Each gate is the larger of its absolute value and fraction x extent.
inline double scaled_gate(double absolute_px, double fraction, double extent_px) {
  return std::max(absolute_px, fraction * extent_px);
}
// The ring path's two acceptance gates for ring sets of `extent_px` (ring_extent_px): the
// centres' reprojection RMS (max_reproj_err_px) and the conic residual (max_edge_residual_px),
// each grown by max_reproj_fraction.
struct RingGates {
  double reproj_px, edge_px;
};
inline RingGates ring_gates(const VisionParams& p, double extent_px) {
  return {scaled_gate(p.max_reproj_err_px, p.max_reproj_fraction, extent_px),
          scaled_gate(p.max_edge_residual_px, p.max_reproj_fraction, extent_px)};
}
// One ring set's image for ring_extent_px(): its centre and its outer circle's semi-axes (px).
struct SetImage {
  Eigen::Vector2d centre;
  double a{0.0}, b{0.0};
};
// The ring sets' extent in the image: the RMS distance of their outer circles' points from the
// centres' centroid, sqrt(mean |c_i - c|^2 + mean (a_i^2 + b_i^2) / 2) (px). A lone central
// pair has the extent of its outer circle; seven sets at 2 m about 200 px.
inline double ring_extent_px(const std::vector<SetImage>& sets) {
  if (sets.empty()) return 0.0;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& s : sets) mean += s.centre;
  mean /= static_cast<double>(sets.size());
  double sum = 0.0;
  for (const auto& s : sets) sum += (s.centre - mean).squaredNorm() + 0.5 * (s.a * s.a + s.b * s.b);
  const double e = std::sqrt(sum / static_cast<double>(sets.size()));
  return std::isfinite(e) ? e : 0.0;
}

RefineResult refine_pose_conics(const Eigen::Matrix3d& K, const Eigen::Isometry3d& X_CP0,
                                const std::vector<ConicObservation>& obs, int points_per_ellipse,
                                int max_iter,
                                const std::vector<PointObservation>* points = nullptr,
                                const YawPrior* yaw_prior = nullptr);

}  // namespace lander::vision_internal
