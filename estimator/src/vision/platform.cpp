// The platform pass (issue 12: far and grazing views): where the ring sets are a few pixels
// across, no threshold separates them (the 0.08 m gaps between sets are 1-2 px and grey, the
// sets themselves read 100-150 of 255 at their darkest, as dark as the ground), so contours
// merge sets with each other or break them into arcs. The platform's white top is still a
// clear bright quadrilateral. Its outline gives a homography of the target's plane up to the
// square's four turns; the turns fall into two placements of the hexagon (a turn of 180 deg,
// and the mirror, keep every set's place), and each placement predicts the ring sets' outer
// circles. Those predictions are the ellipse guesses whose sub-pixel edges are then searched
// as a contour's would be (refine_candidate); identification (the ratios, the layout) and the
// acceptance gates are the detector's own, unchanged. The outline only says where to look.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "lander/estimator/camera_cv.h"
#include "vision/internal.h"

namespace lander::vision_internal {
namespace {

// Levels (fractions of the frame's white reference) at which the platform's top is
// segmented: the top is the scene's white (0.9-1 of the reference), the ground around it
// 0.3-0.5; two levels, because a grazing top fades towards its far edge.
constexpr double kTopLevels[] = {0.75, 0.6};
// A top's outline: its contour fills at least this fraction of the fitted quadrilateral (the
// ring sets are holes inside it and do not count against it), and its shortest side is at
// least this long (px).
constexpr double kMinSolidity = 0.8;
constexpr double kMinSidePx = 6.0;
// Outline sides are re-fitted as lines to the contour points within this distance of the
// side, leaving out this fraction of its length at each end (the corners are rounded).
constexpr double kSideBandPx = 2.0;
constexpr double kSideEndFraction = 0.15;
// Two quadrilaterals whose corners are all within this of each other are one (px).
constexpr double kSameQuadPx = 3.0;
// The pass's pose must put the top's corners on its outline within the larger of these (px,
// and a fraction of the outline's shortest side): the outline's corners are found to about a
// pixel, while a wrong identity of the sets (a turn by 60 or 120 deg) moves them by a third of
// the side or more.
constexpr double kCornerMinGatePx = 2.0;
constexpr double kCornerGateFraction = 0.1;

// The shortest side of a quadrilateral given by its corners in cyclic order (px).
double shortest_side_px(const std::array<Eigen::Vector2d, 4>& corners) {
  double side = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 4; ++k) side = std::min(side, (corners[k] - corners[(k + 1) % 4]).norm());
  return side;
}

// The platform top's corners in P (m), in cyclic order.
std::array<Eigen::Vector2d, 4> top_corners_P(const TargetGeometry& target) {
  const double hx = 0.5 * target.platform_size_m.x(), hy = 0.5 * target.platform_size_m.y();
  return {Eigen::Vector2d(-hx, -hy), Eigen::Vector2d(hx, -hy), Eigen::Vector2d(hx, hy),
          Eigen::Vector2d(-hx, hy)};
}

std::optional<Eigen::Vector2d> intersect(const cv::Vec4f& l1, const cv::Vec4f& l2) {
  // Lines as (vx, vy, x0, y0): x0 + s v1 = x0' + t v2.
  const Eigen::Vector2d v1(l1[0], l1[1]), p1(l1[2], l1[3]);
  const Eigen::Vector2d v2(l2[0], l2[1]), p2(l2[2], l2[3]);
  const double den = v1.x() * v2.y() - v1.y() * v2.x();
  if (std::abs(den) < 1e-6) return std::nullopt;
  const Eigen::Vector2d d = p2 - p1;
  const double s = (d.x() * v2.y() - d.y() * v2.x()) / den;
  return p1 + s * v1;
}

// The quadrilateral `approx` (4 hull vertices) with each side re-fitted to the contour points
// along it; nullopt when a side has too few points or the corners move far.
std::optional<std::array<Eigen::Vector2d, 4>> refine_quad(const std::vector<cv::Point>& contour,
                                                          const std::vector<cv::Point>& approx) {
  std::array<cv::Vec4f, 4> lines;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d a(approx[k].x, approx[k].y),
        b(approx[(k + 1) % 4].x, approx[(k + 1) % 4].y);
    const Eigen::Vector2d u = (b - a).normalized();
    const double len = (b - a).norm();
    std::vector<cv::Point2f> pts;
    for (const cv::Point& q : contour) {
      const Eigen::Vector2d r = Eigen::Vector2d(q.x, q.y) - a;
      const double s = r.dot(u);
      if (s < kSideEndFraction * len || s > (1 - kSideEndFraction) * len) continue;
      if (std::abs(u.x() * r.y() - u.y() * r.x()) > kSideBandPx) continue;
      pts.emplace_back(static_cast<float>(q.x), static_cast<float>(q.y));
    }
    if (pts.size() < 3) return std::nullopt;
    cv::fitLine(pts, lines[k], cv::DIST_HUBER, 0, 0.01, 0.01);
  }
  std::array<Eigen::Vector2d, 4> corners;
  for (int k = 0; k < 4; ++k) {
    // Corner k + 1 is where side k meets side k + 1.
    const auto c = intersect(lines[k], lines[(k + 1) % 4]);
    const Eigen::Vector2d v(approx[(k + 1) % 4].x, approx[(k + 1) % 4].y);
    if (!c || (*c - v).norm() > 4.0) return std::nullopt;
    corners[(k + 1) % 4] = *c;
  }
  return corners;
}

}  // namespace

std::vector<PlatformQuad> platform_quads(const cv::Mat& grey, const VisionParams& p) {
  std::vector<PlatformQuad> quads;
  if (grey.empty() || grey.type() != CV_8UC1) return quads;
  // White reference: the brightest level that a quarter of the smallest top reaches (the top
  // is the scene's white, and far away it covers well under 0.1 % of the frame, so a
  // percentile of the frame would fall on the ground).
  const int white = bright_level(grey, 0.25 * p.platform_min_area_px);
  const double max_area = 0.5 * static_cast<double>(grey.total());
  cv::Mat bin;
  std::vector<std::vector<cv::Point>> contours;
  for (double f : kTopLevels) {
    cv::threshold(grey, bin, f * white, 255, cv::THRESH_BINARY);
    contours.clear();
    cv::findContours(bin, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
    for (const auto& c : contours) {
      const double area = cv::contourArea(c);
      if (area < p.platform_min_area_px || area > max_area) continue;
      // A contour on the frame's border is not a whole top.
      const cv::Rect br = cv::boundingRect(c);
      if (br.x <= 0 || br.y <= 0 || br.x + br.width >= grey.cols || br.y + br.height >= grey.rows) {
        continue;
      }
      std::vector<cv::Point> hull, approx;
      cv::convexHull(c, hull);
      cv::approxPolyDP(hull, approx, 0.04 * cv::arcLength(hull, true), true);
      if (approx.size() != 4 || !cv::isContourConvex(approx)) continue;
      if (area < kMinSolidity * cv::contourArea(approx)) continue;
      const auto corners = refine_quad(c, approx);
      if (!corners) continue;
      if (shortest_side_px(*corners) < kMinSidePx) continue;
      bool dup = false;
      for (const auto& q : quads) {
        // The same top at the other level: corners in the same cyclic order, maybe shifted.
        for (int s = 0; s < 4 && !dup; ++s) {
          bool all = true;
          for (int k = 0; k < 4; ++k) {
            all &= ((*corners)[k] - q.corners[(k + s) % 4]).norm() < kSameQuadPx;
          }
          dup = all;
        }
      }
      if (!dup) quads.push_back({*corners, area});
    }
  }
  std::sort(quads.begin(), quads.end(),
            [](const PlatformQuad& a, const PlatformQuad& b) { return a.area > b.area; });
  if (static_cast<int>(quads.size()) > p.platform_max_quads) quads.resize(p.platform_max_quads);
  return quads;
}

std::vector<EllipseParams> platform_set_guesses(const PlatformQuad& q, int placement,
                                                const CameraModel& cam,
                                                const TargetGeometry& target) {
  std::vector<EllipseParams> out;
  // The top's corners in P, in cyclic order; `placement` 1 starts one corner on (a turn of
  // 90 deg). Either sense of the cycle gives the same places (the hexagon is symmetric
  // about P's x axis), so the image's orientation of the quadrilateral does not matter.
  const std::array<Eigen::Vector2d, 4> model = top_corners_P(target);
  std::vector<cv::Point2d> src(4), raw(4), und;
  for (int k = 0; k < 4; ++k) {
    src[k] = cv::Point2d(model[(k + placement) % 4].x(), model[(k + placement) % 4].y());
    raw[k] = cv::Point2d(q.corners[k].x(), q.corners[k].y());
  }
  if (cam.has_distortion()) {
    cv::undistortPoints(raw, und, camera_matrix_cv(cam), dist_coeffs_cv(cam), cv::noArray(),
                        camera_matrix_cv(cam));
  } else {
    und = raw;
  }
  std::vector<cv::Point2f> srcf(4), undf(4);
  for (int k = 0; k < 4; ++k) {
    srcf[k] = cv::Point2f(static_cast<float>(src[k].x), static_cast<float>(src[k].y));
    undf[k] = cv::Point2f(static_cast<float>(und[k].x), static_cast<float>(und[k].y));
  }
  // Float points (OpenCV's four-point solver takes no others); corners carry ~0.1 px anyway.
  const cv::Mat H = cv::getPerspectiveTransform(srcf, undf);
  if (H.empty()) return out;
  Eigen::Matrix3d He;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) He(r, c) = H.at<double>(r, c);
  }
  constexpr int kPoints = 24;
  auto guess = [&](const Eigen::Vector2d& centre, double radius) {
    std::vector<Eigen::Vector2d> pts;
    for (int k = 0; k < kPoints; ++k) {
      const double a = 2 * M_PI * k / kPoints;
      const Eigen::Vector3d m(centre.x() + radius * std::cos(a), centre.y() + radius * std::sin(a),
                              1);
      const Eigen::Vector3d u = He * m;
      if (!(u.z() > 1e-9)) return;
      pts.push_back(cam.distort_px(u.head<2>() / u.z()));
    }
    const auto C = fit_ellipse(pts);
    const auto e = C ? ellipse_from_conic(*C) : std::nullopt;
    if (e) out.push_back(*e);
  };
  for (const auto& ring : target.rings) {
    guess(ring.centre_P_m, ring.outer_radius_m);
    if (ring.centre_P_m.norm() < 1e-9) guess(ring.centre_P_m, ring.inner_radius_m);
  }
  return out;
}

double platform_corner_gate_px(const PlatformQuad& q) {
  return std::max(kCornerMinGatePx, kCornerGateFraction * shortest_side_px(q.corners));
}

double platform_corner_error_px(const PlatformQuad& q, const Eigen::Isometry3d& X_CP,
                                const CameraModel& cam, const TargetGeometry& target) {
  const std::array<Eigen::Vector2d, 4> model = top_corners_P(target);
  std::array<Eigen::Vector2d, 4> proj;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d c = X_CP * Eigen::Vector3d(model[k].x(), model[k].y(), 0.0);
    if (!(c.z() > 1e-6)) return std::numeric_limits<double>::infinity();
    const Eigen::Vector3d u = cam.K() * c;
    proj[k] = cam.distort_px(u.head<2>() / u.z());
  }
  double best = std::numeric_limits<double>::infinity();
  for (int dir : {1, -1}) {
    for (int s = 0; s < 4; ++s) {
      double worst = 0.0;
      for (int k = 0; k < 4; ++k) {
        worst = std::max(worst, (proj[k] - q.corners[((s + dir * k) % 4 + 4) % 4]).norm());
      }
      best = std::min(best, worst);
    }
  }
  return best;
}

}  // namespace lander::vision_internal
