// Synthetic camera frames of the ring target drawn with exact projective geometry, for the
// vision tests: the texture of render_target_texture() warped by the homography
// K [r1 r2 t] composed with the texture -> platform map, supersampled and box-filtered, so
// the true projected centres (K X_CP c_P) and the true pose are known exactly.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "common/pose_errors.h"
#include "lander/estimator/target.h"
#include "lander/core/types.h"

namespace lander::test {

// models/target.yaml, loaded once.
const TargetGeometry& default_target();

// Pose X_CP of a camera looking at the point `aim_P_m` of the platform plane from height
// `altitude_m` above the plane, its optical axis tilted `tilt_deg` from the platform normal
// (towards azimuth `azimuth_deg` in P), rotated `yaw_deg` about its optical axis.
Eigen::Isometry3d look_at_pose(double altitude_m, double tilt_deg, double yaw_deg,
                               double azimuth_deg = 0.0,
                               const Eigen::Vector2d& aim_P_m = Eigen::Vector2d::Zero());

// A hard shadow band on the platform plane (a directional sun's shadow of a straight
// occluder, e.g. a vehicle arm or the cart's frame): the points q of the plane (P, m) with
// |q . n - offset_m| < width_m / 2, n = (cos angle_deg, sin angle_deg), receive `light` times
// the light. Applied to the supersampled view before blur and noise, ground included.
struct ShadowBand {
  double width_m{0.2};     ///< band width on the plane (m)
  double light{0.2};       ///< light left in the band (0..1): 0.2 = a hard shadow at 20 %
  double angle_deg{0.0};   ///< direction of the band's normal in P (deg from +x)
  double offset_m{0.0};    ///< signed distance of the band's centre line from the P origin (m)
};

// An uneven light across the platform plane (a cloud's edge, a lamp, the sun low behind the
// vehicle): the light falls linearly along the direction n = (cos angle_deg, sin angle_deg)
// from 1 at q . n = -half_width_m to `min_light` at q . n = +half_width_m (held beyond both
// ends). Applied with the shadow bands, ground included. min_light = 1: none.
struct LightRamp {
  double angle_deg{0.0};
  double half_width_m{0.9};
  double min_light{1.0};
};

struct SynthOptions {
  int supersample{3};          ///< samples per pixel side (box filter)
  double ground_grey{0.45};    ///< grey level outside the platform (0..1)
  double noise_sigma{0.0};     ///< additive Gaussian noise (grey levels of 255)
  double blur_px{0.0};         ///< linear motion-blur length (px), 0 = none
  double blur_angle_deg{0.0};  ///< motion direction in the image (deg from +u)
  std::uint64_t seed{1};       ///< noise seed
  bool bgr{true};              ///< 3-channel output (else grey)
  std::vector<ShadowBand> shadows;  ///< shadow bands on the plane (none by default)
  LightRamp light_ramp;             ///< uneven light on the plane (none by default)
};

// The ring sets (ids) whose outer circle a shadow band's edge crosses: the sets a band
// boundary cuts, where a global threshold merges shadowed white with the dark annuli.
std::vector<int> ring_sets_crossed(const TargetGeometry& g, const ShadowBand& band);

// Replaces the texture used by render_view()/render_exposure() for the target object `g`
// (by address; e.g. a copy of default_target() whose printed code was altered). BGR 8-bit,
// g.texture_px square.
void set_texture_override(const TargetGeometry& g, const cv::Mat& texture_bgr);

// The texture of default_target() with the code square rotated by 90 degrees about the
// platform centre (the rings unchanged): a platform printed with a wrong code orientation.
cv::Mat texture_with_rotated_code(const TargetGeometry& g);
// The texture with the code cells (col0..col0+w-1, row0..row0+w-1) inverted (dark <-> light).
cv::Mat texture_with_inverted_cells(const TargetGeometry& g, int col0, int row0, int w);

// A frame of `camera` (distortion applied when the model has any) seeing the target at X_CP.
cv::Mat render_view(const TargetGeometry& g, const CameraModel& camera,
                    const Eigen::Isometry3d& X_CP, const SynthOptions& opt = {});

// Motion blur as the simulator makes it: the average of frames rendered at the poses the
// camera passes through during the exposure.
cv::Mat render_exposure(const TargetGeometry& g, const CameraModel& camera,
                        const std::vector<Eigen::Isometry3d>& X_CP_during,
                        const SynthOptions& opt = {});

// True projected ring centres (undistorted px), by ring id order of g.rings.
std::vector<Eigen::Vector2d> true_centres(const TargetGeometry& g, const CameraModel& camera,
                                          const Eigen::Isometry3d& X_CP);

// Applies a linear motion blur of `length_px` along `angle_deg` (in place).
void motion_blur(cv::Mat& img, double length_px, double angle_deg);

// A 1280x720 frame of grey ground with dark and light discs and annuli whose radius ratios
// match no ring set, some of them concentric.
cv::Mat distractor_frame(const CameraModel& camera, std::uint64_t seed);

// Multiplies a straight band of the image by `light`: the pixels within width_px / 2 of the
// line through `point_px` whose normal makes `angle_deg` with +u, the band's edges
// anti-aliased (coverage of each pixel's box). For frames not drawn through the platform plane
// (distractor_frame()).
void apply_image_band(cv::Mat& img, const Eigen::Vector2d& point_px, double angle_deg,
                      double width_px, double light);

// rotation_error_rad() and position_error_m(): common/pose_errors.h.

}  // namespace lander::test
