// Code-map localisation (seed 001 section 3), see vision_code.h for the pipeline: the five
// stages run in order (code_stages.h; code_grid.cpp, code_cells.cpp, code_pose.cpp).
#include "lander/estimator/vision_code.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <opencv2/core.hpp>

#include "vision/code_stages.h"
#include "vision/internal.h"

namespace lander {

namespace {

namespace cm = vision_internal::code_map;

// Whether the pose `X_CP` (none: unknown) puts every code cell at least
// code_half_res_min_cell_px across: the cell's size at the map's farthest corner.
bool cells_large(const CameraModel& cam, const TargetGeometry& g, const VisionParams& p,
                 const Eigen::Isometry3d* X_CP) {
  if (X_CP == nullptr || !(p.code_half_res_min_cell_px > 0) || g.code.cells == 0) return false;
  const double s = 0.5 * g.code.side_m();
  double z_far = 0.0;
  for (const double x : {-s, s}) {
    for (const double y : {-s, s}) {
      const double z = (*X_CP * Eigen::Vector3d(x, y, 0)).z();
      if (!(z > 0)) return false;
      z_far = std::max(z_far, z);
    }
  }
  return g.code.cell_m * std::min(cam.fx_px, cam.fy_px) / z_far >= p.code_half_res_min_cell_px;
}

// Steps 1-5 on `grey` (the camera's whole image, or a region of it with `cam` shifted to
// it) with the adaptive threshold's block `block` px; `X_CP_prior`, when given, predicts the
// grid's two line families (step 2).
CodeDetection detect_code_impl(const cv::Mat& grey, const CameraModel& cam, const TargetGeometry& g,
                               const VisionParams& p, int block,
                               const Eigen::Isometry3d* X_CP_prior = nullptr) {
  CodeDetection d;
  std::string why;
  auto fail = [&](const std::string& reason) {
    d.detected = false;
    d.reason = "code: " + reason;
    return d;
  };
  if (g.code.cells == 0) return fail("target has no code map");
  if (grey.empty() || grey.type() != CV_8UC1) return fail("need an 8-bit grey frame");
  // 1. threshold, contours, polygon vertices and sides (on the frame halved when the prior
  // shows every cell large).
  const std::optional<cm::GridFeatures> features = cm::find_grid_features(
      grey, cam, p, block, cells_large(cam, g, p, X_CP_prior), why);
  if (!features) return fail(why);
  // 2. two line families, vanishing points, affine rectification, lattice labels.
  const std::optional<cm::GridLattice> lattice =
      cm::fit_grid_lattice(*features, cam, g, p, X_CP_prior, why);
  if (!lattice) return fail(why);
  // 3. read the cells.
  const std::optional<cm::CellReads> reads = cm::read_lattice_cells(grey, cam, *lattice, g, p, why);
  if (!reads) return fail(why);
  d.cell_px = reads->cell_px;
  const std::optional<std::vector<ObservedCell>> cells = cm::classify_cells(reads->reads, p, why);
  if (!cells) return fail(why);
  d.cells_read = static_cast<int>(cells->size());
  // 4. place the read cells in the map.
  const std::vector<std::uint8_t> map = generate_code_map(g.code);
  const cm::CellPlacement placed = cm::place_read_cells(*cells, *reads, g, map, p);
  d.placement = placed.placement;
  d.cells_read = placed.cells_read;
  d.local_white = placed.local_white;
  if (!d.placement.found) return fail(d.placement.reason);
  // 5. sub-pixel corners of the map and PnP.
  std::optional<cm::CornerMatches> matches =
      cm::map_corner_matches(grey, cam, g, map, d.placement, lattice->H, d.cell_px, p, why);
  if (!matches) return fail(why);
  const cm::CornerPose pose = cm::code_corner_pose(std::move(*matches), cam, p);
  d.reproj_rms_px = pose.reproj_rms_px;
  d.reproj_gate_px = pose.reproj_gate_px;
  if (!pose.ok) return fail(pose.why);
  d.cov = pose.cov;
  d.X_CP = pose.X_CP;
  const std::vector<cv::Point3d>& obj = pose.inliers.corners_P_m;
  const std::vector<cv::Point2d>& ip = pose.inliers.corners_px;
  for (std::size_t i = 0; i < obj.size(); ++i) {
    d.corners_P_m.emplace_back(obj[i].x, obj[i].y);
    d.corners_px.emplace_back(ip[i].x, ip[i].y);
  }
  d.detected = true;
  std::ostringstream os;
  os << "code: " << d.cells_read << " cells read, " << d.placement.compared << " compared, "
     << d.placement.mismatched << " disagree, " << obj.size() << " corners, rotation "
     << d.placement.rotation;
  d.reason = os.str();
  return d;
}

// The adaptive threshold's block on a whole frame: code_threshold_block_px, at most the
// largest odd size within half the frame's shorter side.
int threshold_block(const cv::Mat& frame, const VisionParams& p) {
  return std::min(p.code_threshold_block_px, (std::min(frame.cols, frame.rows) / 2) * 2 - 1);
}

}  // namespace

CodeDetection detect_code_pattern(const cv::Mat& grey, const CameraModel& cam,
                                  const TargetGeometry& g, const VisionParams& p,
                                  const Eigen::Isometry3d* X_CP_prior) {
  return detect_code_impl(grey, cam, g, p, threshold_block(grey, p), X_CP_prior);
}

CodeDetection detect_code_pattern(const cv::Mat& grey, const CameraModel& cam,
                                  const TargetGeometry& g, const VisionParams& p,
                                  const cv::Rect& region, const Eigen::Isometry3d* X_CP_prior) {
  const cv::Rect r = region & cv::Rect(0, 0, grey.cols, grey.rows);
  if (grey.empty() || r.width < 16 || r.height < 16) {
    CodeDetection d;
    d.reason = "code: search region outside the frame";
    return d;
  }
  // A copy: no filter of the search reads pixels outside the region. The block is the whole
  // frame's, so pixels at least half a block inside the region threshold as on the frame.
  CodeDetection d = detect_code_impl(grey(r).clone(), vision_internal::zoomed_camera(cam, r, 1), g,
                                     p, threshold_block(grey, p), X_CP_prior);
  for (auto& c : d.corners_px) c += Eigen::Vector2d(r.x, r.y);
  return d;
}

namespace vision_internal {

double bilinear(const cv::Mat& g, double x, double y) {
  x = vision_internal::clamp_coord(x);
  y = vision_internal::clamp_coord(y);
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  auto at = [&](int xx, int yy) {
    xx = std::clamp(xx, 0, g.cols - 1);
    yy = std::clamp(yy, 0, g.rows - 1);
    return static_cast<double>(g.at<std::uint8_t>(yy, xx));
  };
  return (1 - fx) * (1 - fy) * at(x0, y0) + fx * (1 - fy) * at(x0 + 1, y0) +
         (1 - fx) * fy * at(x0, y0 + 1) + fx * fy * at(x0 + 1, y0 + 1);
}

}  // namespace vision_internal
}  // namespace lander
