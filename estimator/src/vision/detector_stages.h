// The ring detector's stages between the ellipses and the reported pose (not public API).
//
// One search region (run_region, region.cpp) goes
//   ellipses -> concentric pairs -> identities -> initial pose -> refined and gated pose
// (region_identities.cpp: pairs and identities; region_pose.cpp: the two poses), with the
// layout's identification as its fallback. One frame (RingTargetDetector::detect) goes
//   the predicted region, then while no pose the ordered passes try_<pass>(frame, so_far)
//   (detect_passes.cpp) -> the code map -> the ring and code poses combined
//   (pose_sources.cpp) -> the checks every pose must pass -> tracking and keyframes.
#pragma once

#include <chrono>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "lander/estimator/vision_detector.h"
#include "lander/estimator/vision_layout.h"
#include "internal.h"  // (relative: the stage tests include this header by path)

namespace lander::vision_internal {

// ---- shared geometry and checks ----

// The target's marked side faces the camera: the camera is in front of the platform's top
// (P's z axis, out of the top, points towards it).
bool faces_camera(const Eigen::Isometry3d& X_CP);
// True if two poses agree within the combination gates (combine_max_angle_rad, _offset_ratio).
bool poses_agree(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, const VisionParams& p);
// The P point c_P (on the top, z = 0) projected through the pinhole K (undistorted px).
Eigen::Vector2d project(const Eigen::Matrix3d& K, const Eigen::Isometry3d& X_CP,
                        const Eigen::Vector2d& c_P);
// 8-bit grey frame in which at least `region` of `img` is converted (detect_passes.cpp).
void grey_region(const cv::Mat& img, const cv::Rect& region, cv::Mat& grey);
// The pixel rectangle covering [x0, x1] x [y0, y1] (outward to whole pixels), within `full`.
cv::Rect covering_rect(double x0, double y0, double x1, double y1, const cv::Rect& full);

// Why a stage gave no result: the detection's status and reason.
struct StageFailure {
  VisionStatus status{VisionStatus::PoseFailed};
  std::string reason;
};
// Marks `d` as not detected for `f`; returns false (for `return fail(...)`).
bool fail(RingDetection& d, StageFailure f);

// ---- one search region: ellipses -> pairs -> identities -> poses ----

// What a region's run reads: the 8-bit frame, the region, the camera, target and parameters.
struct RegionInput {
  const cv::Mat& grey;
  cv::Rect roi;
  const CameraModel& cam;
  const TargetGeometry& target;
  const VisionParams& p;
  bool shadow{false};  ///< the shadow-tolerant segmentation (find_ellipses)
  /// If given, replaces the contours: the ellipses are these guesses refined (platform pass).
  const PlatformGuesses* platform{nullptr};
};

// Stage 1-2's output on a region: the ellipse candidates and the pre-filtered region (for
// the guided inner search's refine_candidate()).
struct RegionEllipses {
  std::vector<EllipseCandidate> cands;
  cv::Mat blurred;
};
RegionEllipses region_ellipses(const RegionInput& in);
// The diagnostic copy of a candidate (RingDetection::ellipses).
DetectedEllipse detected_ellipse(const EllipseCandidate& c);

// A concentric pair of ellipse candidates (eq. 1), its projected centre (eq. 2-8), its
// radius ratio (eq. 9) and the ring set whose ratio is nearest.
struct PairCandidate {
  int outer{-1}, inner{-1};  ///< into the candidates; inner -1: an outer circle alone
  Eigen::Vector2d centre;    ///< undistorted px
  double ratio{0.0};
  int iterations{0};
  int ring_id{-1};
  double err{1e9};  ///< |ratio - the ring set's ratio|
};
// Candidates i (outer) and j (inner) as a pair; nullopt if they are not one.
std::optional<PairCandidate> concentric_pair(const std::vector<EllipseCandidate>& cands, int i,
                                             int j, const TargetGeometry& target,
                                             const VisionParams& p);
// Every ordered pair of candidates that is concentric.
std::vector<PairCandidate> concentric_pairs(const std::vector<EllipseCandidate>& cands,
                                            const TargetGeometry& target, const VisionParams& p);

// The ring identities: the pairs, the ones chosen as identified sets and the candidates they
// use.
struct Identities {
  std::vector<PairCandidate> pairs;
  std::vector<int> chosen;         ///< identified sets, indices into pairs
  std::vector<bool> used_ellipse;  ///< per candidate: in a chosen pair
  bool id_used(int id) const;
  void choose(int k);   ///< pairs[k] identified: its ellipses used
  void release(std::size_t c);  ///< chosen[c] dropped: its ellipses free again
};
// Greedy one-to-one assignment of `pairs` by identity error (within ratio_tol).
Identities identify_by_ratio(std::vector<PairCandidate> pairs, std::size_t n_cands,
                             const VisionParams& p);
// Inner circles searched inside unused outer circles at each unidentified model ratio; the
// found ones join the candidates, `ellipses` and the identities.
void guided_inner_search(const RegionInput& in, RegionEllipses& found, Identities& ids,
                         std::vector<DetectedEllipse>& ellipses);
// d.centres from the chosen pairs, and the ellipses' ring ids and outer flags.
void fill_centres(const Identities& ids, const CameraModel& cam, RingDetection& d);

// What the layout's identification works on: one candidate per ring set seen (an outer circle
// with its best pair, or alone), and where each came from.
struct LayoutInput {
  std::vector<LayoutCandidate> sets;
  std::vector<int> ellipse;    ///< per set: its outer circle's candidate
  std::vector<int> best_pair;  ///< per candidate: its best pair as the outer circle, or -1
};
LayoutInput layout_input(const RegionInput& in, const RegionEllipses& found,
                         const Identities& ids);
// The identities the layout's match `m` gives (the ratio path's pairs, plus outer circles
// alone).
Identities identities_from_layout(const LayoutMatch& m, const LayoutInput& li,
                                  const RegionEllipses& found, Identities ids,
                                  const TargetGeometry& target);

// The initial pose of the chosen sets (IPPE on >= min_rings centres with the layout check,
// else P3P on three sets); may drop chosen sets. nullopt with the failure in `why`.
std::optional<Eigen::Isometry3d> initial_pose(const RegionInput& in, const RegionEllipses& found,
                                              Identities& ids, StageFailure& why);
// From the initial pose: sets recovered by the layout, the conic refinement (eq. 14-15), the
// gates and the plane's two tilts. Fills d's pose, gates and reason; returns d.detected.
bool refine_and_gate(const RegionInput& in, const RegionEllipses& found, Identities& ids,
                     const Eigen::Isometry3d& X0, RingDetection& d);

// Everything from contours to the refined pose on one search region. Fills `d` except the
// keyframe fields and the timing; returns d.detected. `cands` receives the ellipse
// candidates (index-aligned with d.ellipses) for the fewer-ring and combined poses.
bool run_region(const RegionInput& in, RingDetection& d, std::vector<EllipseCandidate>& cands);

// ---- one frame: the passes ----

// A detection with the ellipse candidates its centres index.
struct Found {
  RingDetection d;
  std::vector<EllipseCandidate> cands;
};

// One frame's inputs and its grey conversions, shared by detect()'s passes and checks.
struct FrameContext {
  const cv::Mat& image;
  const CameraModel& cam;
  const TargetGeometry& target;
  const VisionParams& p;
  Eigen::Vector2d blur_px;  ///< the caller's predicted blur (detect())
  cv::Rect full;            ///< the whole frame
  double min_depth_m{0.0};  ///< the caller's least depth of the target's plane (detect()), 0 unknown
  cv::Mat grey{};           ///< 8-bit grey, converted at least where a pass needed it
  bool grey_full{false};    ///< the whole frame is in `grey` (no more conversion)
  cv::Mat sharp{};          ///< the deconvolved frame, when the deblur pass ran
  RingDetection::StageTimes times{};  ///< wall time by stage, added by timed_stage()
  /// Run by the full-frame pass when its global segmentation gave no pose, before the shadow
  /// pass: true when it gave the frame a pose, and the rings' passes then stop (rings_stopped).
  std::function<bool()> before_shadow{};
  bool rings_stopped{false};

  // Converts the whole frame into `grey` (once).
  void whole_grey();
  // Converts at least `r` into `grey` (nothing when the whole frame is in).
  void grey_in(const cv::Rect& r);
  // The frame can hold the target (16 px both ways).
  bool big_enough() const { return full.width >= 16 && full.height >= 16; }
};

// Runs `stage()` and adds its wall time (ms) to `ms`.
template <class Stage>
void timed_stage(double& ms, Stage&& stage) {
  const auto t0 = std::chrono::steady_clock::now();
  stage();
  ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// The global segmentation first; if it gives no pose, the shadow-tolerant one (issue 12),
// unless `before_shadow` (when given, run first) returns true: then no ring pose (false).
bool search_region(const cv::Mat& grey, const cv::Rect& roi, const CameraModel& cam,
                   const TargetGeometry& target, const VisionParams& p, Found& out,
                   const std::function<bool()>& before_shadow = {});

// The region predicted by the last pose `X_pred`; d.used_roi when it gives a pose.
void try_predicted_region(FrameContext& f, const Eigen::Isometry3d& X_pred, Found& so_far);
// The passes tried while no pose, in order (each checks its own switch): the full frame,
// deblurred, unfiltered, zoomed, platform.
void try_fallback_passes(FrameContext& f, Found& so_far);
// The code map (seed 001) searched unless the pose (this frame's, else the track) shows its
// cells too small; fills d.code, d.code_searched and d.code_region.
void search_code_map(FrameContext& f, const Eigen::Isometry3d* track, RingDetection& d);
// The outer circle of `ring` under the pose `X`: 12 points in the camera frame, fewer where
// they are behind it.
std::vector<cv::Point3d> outer_circle_C(const RingSet& ring, const Eigen::Isometry3d& X);
// `ring` wholly in the frame under `X` (every point of the outer circle in front and inside,
// the outer radius at least min_axis_px); ring_sets_in_view counts the target's.
bool wholly_in_view(const FrameContext& f, const RingSet& ring, const Eigen::Isometry3d& X);
int ring_sets_in_view(const FrameContext& f, const Eigen::Isometry3d& X);
// After the predicted region: the rings' fallback passes and the code map, the code map first
// at close range (code_first_close_range: no pose yet and the track shows no ring set wholly
// in the frame), the passes then only when it gives no pose (d.rings_skipped when they did
// not run); else the passes, then the code map with their pose.
void search_rings_and_code(FrameContext& f, const Eigen::Isometry3d* track, Found& found);

// Fewer-ring / combined pose on top of the ring pass (pose_sources.cpp). `d` is the ring
// result (detected or not), `cands` its ellipse candidates, d.code the code result (may be
// undetected), `tracked` the last tracked pose (nullptr if none). Updates d when a pose
// results.
void combine_sources(RingDetection& d, const std::vector<EllipseCandidate>& cands,
                     const Eigen::Matrix3d& K, const TargetGeometry& target,
                     const VisionParams& p, const Eigen::Isometry3d* tracked);

}  // namespace lander::vision_internal
