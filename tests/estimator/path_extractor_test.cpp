// Tests of the path-extraction stage (seed 003 section 3: eq. 6 colour threshold, eq. 7
// erosion, eq. 8-9 thinning, M x N grid centre points) on synthetic 1280x720 frames whose
// route centre line is known exactly: a noisy grey asphalt-like background, the route painted
// as a thick anti-aliased polyline in the colour a MuJoCo render gives red paint
// rgba (0.85, 0.1, 0.1) under the world's sun + ambient light.
//
// Given a route of known centre polyline and width, When the frame is extracted, Then
//  - every point lies on the truth centre line within a stated tolerance (straight parts,
//    arcs and corner cells each have their own, derived below);
//  - every grid cell the route crosses by more than a stated length gives a point;
//  - nothing is found on distractors, in gaps, or without a route.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "lander/estimator/path_extractor.h"

namespace lander {
namespace {

using Polyline = std::vector<Eigen::Vector2d>;

constexpr int kW = 1280, kH = 720;
constexpr double kPi = 3.14159265358979323846;

// Work resolution of the default params: 1280 / 320 = 4 full-resolution px per work px.
constexpr double kWorkPx = 4.0;
// Default grid 10 x 10 on 1280 x 720: cells of 128 x 72 px, diagonal 146.9 px.
const double kCellDiagPx = std::hypot(128.0, 72.0);

// Route widths: 0.2 m (the paper's route) at 4 m height with fx = 900 px is 45 px; a thin
// route of 16 px is 4 work px, 2 after the 3 x 3 erosion.
constexpr double kWideRoutePx = 45.0;
constexpr double kThinRoutePx = 16.0;

// ---- tolerances (each with its reason) ----
// Straight parts: the thinned line of a band of even width at work resolution is ambiguous by
// half a work pixel, and an anti-aliased edge pixel joining or leaving the eq. 6 mask on one
// side moves the middle by another half: one work pixel, 4 px.
constexpr double kOnLineTolPx = kWorkPx;
// Arcs: a cell's point is the mean of the arc's pixels in it, which lies inside the arc by
// about L^2 / (24 R) for a chord L (parabola y = x^2 / 2R averaged over [-L/2, L/2]); L is
// at most the cell diagonal. Added to the straight tolerance.
double arc_tol_px(double radius_px) {
  return kOnLineTolPx + kCellDiagPx * kCellDiagPx / (24.0 * radius_px);
}
// Corner cells (a cell within the corner zone below): the mean of two legs of lengths a, b
// meeting at an angle theta lies off both legs by up to (a / 4) sin(theta) <= a / 4 (a = b,
// theta = 90 deg), a at most the cell diagonal; by design, not an error of the stage (the
// seed cuts corners the same way). Plus the straight tolerance.
const double kCornerCellTolPx = kCellDiagPx / 4.0 + kOnLineTolPx;
// Corner zone: where the two thick legs of interior angle theta overlap, out to
// w / (2 sin(theta / 2)) from the vertex, the thinned line follows the bisector, not the legs;
// cells whose rectangle comes within that radius plus half a width of a vertex are corner
// cells.
double corner_zone_px(double width_px, double theta_rad) {
  return width_px / (2.0 * std::sin(0.5 * theta_rad)) + 0.5 * width_px;
}
// Coverage: the centre line of a thick line ends about half its width before a free end (a
// line end, a gap, the image border), the erosion takes one more work pixel (4 px), and a
// cell needs min_cell_pixels = 2 centre-line work pixels (8 px), one more for a diagonal
// (4 px): any cell the drawn centre line crosses for longer than this must give a point.
double coverage_min_len_px(double width_px) { return 0.5 * width_px + 16.0; }

// ---- scene ----
// The calibration of the tests: fx = fy = 900 px, principal point at the image centre.
CameraModel test_camera(double k1 = 0.0, double k2 = 0.0) {
  CameraModel c;
  c.width_px = kW;
  c.height_px = kH;
  c.fx_px = c.fy_px = 900.0;
  c.cx_px = 639.5;
  c.cy_px = 359.5;
  c.k1 = k1;
  c.k2 = k2;
  return c;
}

// Rendered colours (BGR) of the simulator's materials: MuJoCo multiplies rgba by the light
// (headlight ambient 0.35 + diffuse 0.35, sun 0.55 at ~20 deg: about 1.22 on the ground seen
// from above) and clamps at 1.
cv::Scalar lit(double r, double g, double b, double light = 1.22) {
  const auto c = [&](double v) { return std::min(255.0, std::round(v * light * 255.0)); };
  return cv::Scalar(c(b), c(g), c(r));
}
const cv::Scalar kRedPaint = lit(0.85, 0.1, 0.1);     // (31, 31, 255)
const cv::Scalar kYellowPaint = lit(0.9, 0.8, 0.1);   // (31, 249, 255)
const cv::Scalar kWhitePaint = lit(0.92, 0.92, 0.9);  // (255, 255, 255)
const cv::Scalar kBluePaint = lit(0.15, 0.3, 0.85);   // (255, 93, 47)

// Asphalt-like background: mid grey with large stains and grain, slightly blue like the
// simulator's ground texture (G + 4, B + 8), fixed seed.
cv::Mat asphalt(std::uint64_t seed = 7) {
  cv::RNG rng(seed);
  cv::Mat coarse(9, 16, CV_32F), fine(kH, kW, CV_32F);
  rng.fill(coarse, cv::RNG::NORMAL, 0.0, 18.0);
  cv::Mat stains;
  cv::resize(coarse, stains, cv::Size(kW, kH), 0, 0, cv::INTER_CUBIC);
  rng.fill(fine, cv::RNG::NORMAL, 0.0, 8.0);
  cv::Mat grey = stains + fine + 95.0f;
  cv::Mat g8;
  grey.convertTo(g8, CV_8U);
  cv::Mat bgr;
  cv::merge(std::vector<cv::Mat>{g8 + 8, g8 + 4, g8}, bgr);
  return bgr;
}

// Sensor noise on the finished frame (sigma 4 grey levels), fixed seed.
void add_noise(cv::Mat& img, std::uint64_t seed = 11) {
  cv::RNG rng(seed);
  cv::Mat n(img.size(), CV_16SC3);
  rng.fill(n, cv::RNG::NORMAL, 0.0, 4.0);
  cv::Mat s;
  img.convertTo(s, CV_16SC3);
  s += n;
  s.convertTo(img, CV_8UC3);
}

// Points every `step_px` along a polyline (vertices kept).
Polyline densify(const Polyline& p, double step_px = 1.0) {
  Polyline out;
  for (std::size_t i = 0; i + 1 < p.size(); ++i) {
    const Eigen::Vector2d d = p[i + 1] - p[i];
    const int n = std::max(1, static_cast<int>(std::ceil(d.norm() / step_px)));
    for (int k = 0; k < n; ++k) out.push_back(p[i] + d * (double(k) / n));
  }
  if (!p.empty()) out.push_back(p.back());
  return out;
}

// The polyline as it appears in the delivered (distorted) frame: densely sampled, every sample
// distorted with the camera's model (identity without distortion).
Polyline as_imaged(const Polyline& p, const CameraModel& cam) {
  if (!cam.has_distortion()) return p;
  Polyline out;
  for (const auto& q : densify(p, 1.0)) out.push_back(cam.distort_px(q));
  return out;
}

// Thick anti-aliased polyline (round joins and caps, as cv::polylines draws them), at 1/16 px.
void draw_polyline(cv::Mat& img, const Polyline& p, double width_px, const cv::Scalar& colour) {
  constexpr int kShift = 4;
  std::vector<cv::Point> pts;
  for (const auto& q : p)
    pts.emplace_back(static_cast<int>(std::lround(q.x() * 16)),
                     static_cast<int>(std::lround(q.y() * 16)));
  cv::polylines(img, std::vector<std::vector<cv::Point>>{pts}, false, colour,
                static_cast<int>(std::lround(width_px)), cv::LINE_AA, kShift);
}

double dist_to_segment(const Eigen::Vector2d& q, const Eigen::Vector2d& a,
                       const Eigen::Vector2d& b) {
  const Eigen::Vector2d d = b - a;
  const double t = d.squaredNorm() > 0 ? std::clamp((q - a).dot(d) / d.squaredNorm(), 0.0, 1.0) : 0;
  return (q - (a + t * d)).norm();
}

double dist_to_route(const Eigen::Vector2d& q, const std::vector<Polyline>& route) {
  double best = 1e18;
  for (const auto& p : route)
    for (std::size_t i = 0; i + 1 < p.size(); ++i) best = std::min(best, dist_to_segment(q, p[i], p[i + 1]));
  return best;
}

// Cell rectangle in full-resolution edge coordinates (OpenCV pixel x covers [x - 0.5, x + 0.5)),
// for the default grid at the default work resolution: work columns [ceil(c w / M), ...).
struct CellRect {
  double x0, y0, x1, y1;
};
CellRect cell_rect(int col, int row, const PathExtractorParams& p) {
  const int ww = p.work_width_px;
  const int wh = static_cast<int>(std::lround(double(kH) * ww / kW));
  const auto lo = [](int i, int n, int w) { return (std::int64_t(i) * w + n - 1) / n; };
  const double s = double(kW) / ww;
  return {lo(col, p.grid_cols, ww) * s - 0.5, lo(row, p.grid_rows, wh) * s - 0.5,
          lo(col + 1, p.grid_cols, ww) * s - 0.5, lo(row + 1, p.grid_rows, wh) * s - 0.5};
}

double dist_point_rect(const Eigen::Vector2d& q, const CellRect& r) {
  const double dx = std::max({r.x0 - q.x(), 0.0, q.x() - r.x1});
  const double dy = std::max({r.y0 - q.y(), 0.0, q.y() - r.y1});
  return std::hypot(dx, dy);
}

// Length of the (imaged) route inside each cell shrunk by `margin_px` on every side, by
// 0.25 px samples; index row * M + col.
std::vector<double> length_per_cell(const std::vector<Polyline>& imaged,
                                    const PathExtractorParams& p, double margin_px) {
  std::vector<double> len(p.grid_cols * p.grid_rows, 0.0);
  for (const auto& pl : imaged) {
    const Polyline d = densify(pl, 0.25);
    for (std::size_t i = 0; i + 1 < d.size(); ++i) {
      const Eigen::Vector2d m = 0.5 * (d[i] + d[i + 1]);
      for (int r = 0; r < p.grid_rows; ++r)
        for (int c = 0; c < p.grid_cols; ++c) {
          const CellRect cr = cell_rect(c, r, p);
          if (m.x() >= cr.x0 + margin_px && m.x() < cr.x1 - margin_px &&
              m.y() >= cr.y0 + margin_px && m.y() < cr.y1 - margin_px)
            len[r * p.grid_cols + c] += (d[i + 1] - d[i]).norm();
        }
    }
  }
  return len;
}

// A route for a test: its centre polylines (undistorted px) as drawn, width, corner vertices
// with their interior angles.
struct Route {
  std::vector<Polyline> drawn;
  double width_px{kWideRoutePx};
  std::vector<std::pair<Eigen::Vector2d, double>> corners;  // vertex (px), interior angle (rad)
  double arc_radius_px{0.0};                                  // > 0: the route is an arc
};

// Interior angle at vertex b of the polyline a-b-c.
double interior_angle(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  const Eigen::Vector2d u = (a - b).normalized(), v = (c - b).normalized();
  return std::acos(std::clamp(u.dot(v), -1.0, 1.0));
}

Route corner_route(const Polyline& p, double width_px = kWideRoutePx) {
  Route r;
  r.drawn = {p};
  r.width_px = width_px;
  for (std::size_t i = 1; i + 1 < p.size(); ++i)
    r.corners.emplace_back(p[i], interior_angle(p[i - 1], p[i], p[i + 1]));
  return r;
}

cv::Mat frame_of(const Route& route, const CameraModel& cam, const cv::Scalar& colour = kRedPaint) {
  cv::Mat img = asphalt();
  for (const auto& p : route.drawn) draw_polyline(img, as_imaged(p, cam), route.width_px, colour);
  add_noise(img);
  return img;
}

struct CheckResult {
  double worst_line_px{0.0};    // worst distance of a point outside corner cells
  double worst_corner_px{0.0};  // worst distance of a point in a corner cell
  int points{0};
};

// The checks every route test shares: truth distance per point (corner cells apart) and
// coverage. `name` labels the printed measurements.
CheckResult check_route(const std::string& name, const Route& route, const CameraModel& cam,
                        const PathObservation& obs, const PathExtractorParams& p = {}) {
  CheckResult res;
  EXPECT_TRUE(obs.valid) << name;
  EXPECT_EQ(obs.points_px.size(), obs.points_n.size());
  EXPECT_EQ(obs.points_px.size(), obs.cells.size());
  res.points = static_cast<int>(obs.points_px.size());
  const double line_tol =
      route.arc_radius_px > 0 ? arc_tol_px(route.arc_radius_px) : kOnLineTolPx;
  std::vector<bool> has_point(p.grid_cols * p.grid_rows, false);
  for (std::size_t i = 0; i < obs.points_px.size(); ++i) {
    const Eigen::Vector2d& q = obs.points_px[i];
    const Eigen::Vector2i cell = obs.cells[i];
    has_point[cell.y() * p.grid_cols + cell.x()] = true;
    // Normalised coordinates agree with the pixels.
    EXPECT_NEAR(obs.points_n[i].x(), (q.x() - cam.cx_px) / cam.fx_px, 1e-12);
    EXPECT_NEAR(obs.points_n[i].y(), (q.y() - cam.cy_px) / cam.fy_px, 1e-12);
    // Corner cell: its rectangle (in the delivered image) near a corner vertex (imaged).
    const CellRect cr = cell_rect(cell.x(), cell.y(), p);
    bool corner = false;
    for (const auto& [v, theta] : route.corners) {
      const Eigen::Vector2d vi = cam.has_distortion() ? cam.distort_px(v) : v;
      corner = corner || dist_point_rect(vi, cr) < corner_zone_px(route.width_px, theta);
    }
    const double d = dist_to_route(q, route.drawn);
    if (corner) {
      res.worst_corner_px = std::max(res.worst_corner_px, d);
      EXPECT_LT(d, kCornerCellTolPx) << name << ": corner cell (" << cell.x() << ", " << cell.y()
                                     << ") point (" << q.x() << ", " << q.y() << ")";
    } else {
      res.worst_line_px = std::max(res.worst_line_px, d);
      EXPECT_LT(d, line_tol) << name << ": cell (" << cell.x() << ", " << cell.y() << ") point ("
                             << q.x() << ", " << q.y() << ")";
    }
  }
  // Coverage: cells the imaged centre line crosses for long enough, counting only the part
  // farther than the line tolerance inside the cell (the centre line found may lie up to that
  // far from the truth, so a route along a cell edge may give its points to the neighbour).
  std::vector<Polyline> imaged;
  for (const auto& pl : route.drawn) imaged.push_back(as_imaged(pl, cam));
  const std::vector<double> len = length_per_cell(imaged, p, line_tol);
  const double min_len = coverage_min_len_px(route.width_px);
  for (int k = 0; k < p.grid_cols * p.grid_rows; ++k) {
    if (len[k] > min_len) {
      EXPECT_TRUE(has_point[k]) << name << ": cell (" << k % p.grid_cols << ", "
                                << k / p.grid_cols << ") crossed for " << len[k]
                                << " px gives no point";
    }
  }
  std::printf("[path] %-22s points %2d  worst line %.2f px (tol %.2f)  worst corner-cell %.2f px "
              "(tol %.2f)  %.2f ms\n",
              name.c_str(), res.points, res.worst_line_px, line_tol, res.worst_corner_px,
              kCornerCellTolPx, obs.process_ms);
  return res;
}

CheckResult run_route(const std::string& name, const Route& route,
                      const CameraModel& cam = test_camera(), const PathExtractorParams& p = {}) {
  const PathExtractor ex(cam, p);
  return check_route(name, route, cam, ex.extract(frame_of(route, cam)), p);
}

// ---- params ----
TEST(PathExtractorParams, DefaultIsValid) { EXPECT_NO_THROW(PathExtractorParams{}.validate()); }

TEST(PathExtractorParams, SaveLoadRoundTrip) {
  PathExtractorParams p;
  p.enabled = false;
  p.work_width_px = 160;
  p.r_min = 20;
  p.r_max = 90;
  p.g_min = 5;
  p.g_max = 100;
  p.b_min = 160;
  p.b_max = 250;
  p.min_dominance = 0.0;
  p.erode_px = 5;
  p.grid_cols = 8;
  p.grid_rows = 6;
  p.min_cell_pixels = 3;
  p.min_component_px = 0;
  const YAML::Node node = YAML::Load(yaml_to_string(params_to_yaml(p)));
  PathExtractorParams q;
  read_params(node, "roundtrip.yaml", q);
  EXPECT_EQ(yaml_to_string(params_to_yaml(q)), yaml_to_string(params_to_yaml(p)));
  EXPECT_FALSE(q.enabled);
  EXPECT_EQ(q.work_width_px, 160);
  EXPECT_EQ(q.b_min, 160);
  EXPECT_EQ(q.erode_px, 5);
  EXPECT_EQ(q.grid_rows, 6);
  EXPECT_EQ(q.min_component_px, 0);
}

TEST(PathExtractorParams, BadValueNamesField) {
  const auto expect_names = [](const char* yaml, const char* field) {
    PathExtractorParams p;
    try {
      read_params(YAML::Load(yaml), "bad.yaml", p);
      FAIL() << "no exception for " << yaml;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("'") + field + "'"), std::string::npos)
          << e.what();
    }
  };
  expect_names("grid_cols: 0", "grid_cols");
  expect_names("grid_rows: 101", "grid_rows");
  expect_names("work_width_px: 8", "work_width_px");
  expect_names("{r_min: 200, r_max: 100}", "r_min");
  expect_names("g_max: 256", "g_max");
  expect_names("b_min: -1", "b_min");
  expect_names("min_dominance: -5", "min_dominance");
  expect_names("erode_px: 2", "erode_px");
  expect_names("min_cell_pixels: 0", "min_cell_pixels");
  expect_names("min_component_px: -1", "min_component_px");
  expect_names("no_such_key: 1", "no_such_key");
}

TEST(PathExtractor, ConstructorRejectsBadParamsAndCalibration) {
  PathExtractorParams p;
  p.grid_cols = 0;
  EXPECT_THROW(PathExtractor(test_camera(), p), ConfigError);
  CameraModel c = test_camera();
  c.fx_px = 0;
  EXPECT_THROW(PathExtractor(c, PathExtractorParams{}), ConfigError);
}

// ---- the default colour threshold against the simulator's rendered colours ----
TEST(PathExtractor, DefaultThresholdTakesLitRedPaintOnly) {
  const PathExtractor ex(test_camera(), {});
  const auto is_paint = [&](const cv::Scalar& bgr) {
    cv::Mat img(kH, kW, CV_8UC3, bgr);
    PathExtractor::Debug dbg;
    ex.extract(img, &dbg);
    return cv::countNonZero(dbg.mask) == dbg.mask.rows * dbg.mask.cols;
  };
  // Red paint from full light (1.22: sun + headlight + ambient) down to 0.5 (camera tilted
  // away from the headlight and the sun shadowed).
  for (double light : {1.22, 1.0, 0.87, 0.7, 0.5})
    EXPECT_TRUE(is_paint(lit(0.85, 0.1, 0.1, light))) << "light " << light;
  // Not paint: asphalt greys of the ground texture (R lowest), white, yellow, blue, the brown
  // cart, orange.
  for (int g : {40, 95, 150, 200}) EXPECT_FALSE(is_paint(cv::Scalar(g + 8, g + 4, g))) << g;
  EXPECT_FALSE(is_paint(kWhitePaint));
  EXPECT_FALSE(is_paint(kYellowPaint));
  EXPECT_FALSE(is_paint(kBluePaint));
  EXPECT_FALSE(is_paint(lit(0.35, 0.3, 0.25)));
  EXPECT_FALSE(is_paint(lit(0.9, 0.5, 0.1)));
}

// ---- routes ----
TEST(PathExtractor, StraightWideRoute) {
  const Route r = corner_route({{100, 650}, {1180, 80}});
  run_route("straight 45 px", r);
}

TEST(PathExtractor, StraightThinRoute) {
  const Route r = corner_route({{60, 200}, {1220, 560}}, kThinRoutePx);
  run_route("straight 16 px", r);
}

TEST(PathExtractor, StraightRouteWithoutErosion) {
  // erode_px = 1: the mask reaches the image border where the route leaves the frame; the
  // thinning must not leave a bar along the border there (OpenCV's thinning never deletes its
  // input's outermost pixels).
  PathExtractorParams p;
  p.erode_px = 1;
  const Route r = corner_route({{-40, 700}, {1320, 20}});
  run_route("straight, no erosion", r, test_camera(), p);
}

TEST(PathExtractor, RightAngleCorner) {
  // Vertex in the middle of cell (5, 8) (x 639.5 .. 767.5, y 575.5 .. 647.5): the cell's point
  // is the mean of both legs.
  const Route r = corner_route({{150, 610}, {700, 610}, {700, 40}});
  run_route("right angle", r);
}

TEST(PathExtractor, RightAngleCornerThin) {
  // Vertex on a cell corner, the vertical leg along the edge between columns 4 and 5.
  const Route r = corner_route({{150, 600}, {640, 600}, {640, 40}}, kThinRoutePx);
  run_route("right angle 16 px", r);
}

TEST(PathExtractor, AcuteCorner) {
  // 40 deg between the legs, vertex inside cell (7, 5) (x 895.5 .. 1023.5, y 359.5 .. 431.5).
  const Eigen::Vector2d v(960, 400);
  const double a = 20.0 * kPi / 180.0;
  const Route r = corner_route({v + 700 * Eigen::Vector2d(-std::cos(a), std::sin(a)), v,
                                v + 700 * Eigen::Vector2d(-std::cos(a), -std::sin(a))});
  ASSERT_NEAR(r.corners[0].second, 2 * a, 1e-9);
  run_route("acute 40 deg", r);
}

TEST(PathExtractor, ObtuseCorner) {
  // 135 deg between the legs, vertex inside cell (4, 7) (x 511.5 .. 639.5, y 503.5 .. 575.5).
  const Route r = corner_route(
      {{100, 540}, {580, 540}, {580 + 480 * std::cos(kPi / 4), 540 - 480 * std::sin(kPi / 4)}});
  ASSERT_NEAR(r.corners[0].second, 3 * kPi / 4, 1e-9);
  run_route("obtuse 135 deg", r);
}

TEST(PathExtractor, Arc) {
  // Three quarters of a circle of radius 250 px about the image centre.
  Route r;
  r.arc_radius_px = 250.0;
  Polyline p;
  for (int i = 0; i <= 270; ++i) {
    const double phi = (90.0 + i) * kPi / 180.0;
    p.emplace_back(640 + 250 * std::cos(phi), 360 + 250 * std::sin(phi));
  }
  r.drawn = {p};
  run_route("arc R 250 px", r);
}

TEST(PathExtractor, GapCellsGiveNoPoints) {
  // A horizontal route with a gap: the cells of columns 4 and 5 (x 511.5 .. 767.5) lie wholly
  // inside the gap, whose painted ends (round caps of half the width) stop at x 492.5 and
  // 787.5.
  Route r;
  r.drawn = {{{40, 330}, {470, 330}}, {{810, 330}, {1240, 330}}};
  const PathExtractor ex(test_camera(), {});
  const PathObservation obs = ex.extract(frame_of(r, test_camera()));
  check_route("gap", r, test_camera(), obs);
  for (std::size_t i = 0; i < obs.cells.size(); ++i) {
    EXPECT_NE(obs.cells[i].x(), 4) << "point in the gap at x " << obs.points_px[i].x();
    EXPECT_NE(obs.cells[i].x(), 5) << "point in the gap at x " << obs.points_px[i].x();
  }
  // Both sides give points: columns 0-3 and 6-9 on row 4 (y 288 .. 359.5).
  EXPECT_EQ(obs.points_px.size(), 8u);
}

// Distractors: a yellow and a white stripe crossing the route and a blue patch beside it.
void draw_distractors(cv::Mat& img) {
  cv::rectangle(img, cv::Rect(300, 0, 40, kH), kYellowPaint, cv::FILLED, cv::LINE_AA);
  cv::rectangle(img, cv::Rect(0, 500, kW, 35), kWhitePaint, cv::FILLED, cv::LINE_AA);
  cv::rectangle(img, cv::Rect(900, 80, 200, 150), kBluePaint, cv::FILLED, cv::LINE_AA);
}

TEST(PathExtractor, DistractorsOfOtherColoursGiveNoPoints) {
  Route r;
  r.drawn = {{{80, 120}, {1200, 640}}};
  cv::Mat img = asphalt();
  draw_distractors(img);
  draw_polyline(img, r.drawn[0], r.width_px, kRedPaint);
  add_noise(img);
  const PathExtractor ex(test_camera(), {});
  PathExtractor::Debug dbg;
  const PathObservation obs = ex.extract(img, &dbg);
  // All points on the red centre line (a point on a distractor would be far from it); the
  // route is painted over the yellow and white stripes it crosses.
  check_route("distractors", r, test_camera(), obs);
  // No paint pixel on the distractors away from the route.
  cv::Mat route_zone = cv::Mat::zeros(dbg.mask.size(), CV_8UC1);
  std::vector<cv::Point> pts;
  for (const auto& q : r.drawn[0]) pts.emplace_back(int(q.x() / kWorkPx), int(q.y() / kWorkPx));
  cv::polylines(route_zone, std::vector<std::vector<cv::Point>>{pts}, false, 255,
                int(r.width_px / kWorkPx) + 4);
  cv::Mat outside = dbg.mask & ~route_zone;
  EXPECT_EQ(cv::countNonZero(outside), 0);
}

TEST(PathExtractor, NoRouteIsInvalid) {
  cv::Mat img = asphalt();
  draw_distractors(img);
  add_noise(img);
  const PathExtractor ex(test_camera(), {});
  const PathObservation obs = ex.extract(img);
  EXPECT_FALSE(obs.valid);
  EXPECT_TRUE(obs.points_px.empty());
  EXPECT_EQ(obs.paint_pixels, 0);
  EXPECT_EQ(obs.centerline_pixels, 0);
  // The intrinsics are reported even without points.
  EXPECT_EQ(obs.fx, 900.0);
  EXPECT_EQ(obs.width_px, kW);
}

TEST(PathExtractor, BadImagesAreInvalidWithoutThrowing) {
  const PathExtractor ex(test_camera(), {});
  PathObservation obs;
  EXPECT_NO_THROW(obs = ex.extract(cv::Mat()));
  EXPECT_FALSE(obs.valid);
  EXPECT_NO_THROW(obs = ex.extract(cv::Mat(kH, kW, CV_8UC1, cv::Scalar(128))));
  EXPECT_FALSE(obs.valid);
  EXPECT_TRUE(obs.points_px.empty());
  // Another size than the calibration's: the points could not be placed.
  cv::Mat small(360, 640, CV_8UC3, kRedPaint);
  EXPECT_NO_THROW(obs = ex.extract(small));
  EXPECT_FALSE(obs.valid);
  PathExtractor::Debug dbg;
  EXPECT_NO_THROW(obs = ex.extract(cv::Mat(), &dbg));
  EXPECT_FALSE(obs.valid);
}

TEST(PathExtractor, DisabledGivesNothing) {
  PathExtractorParams p;
  p.enabled = false;
  const Route r = corner_route({{100, 650}, {1180, 80}});
  const PathObservation obs = PathExtractor(test_camera(), p).extract(frame_of(r, test_camera()));
  EXPECT_FALSE(obs.valid);
  EXPECT_TRUE(obs.points_px.empty());
}

TEST(PathExtractor, BlueRouteWithBlueThreshold) {
  // The route colour is configuration: a blue route with a blue window (dominance off, since
  // it measures red), the red paint is now a distractor.
  PathExtractorParams p;
  p.r_min = 0;
  p.r_max = 110;
  p.g_max = 140;
  p.b_min = 150;
  p.b_max = 255;
  p.min_dominance = 0;
  const Route r = corner_route({{150, 600}, {640, 600}, {640, 40}});
  cv::Mat img = asphalt();
  draw_polyline(img, {{100, 100}, {400, 300}}, kWideRoutePx, kRedPaint);
  draw_polyline(img, r.drawn[0], r.width_px, kBluePaint);
  add_noise(img);
  const PathExtractor ex(test_camera(), p);
  check_route("blue route", r, test_camera(), ex.extract(img), p);
}

TEST(PathExtractor, DistortedFrameGivesUndistortedPoints) {
  // Barrel distortion of a wide-angle lens (about 34 px at the top-left corner of the route):
  // the route is drawn through the distortion, the points must lie on the undistorted truth.
  const CameraModel cam = test_camera(-0.12, 0.03);
  Route r = corner_route({{80, 110}, {1100, 110}, {1100, 660}});
  const CheckResult res = run_route("distorted", r, cam);
  // Control: the same frame read with a calibration that ignores the distortion is off the
  // truth by far more than the tolerance, so the check above does test the undistortion.
  const PathExtractor wrong(test_camera(), {});
  const PathObservation obs = wrong.extract(frame_of(r, cam));
  double worst = 0.0;
  for (const auto& q : obs.points_px) worst = std::max(worst, dist_to_route(q, r.drawn));
  EXPECT_GT(worst, 3 * kOnLineTolPx);
  std::printf("[path] distorted, read as undistorted: worst %.2f px\n", worst);
  EXPECT_GT(res.points, 10);
}

TEST(PathExtractor, CentrePointConventionIsExact) {
  // A vertical route whose centre is at x = 641.5 (OpenCV px): work pixel 160 (full-res
  // 640 .. 643, centre 641.5) is its middle after the resize; the points must sit on it to
  // well under a work pixel, which the pixel-centre conversion decides ((i + 0.5) s - 0.5;
  // i s would give 640, (i + 0.5) s 642).
  cv::Mat img(kH, kW, CV_8UC3, cv::Scalar(108, 104, 100));
  // Columns 620 .. 663 (44 px = 11 work px, 160 +- 5) painted exactly, no anti-aliasing.
  img(cv::Rect(620, 0, 44, kH)).setTo(kRedPaint);
  const PathExtractor ex(test_camera(), {});
  const PathObservation obs = ex.extract(img);
  ASSERT_TRUE(obs.valid);
  for (const auto& q : obs.points_px) EXPECT_NEAR(q.x(), 641.5, 0.25);
}

}  // namespace
}  // namespace lander
