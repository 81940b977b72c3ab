// `lander bench estimator`: the side-by-side benchmark of issue 3 (seed 000 Table 1 on frames
// with known truth). A sweep of platform views (altitude x tilt x blur x random yaw) rendered
// with the ring target, an AprilTag and an ArUco marker of the same outer size, plus frames
// with no target in view; each method runs on its own frames; per-method metrics, overall,
// per altitude and per blur length, as JSON.
//
// The renderer is a callback, so the harness runs with the MuJoCo renderer (wired by the
// `lander bench estimator` command) or with the exact synthetic warp (tests, --synthetic).
#pragma once

#include <cstdint>
#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "lander/core/params_io.h"
#include "lander/estimator/target.h"
#include "lander/core/types.h"
#include "lander/estimator/vision_params.h"
#include "lander/bench/peer_detectors.h"

namespace lander::bench {

// Renders one BGR frame of the bench camera at X_WC (C: OpenCV camera frame, x right, y down,
// z along the optical axis) with the platform showing marker `kind`, motion-blurred by
// `blur_px` pixels (0 = sharp). Frame size = the bench camera's.
using BenchRenderFn =
    std::function<cv::Mat(const Eigen::Isometry3d& X_WC, MarkerKind kind, double blur_px)>;

// A hard shadow band on the platform plane, the shadow of a straight occluder (a vehicle arm,
// the cart's frame) in a directional sun: the plane points q (P, m) with
// |q . n - offset_m| < width_m / 2, n = (cos angle_rad, sin angle_rad), get `light` times
// the light. Multiplying that band of a rendered frame is the flat target's shadow.
struct ShadowBand {
  double width_m{0.2};     ///< band width on the platform plane (m)
  double light{0.2};       ///< light left in the band (0..1)
  double angle_rad{0.0};   ///< direction of the band's normal in P (rad from +x)
  double offset_m{0.0};    ///< signed distance of the centre line from the P origin (m)
};

// Multiplies the pixels of `img` (8-bit, any channel count) whose ray meets the platform
// plane inside `band` by band.light; pixels on the band's edges by their covered fraction
// (analytic anti-aliasing), pixels above the horizon not at all. `camera` projects (lens
// distortion included) and `X_CP` places the platform in the camera frame.
void apply_shadow_band(cv::Mat& img, const CameraModel& camera, const Eigen::Isometry3d& X_CP,
                       const ShadowBand& band);

// Ids of the ring sets whose outer circle a band edge cuts (the sets a shadow boundary crosses).
std::vector<int> ring_sets_crossed(const TargetGeometry& target, const ShadowBand& band);

// Views whose every ring set is at least this wide in the image count in the
// `rings_resolvable` group (issue 12: grazing views are judged where the rings are >= 4 px).
constexpr double kResolvablePx = 4.0;

struct EstimatorBenchParams {
  std::vector<double> altitudes_m{1.0, 2.5, 5.0, 10.0, 15.0};  ///< camera height above the top
  std::vector<double> tilts_deg{0.0, 30.0, 45.0, 60.0, 70.0, 75.0, 80.0};  ///< optical axis
                                                                           ///< vs normal
  std::vector<double> blur_px{0.0, 5.0, 12.0, 15.0};  ///< motion-blur lengths (px)
  double blur_direction_deg{0.0};  ///< direction of that blur in the image (image x = 0, y
                                   ///< down): ours is told the blur (the vehicle knows its
                                   ///< motion over the exposure: issue 12's blur-aware path),
                                   ///< the peers are not; it must match the renderer's blur
  int yaws_per_view{2};       ///< random yaws (and azimuths) per altitude/tilt/blur
  int empty_frames{1000};     ///< frames with no target in view, per method
  std::uint64_t seed{1};      ///< random yaws, empty-frame poses
  double aim_jitter_m{0.1};   ///< random offset of the aim point from the platform centre (m)
  bool view_sweep{true};      ///< run the sweep of views above (altitude x tilt x blur)
  std::string save_misses_dir;  ///< if set: each view-sweep ring frame ours misses is written
                                ///< there as view_<n>.png (n: its sweep index, `index` in
                                ///< `views`)
  std::vector<int> only_views;  ///< if not empty: only these sweep indices are rendered and
                                ///< scored (the others' random draws are still made, so an
                                ///< index names the same view as in the whole sweep)
  // ---- shadow condition (issue 12): hard shadow bands across the target ----
  bool shadow_sweep{false};   ///< run the shadow condition (`lander bench estimator` turns
                              ///< it on for the full sweep)
  std::vector<double> shadow_altitudes_m{1.5, 2.5, 5.0, 10.0};  ///< camera heights (m)
  std::vector<double> shadow_tilts_deg{0.0, 30.0, 45.0};        ///< optical axis vs normal
  std::vector<double> shadow_widths_m{0.05, 0.2, 0.5, 1.0};     ///< band widths on the plane
  std::vector<double> shadow_lights{0.2, 0.5};  ///< light left in the band (0.2 = 20 %)
  int shadow_views_per_pose{3};  ///< random yaws per altitude/tilt; each view gets every
                                 ///< width x light band at one random angle and offset
  double shadow_max_offset_m{0.6};  ///< band centre line within this of the P origin (m)
  int shadow_empty_frames{200};  ///< target-free frames with a random band, per method
  // ---- camera condition (issue 54): the seed's camera, rolling shutter and JPEG ----
  bool camera_sweep{false};   ///< run the camera condition (`lander bench estimator` turns it
                              ///< on for the full sweep)
  std::vector<double> camera_altitudes_m{1.5, 2.5, 5.0, 10.0};  ///< camera heights (m)
  std::vector<double> camera_tilts_deg{0.0, 30.0, 45.0};        ///< optical axis vs normal
  int camera_views_per_pose{3};    ///< random yaws and motions per altitude/tilt
  double camera_readout_ms{30.0};  ///< rolling shutter: first row to last row (ms)
  int camera_jpeg_quality{80};     ///< JPEG quality of the JPEG conditions
  double camera_speed_mps{2.0};    ///< the camera's speed over the platform during the readout
                                   ///< (m/s, a random direction parallel to the platform)
  double camera_rate_dps{30.0};    ///< its angular rate about a random axis (deg/s)
  int camera_bands{32};            ///< bands of rows a rolling-shutter frame is built from, each
                                   ///< rendered at its centre row's time
  void validate() const;
};

template <class V>
void visit_fields(V& v, EstimatorBenchParams& p) {
  v("altitudes_m", p.altitudes_m, range::any, "m", "camera height above the top");
  v("tilts_deg", p.tilts_deg, range::any, "deg", "optical axis vs normal");
  v("blur_px", p.blur_px, range::any, "px", "motion-blur lengths");
  v("yaws_per_view", p.yaws_per_view, range::at_least(1), "",
    "random yaws (and azimuths) per altitude/tilt/blur");
  v("empty_frames", p.empty_frames, range::non_negative, "", "frames with no target in view");
  v("seed", p.seed, range::any, "", "random yaws, empty-frame poses");
  v("aim_jitter_m", p.aim_jitter_m, range::non_negative, "m",
    "random offset of the aim point from the platform centre");
  v("view_sweep", p.view_sweep, range::any, "",
    "run the sweep of views above (altitude x tilt x blur)");
  v("shadow_sweep", p.shadow_sweep, range::any, "", "run the shadow condition");
  v("shadow_altitudes_m", p.shadow_altitudes_m, range::any, "m", "camera heights");
  v("shadow_tilts_deg", p.shadow_tilts_deg, range::any, "deg", "optical axis vs normal");
  v("shadow_widths_m", p.shadow_widths_m, range::any, "m", "band widths on the plane");
  v("shadow_lights", p.shadow_lights, range::any, "", "light left in the band (0.2 = 20 %)");
  v("shadow_views_per_pose", p.shadow_views_per_pose, range::at_least(1), "",
    "random yaws per altitude/tilt");
  v("shadow_max_offset_m", p.shadow_max_offset_m, range::non_negative, "m",
    "band centre line within this of the P origin");
  v("shadow_empty_frames", p.shadow_empty_frames, range::non_negative, "",
    "target-free frames with a random band");
  v("camera_sweep", p.camera_sweep, range::any, "", "run the camera condition");
  v("camera_altitudes_m", p.camera_altitudes_m, range::any, "m", "camera heights");
  v("camera_tilts_deg", p.camera_tilts_deg, range::any, "deg", "optical axis vs normal");
  v("camera_views_per_pose", p.camera_views_per_pose, range::at_least(1), "",
    "random yaws and motions per altitude/tilt");
  v("camera_readout_ms", p.camera_readout_ms, range::positive, "ms",
    "rolling shutter: first row to last row");
  v("camera_jpeg_quality", p.camera_jpeg_quality, range::closed(1, 100), "",
    "JPEG quality of the JPEG conditions");
  v("camera_speed_mps", p.camera_speed_mps, range::non_negative, "m/s",
    "the camera's speed over the platform during the readout");
  v("camera_rate_dps", p.camera_rate_dps, range::non_negative, "deg/s",
    "its angular rate about a random axis");
  v("camera_bands", p.camera_bands, range::at_least(1), "",
    "bands of rows a rolling-shutter frame is built from");
}

// Camera pose X_PC looking at `aim_P_m` from `altitude_m` above the platform plane, the optical
// axis tilted `tilt_deg` from the platform normal towards azimuth `azimuth_deg`, rotated
// `yaw_deg` about the optical axis.
Eigen::Isometry3d bench_camera_pose_P(double altitude_m, double tilt_deg, double yaw_deg,
                                      double azimuth_deg, const Eigen::Vector2d& aim_P_m);

// Runs the sweep and returns the JSON document: top-level keys `ours`, `apriltag`, `aruco`
// (OpenCV default, no corner refinement; `aruco.subpix` holds CORNER_REFINE_SUBPIX), each with
// `overall`, `by_altitude_m` and `by_blur_px` objects of metrics: detection_rate,
// false_positive_rate, centre_err_px_mean (centres for ours, corners for the squares, against
// the true projections), reproj_err_px_mean and reproj_err_px_var (eq. 30 as a per-frame RMS),
// pos_err_m_mean, rot_err_deg_mean, ms_per_frame_median (thread CPU time of one detection,
// one thread, so a loaded machine does not inflate it), frames, empty_frames;
// plus `ours.overall.ms_per_frame_median_tracking` and `ours.overall.ms_per_frame_median_empty`
// (target-free frames), and `config`.
// With params.shadow_sweep, `shadows` holds the shadow condition: for each method (`ours`,
// `apriltag`, `aruco`, `aruco.subpix`) and each light level (`light_0.2`, ...), the metrics
// over frames with the whole target in view (`in_view`: all ring sets and the marker's
// corners inside the image), `all` frames, `by_width_m`, `by_altitude_m` and
// `by_sets_crossed` (in-view frames), and `empty` (target-free frames with a band); the
// same rendered frame (one per view and method) carries every band.
// With params.camera_sweep, `camera` holds the camera condition (camera_condition.h): the same
// views and motions seen through a global shutter, JPEG, a rolling shutter and both.
// `progress`, if given, receives one line per altitude and, at the end, the shadow table.
std::string run_estimator_bench(const BenchRenderFn& render, const Eigen::Isometry3d& X_WP,
                                const TargetGeometry& target, const CameraModel& camera,
                                const VisionParams& vision, const EstimatorBenchParams& params,
                                std::ostream* progress = nullptr);

// A BenchRenderFn drawing the platform with the exact synthetic warp (SyntheticPlatformView,
// no distortion) at X_WP on uniform ground; blur along kSyntheticBlurDirectionDeg in the image
// (set EstimatorBenchParams::blur_direction_deg to it).
constexpr double kSyntheticBlurDirectionDeg = 30.0;
BenchRenderFn make_synthetic_bench_renderer(const TargetGeometry& target,
                                            const CameraModel& camera,
                                            const Eigen::Isometry3d& X_WP);

}  // namespace lander::bench
