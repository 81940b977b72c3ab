// The code map's five stages (seed 001 section 3; vision_code.h gives the pipeline), each a
// function from typed input to typed output, in the manner of AprilTag 3's detector
// (apriltag_quad_thresh -> segmentation -> fit_quads -> decode):
//
//   grey frame --1. find_grid_features (code_grid.cpp)--> GridFeatures
//              --2. fit_grid_lattice   (code_grid.cpp)--> GridLattice
//              --3. read_lattice_cells, classify_cells (code_cells.cpp)--> CellReads, cells
//              --4. place_read_cells   (code_cells.cpp)--> CellPlacement
//              --5. map_corner_matches, code_corner_pose (code_pose.cpp)--> CornerPose
//
// code.cpp runs them (detect_code_pattern). A stage that finds nothing returns nullopt and
// says why in `why` (without the "code: " prefix). Not part of the public API; only public
// headers are included, so that the stage tests can include this one.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "lander/estimator/target.h"
#include "lander/core/types.h"
#include "lander/estimator/vision_code.h"
#include "lander/estimator/vision_params.h"

namespace lander::vision_internal::code_map {

// ---- shared by the stages ----

// The point p mapped by the homography H (homogeneous division).
inline Eigen::Vector2d apply_h(const Eigen::Matrix3d& H, const Eigen::Vector2d& p) {
  const Eigen::Vector3d q = H * Eigen::Vector3d(p.x(), p.y(), 1.0);
  return q.head<2>() / q.z();
}

// Raw image px -> undistorted px of the pinhole K (unchanged without distortion).
std::vector<Eigen::Vector2d> undistort_points(const CameraModel& cam,
                                              const std::vector<cv::Point2f>& pts);

// Code map extended by a margin of E cells: 0 light, 1 dark, 2 unknown (outside the inner
// circle of the central ring set or not background).
struct ExtendedMap {
  int n{0}, E{0}, w{0};
  std::vector<std::uint8_t> v;
  int at(int col, int row) const {
    if (col < -E || row < -E || col >= n + E || row >= n + E) return 2;
    return v[(row + E) * w + (col + E)];
  }
};
ExtendedMap extended_map(const TargetGeometry& g, const std::vector<std::uint8_t>& map);

// The inner radius of the central ring set (m), 0 without one.
double central_inner_radius_m(const TargetGeometry& g);

// ---- 1. threshold, contours, polygon vertices and sides ----

// A polygon side: a grid line segment.
struct Segment {
  Eigen::Vector2d p0, p1;  // undistorted px
  double len{0.0};
  double theta{0.0};
};
// What the threshold's polygons offer as grid: their corners (vertices with two long sides at
// a grid-like angle) and their sides, in undistorted px.
struct GridFeatures {
  std::vector<Eigen::Vector2d> verts;
  std::vector<Segment> segs;
};
// Stage 1 on `grey` with the adaptive threshold's block `block` px (>= 3); with `halved`,
// on `grey` halved (block, smallest cell and margins halved too), the corners and sides
// returned in `grey`'s pixels.
std::optional<GridFeatures> find_grid_features(const cv::Mat& grey, const CameraModel& cam,
                                               const VisionParams& p, int block, bool halved,
                                               std::string& why);

// ---- 2. two line families, vanishing points, affine rectification, lattice labels ----

// Vanishing point (homogeneous, normalised coordinates (x - c) / f) of a family of segments:
// least-squares intersection of their lines, iterated on the inliers; `segs` keeps only those.
std::optional<Eigen::Vector3d> vanishing_point(std::vector<Segment>& segs,
                                               const Eigen::Vector2d& c, double f);
// Lattice spacing and phase of 1-D coordinates x_k that lie near x0 + i * delta (nullopt
// without enough of them): {delta, x0}.
std::optional<std::pair<double, double>> lattice_1d(const std::vector<double>& lengths,
                                                    const std::vector<double>& x);
// The grid as a lattice: H maps lattice (a, b) to undistorted px, with the handedness of the
// code map's (col, row); `labels` are the lattice labels of the corners on it, all within
// the code map's reach of their median.
struct GridLattice {
  Eigen::Matrix3d H;
  std::vector<Eigen::Vector2i> labels;
};
// Stage 2. `X_CP_prior`, when given, predicts the two line families' directions.
std::optional<GridLattice> fit_grid_lattice(const GridFeatures& features, const CameraModel& cam,
                                            const TargetGeometry& g, const VisionParams& p,
                                            const Eigen::Isometry3d* X_CP_prior,
                                            std::string& why);

// ---- 3. read the cells ----

// A cell's mean grey at lattice label (a, b).
struct CellRead {
  int a, b;
  double mean;
};
// The lattice cells in view, read, with the labels' bounds and the median cell side.
struct CellReads {
  std::vector<CellRead> reads;
  int amin, amax, bmin, bmax;  // bounds of the lattice labels
  double cell_px;              // median cell side in the image (px)
};
// Stage 3a: every lattice cell wholly in view and at least 0.8 code_min_cell_px across, read
// as the mean grey of its inner half.
std::optional<CellReads> read_lattice_cells(const cv::Mat& grey, const CameraModel& cam,
                                            const GridLattice& lattice, const TargetGeometry& g,
                                            const VisionParams& p, std::string& why);
// Stage 3b: the reads as dark or light by one two-class (Otsu) level over all of them; a read
// near the level is left out. nullopt when the classes differ by less than code_min_contrast.
std::optional<std::vector<ObservedCell>> classify_cells(const std::vector<CellRead>& reads,
                                                        const VisionParams& p, std::string& why);
// Cells read against their local white (the closing of the cell means over the lattice).
std::vector<ObservedCell> read_cells_local_white(const std::vector<CellRead>& reads, int amin,
                                                 int amax, int bmin, int bmax);

// ---- 4. place the read cells in the map ----

// The placement of stage 4 and the cells it was made with.
struct CellPlacement {
  CodePlacement placement;
  int cells_read{0};
  bool local_white{false};  // placed with the cells read against their local white
};
// Stage 4: `cells` placed in `map`; if they are not and code_local_white is on, the reads
// again against their local white.
CellPlacement place_read_cells(const std::vector<ObservedCell>& cells, const CellReads& reads,
                               const TargetGeometry& g, const std::vector<std::uint8_t>& map,
                               const VisionParams& p);

// ---- 5. sub-pixel corners of the map and PnP ----

// Map corners matched to the image: corners_P_m[i] (m, z = 0) seen at corners_px[i]
// (undistorted px).
struct CornerMatches {
  std::vector<cv::Point3d> corners_P_m;
  std::vector<cv::Point2d> corners_px;
};
// Stage 5a: every map corner with an L or X pattern, clear of the ring, predicted through
// the placement and H, refined by cornerSubPix; those that stay near their prediction.
std::optional<CornerMatches> map_corner_matches(const cv::Mat& grey, const CameraModel& cam,
                                                const TargetGeometry& g,
                                                const std::vector<std::uint8_t>& map,
                                                const CodePlacement& placement,
                                                const Eigen::Matrix3d& H, double cell_px,
                                                const VisionParams& p, std::string& why);
// Stage 5b's pose: PnP on the matches (outliers dropped), its gate and covariance. When `ok`
// is false, `why` says why; reproj_rms_px and reproj_gate_px hold what was reached (0 when
// not: CodeDetection's defaults).
struct CornerPose {
  bool ok{false};
  std::string why;
  Eigen::Isometry3d X_CP{Eigen::Isometry3d::Identity()};
  Eigen::Matrix<double, 6, 6> cov{Eigen::Matrix<double, 6, 6>::Identity()};
  CornerMatches inliers;
  double reproj_rms_px{0.0};
  double reproj_gate_px{0.0};
};
// Stage 5b.
CornerPose code_corner_pose(CornerMatches matches, const CameraModel& cam,
                            const VisionParams& p);

}  // namespace lander::vision_internal::code_map
