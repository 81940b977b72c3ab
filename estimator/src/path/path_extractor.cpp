// Path extraction (seed 003 section 3): colour threshold, erosion, thinning, grid centre points.
#include "lander/estimator/path_extractor.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc.hpp>

#include "lander/estimator/camera_cv.h"

namespace lander {

void PathExtractorParams::validate() const {
  check_fields(*this);
  const auto channel = [](int v, const char* key) {
    require(v >= 0 && v <= 255, key, "must be in [0, 255]");
  };
  channel(r_min, "r_min");
  channel(r_max, "r_max");
  channel(g_min, "g_min");
  channel(g_max, "g_max");
  channel(b_min, "b_min");
  channel(b_max, "b_max");
  require(r_min <= r_max, "r_min", "must be <= r_max");
  require(g_min <= g_max, "g_min", "must be <= g_max");
  require(b_min <= b_max, "b_min", "must be <= b_max");
  require(erode_px >= 1 && erode_px <= 15 && erode_px % 2 == 1, "erode_px",
          "must be odd and in [1, 15]");
  require(grid_cols <= work_width_px, "grid_cols", "must be <= work_width_px");
}

PathExtractor::PathExtractor(const CameraModel& calibration, const PathExtractorParams& params)
    : cam_(calibration), params_(params) {
  validate_nested("calibration", cam_);
  params_.validate();
  K_ = camera_matrix_cv(cam_);
  dist_ = dist_coeffs_cv(cam_);
}

namespace {

// Removes the 8-connected components of `mask` (0 / 255) with fewer than `min_px` pixels.
void remove_small_components(cv::Mat& mask, int min_px) {
  if (min_px <= 1) return;
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  std::vector<unsigned char> keep(n, 0);
  bool any_dropped = false;
  for (int i = 1; i < n; ++i) {
    keep[i] = stats.at<int>(i, cv::CC_STAT_AREA) >= min_px;
    any_dropped = any_dropped || !keep[i];
  }
  if (!any_dropped) return;
  for (int y = 0; y < mask.rows; ++y) {
    const int* l = labels.ptr<int>(y);
    unsigned char* m = mask.ptr<unsigned char>(y);
    for (int x = 0; x < mask.cols; ++x)
      if (m[x] && !keep[l[x]]) m[x] = 0;
  }
}

// The frame at the work resolution: width work_width_px (at most the frame's), aspect kept.
cv::Mat work_image(const cv::Mat& bgr, int work_width_px) {
  const int ww = std::min(work_width_px, bgr.cols);
  const int wh = std::max(1, static_cast<int>(std::lround(double(bgr.rows) * ww / bgr.cols)));
  cv::Mat small;
  if (ww == bgr.cols && wh == bgr.rows)
    small = bgr;
  else
    cv::resize(bgr, small, cv::Size(ww, wh), 0, 0, cv::INTER_AREA);
  return small;
}

// The paint-coloured pixels of the work image (0 / 255).
cv::Mat paint_mask(const cv::Mat& small, const PathExtractorParams& params_) {
  // eq. 6: r_min <= R <= r_max, g_min <= G <= g_max, b_min <= B <= b_max (BGR order), and the
  // red-dominance test R - max(G, B) > min_dominance (saturating subtraction: a negative
  // difference becomes 0, which never exceeds a threshold >= 0).
  cv::Mat mask;
  cv::inRange(small, cv::Scalar(params_.b_min, params_.g_min, params_.r_min),
              cv::Scalar(params_.b_max, params_.g_max, params_.r_max), mask);
  if (params_.min_dominance > 0) {
    cv::Mat ch[3];
    cv::split(small, ch);
    cv::Mat gb, dom;
    cv::max(ch[0], ch[1], gb);
    cv::subtract(ch[2], gb, dom);  // saturates at 0
    cv::Mat dominant = dom > params_.min_dominance;
    cv::bitwise_and(mask, dominant, mask);
  }
  return mask;
}

// The route's body: the mask eroded, without speckles.
cv::Mat route_body(const cv::Mat& mask, const PathExtractorParams& params_) {
  // eq. 7: erosion A (-) B = {z | (B)_z subset of A} with a square erode_px x erode_px
  // structuring element B; outside the image counts as background, so a route leaving the
  // frame is not widened at the border.
  cv::Mat body = mask;
  if (params_.erode_px > 1) {
    const cv::Mat B = cv::getStructuringElement(
        cv::MORPH_RECT, cv::Size(params_.erode_px, params_.erode_px));
    cv::erode(mask, body, B, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  }
  // Speckles of paint-coloured noise: components below min_component_px.
  remove_small_components(body, params_.min_component_px);
  return body;
}

// The body's centre line (0 / 255), one pixel wide.
cv::Mat centre_line(const cv::Mat& body) {
  // eq. 8-9: thinning A (x) B = A - (A hit-or-miss B), iterated with Zhang-Suen's pair of
  // sub-iterations until nothing changes: a one-pixel wide, 8-connected centre line.
  // Zhang-Suen is local, so only the bounding box of the paint is thinned (the cost of
  // OpenCV's implementation grows with the image it scans), inside a one-pixel frame of
  // background: OpenCV never deletes the outermost row and column of its input, which would
  // otherwise leave a route leaving the frame with a bar along the image border.
  cv::Mat centre = cv::Mat::zeros(body.size(), CV_8UC1);
  const cv::Rect box = cv::boundingRect(body);
  if (box.area() > 0) {
    cv::Mat framed, thin;
    cv::copyMakeBorder(body(box), framed, 1, 1, 1, 1, cv::BORDER_CONSTANT | cv::BORDER_ISOLATED, cv::Scalar(0));
    cv::ximgproc::thinning(framed, thin, cv::ximgproc::THINNING_ZHANGSUEN);
    thin(cv::Rect(1, 1, box.width, box.height)).copyTo(centre(box));
  }
  return centre;
}

// The grid's points in full-resolution raw px (scale factors sx, sy full / work per axis),
// their cells appended to obs.cells and the centre-line pixels counted in
// obs.centerline_pixels.
std::vector<cv::Point2d> grid_points(const cv::Mat& centre, const PathExtractorParams& params_,
                                     double sx, double sy, PathObservation& obs) {
  const int ww = centre.cols, wh = centre.rows;
  // The M x N grid: work pixel (x, y) is in cell (x * M / w, y * N / h) (integer division, so
  // the cells tile the image exactly). Each cell's point is the mean of its centre-line pixels.
  const int M = params_.grid_cols, N = params_.grid_rows;
  std::vector<double> sum_x(M * N, 0.0), sum_y(M * N, 0.0);
  std::vector<int> count(M * N, 0);
  std::vector<int> col_of(ww);
  for (int x = 0; x < ww; ++x) col_of[x] = static_cast<int>(std::int64_t(x) * M / ww);
  for (int y = 0; y < wh; ++y) {
    const unsigned char* c = centre.ptr<unsigned char>(y);
    const int row = static_cast<int>(std::int64_t(y) * N / wh);
    for (int x = 0; x < ww; ++x) {
      if (!c[x]) continue;
      const int k = row * M + col_of[x];
      sum_x[k] += x;
      sum_y[k] += y;
      ++count[k];
      ++obs.centerline_pixels;
    }
  }

  // Work pixel i covers full-resolution [i * s, (i + 1) * s) in edge coordinates (the full-res
  // pixel k spans [k, k + 1)); its centre (i + 0.5) s is the OpenCV pixel position
  // (i + 0.5) s - 0.5 (the convention INTER_AREA resizes with).
  std::vector<cv::Point2d> raw;
  for (int k = 0; k < M * N; ++k) {
    if (count[k] < params_.min_cell_pixels) continue;
    const double mx = sum_x[k] / count[k], my = sum_y[k] / count[k];
    raw.emplace_back((mx + 0.5) * sx - 0.5, (my + 0.5) * sy - 0.5);
    obs.cells.emplace_back(k % M, k / M);
  }
  return raw;
}

}  // namespace

PathObservation PathExtractor::extract(const cv::Mat& bgr, Debug* debug) const {
  const auto t0 = std::chrono::steady_clock::now();
  PathObservation obs;
  obs.fx = cam_.fx_px;
  obs.fy = cam_.fy_px;
  obs.cx = cam_.cx_px;
  obs.cy = cam_.cy_px;
  obs.width_px = cam_.width_px;
  obs.height_px = cam_.height_px;
  const auto finish = [&]() {
    obs.valid = !obs.points_px.empty();
    obs.process_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return obs;
  };
  if (debug) *debug = Debug{};
  // Bad content is not an error of the caller's program: no points.
  if (!params_.enabled || bgr.empty() || bgr.type() != CV_8UC3 || bgr.cols != cam_.width_px ||
      bgr.rows != cam_.height_px)
    return finish();

  // Work resolution: width work_width_px, aspect kept. Scale factors full / work per axis.
  const cv::Mat small = work_image(bgr, params_.work_width_px);
  const double sx = double(bgr.cols) / small.cols, sy = double(bgr.rows) / small.rows;
  // The paint (eq. 6), its body (eq. 7) and centre line (eq. 8-9).
  const cv::Mat mask = paint_mask(small, params_);
  obs.paint_pixels = cv::countNonZero(mask);
  if (debug) debug->mask = mask.clone();
  const cv::Mat centre = centre_line(route_body(mask, params_));
  if (debug) debug->centerline = centre.clone();
  // One point per grid cell on the centre line.
  const std::vector<cv::Point2d> raw = grid_points(centre, params_, sx, sy, obs);
  if (raw.empty()) return finish();

  // The points lie on the distorted image: undistort them into the calibration's pinhole
  // image (P = K), iterating past OpenCV's default 5 steps for strong distortion.
  std::vector<cv::Point2d> und;
  if (cam_.has_distortion()) {
    cv::undistortPoints(raw, und, K_, dist_, cv::noArray(), K_,
                        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30,
                                         1e-9));
  } else {
    und = raw;
  }
  obs.points_px.reserve(und.size());
  obs.points_n.reserve(und.size());
  for (const auto& p : und) {
    obs.points_px.emplace_back(p.x, p.y);
    obs.points_n.emplace_back((p.x - cam_.cx_px) / cam_.fx_px, (p.y - cam_.cy_px) / cam_.fy_px);
  }
  return finish();
}

}  // namespace lander
