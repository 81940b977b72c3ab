// Path extraction for image-based path following (seed 003 section 3): the painted route is
// segmented by a per-channel colour threshold (eq. 6), eroded (eq. 7) and thinned to its
// centre line (eq. 8-9, Zhang-Suen), the image is cut into an M x N grid and each cell that
// the centre line crosses gives one candidate point, the mean of its centre-line pixels (the
// paper's "path centre point"). The controller's guidance law picks its target among them.
// Flight software: OpenCV only, no MuJoCo, no GL.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "lander/core/params_io.h"
#include "lander/core/types.h"

namespace lander {

struct PathExtractorParams {
  bool enabled{true};            ///< run the stage at all
  int work_width_px{320};        ///< the frame is resized (INTER_AREA) to this width first (px);
                                 ///< the height keeps the aspect ratio (the paper's camera is
                                 ///< 160x120; 320 keeps a 16 px wide route 4 px wide)
  // eq. 6: a pixel is route paint when every bound holds (0..255 per channel, on the resized
  // BGR image). The defaults take red paint rgba (0.85, 0.1, 0.1) lit by anything from about
  // half of the simulator's sun + ambient (R ~ 110, G = B ~ 13) to full light (R = 255,
  // G = B ~ 31), and reject grey asphalt (R lowest), white, yellow (G high), blue and the
  // brown cart.
  int r_min{100};                ///< red lower bound (0..255)
  int r_max{255};                ///< red upper bound (0..255)
  int g_min{0};                  ///< green lower bound (0..255)
  int g_max{110};                ///< green upper bound (0..255)
  int b_min{0};                  ///< blue lower bound (0..255)
  int b_max{110};                ///< blue upper bound (0..255)
  double min_dominance{40.0};    ///< R - max(G, B) must exceed this (0..255, grey levels);
                                 ///< rejects grey, white, orange-ish; 0 disables (for a route of
                                 ///< another colour set the bounds and this to 0)
  int erode_px{3};               ///< eq. 7 erosion kernel side (px at work resolution), odd;
                                 ///< the paper's 3 x 3 square structuring element; 1 = none. A
                                 ///< route narrower than erode_px work pixels is erased
  int grid_cols{10};             ///< M: grid columns (the paper: 10)
  int grid_rows{10};             ///< N: grid rows (the paper: 10)
  int min_cell_pixels{2};        ///< centre-line pixels a cell needs to give a point (work px)
  int min_component_px{8};       ///< connected components (8-connected) of the eroded mask
                                 ///< smaller than this many work pixels are noise, removed
                                 ///< before thinning; 0 keeps all

  void validate() const;
};

template <class V>
void visit_fields(V& v, PathExtractorParams& p) {
  v("enabled", p.enabled, range::any, "", "run the stage at all");
  v("work_width_px", p.work_width_px, range::closed(32, 8192), "px",
    "the frame is resized to this width first");
  v("r_min", p.r_min, range::any, "", "red lower bound");
  v("r_max", p.r_max, range::any, "", "red upper bound");
  v("g_min", p.g_min, range::any, "", "green lower bound");
  v("g_max", p.g_max, range::any, "", "green upper bound");
  v("b_min", p.b_min, range::any, "", "blue lower bound");
  v("b_max", p.b_max, range::any, "", "blue upper bound");
  v("min_dominance", p.min_dominance, range::closed_open(0, 255), "",
    "R - max(G, B) must exceed this (0..255, grey levels)");
  v("erode_px", p.erode_px, range::any, "px", "eq. 7 erosion kernel side (px at work resolution)");
  v("grid_cols", p.grid_cols, range::closed(1, 100), "", "M: grid columns (the paper: 10)");
  v("grid_rows", p.grid_rows, range::closed(1, 100), "", "N: grid rows (the paper: 10)");
  v("min_cell_pixels", p.min_cell_pixels, range::at_least(1), "",
    "centre-line pixels a cell needs to give a point (work px)");
  v("min_component_px", p.min_component_px, range::non_negative, "px",
    "connected components of the eroded mask smaller than this many work");
}

// One frame's result. Pixel coordinates follow OpenCV (centre of the top-left pixel (0, 0)).
struct PathObservation {
  double t_s{0.0};                          ///< mid-exposure time of the frame (s; the caller
                                            ///< sets it)
  bool valid{false};                        ///< at least one candidate point
  std::vector<Eigen::Vector2d> points_px;   ///< cell centre points in the UNDISTORTED
                                            ///< full-resolution image (pinhole fx, fy, cx, cy
                                            ///< of the calibration), px; one per cell with a
                                            ///< point, row-major cell order
  std::vector<Eigen::Vector2d> points_n;    ///< the same as normalised image coordinates
                                            ///< ((u - cx) / fx, (v - cy) / fy) = (x/z, y/z)
  std::vector<Eigen::Vector2i> cells;       ///< (col, row) of the grid cell of each point
  int centerline_pixels{0};                 ///< centre-line pixels found (work resolution)
  int paint_pixels{0};                      ///< pixels passing eq. 6 (work resolution)
  double fx{0}, fy{0}, cx{0}, cy{0};        ///< the calibration's intrinsics (px)
  int width_px{0}, height_px{0};            ///< full-resolution image size (px)
  double process_ms{0.0};                   ///< wall time spent in extract() (ms, informative)
};

class PathExtractor {
 public:
  // Intermediate images of one call, at work resolution (CV_8UC1, 0 / 255): `mask` the pixels
  // passing eq. 6, `centerline` the thinned centre line the grid points are taken from.
  struct Debug {
    cv::Mat mask, centerline;
  };

  // Throws ConfigError when the calibration or the params are invalid.
  PathExtractor(const CameraModel& calibration, const PathExtractorParams& params);

  // `bgr`: the camera frame as delivered (distorted, full resolution, CV_8UC3, the size of the
  // calibration). Never throws for bad image content: an empty image, another type or another
  // size gives valid = false (and no points).
  PathObservation extract(const cv::Mat& bgr) const { return extract(bgr, nullptr); }
  // The same, also filling `debug` when it is not null.
  PathObservation extract(const cv::Mat& bgr, Debug* debug) const;

  const PathExtractorParams& params() const { return params_; }
  const CameraModel& calibration() const { return cam_; }

 private:
  CameraModel cam_;
  PathExtractorParams params_;
  cv::Mat K_, dist_;  // OpenCV camera matrix and distortion coefficients of cam_
};

}  // namespace lander
