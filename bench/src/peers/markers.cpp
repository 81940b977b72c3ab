// Marker textures, synthetic platform views and motion blur for the estimator benchmark.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <vector>

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>

#include "lander/estimator/vision_conic.h"
#include "lander/bench/peer_detectors.h"

namespace lander::bench {


const char* to_string(MarkerKind k) {
  switch (k) {
    case MarkerKind::Rings: return "rings";
    case MarkerKind::AprilTag: return "apriltag";
    case MarkerKind::Aruco: return "aruco";
  }
  return "unknown";
}

double marker_side_m(const TargetGeometry& g) {
  return g.platform_size_m.x() * kMarkerBlackCells / kMarkerGridCells;
}

std::array<Eigen::Vector2d, 4> marker_corners_P(const TargetGeometry& g) {
  const double h = 0.5 * marker_side_m(g);
  return {Eigen::Vector2d(-h, h), Eigen::Vector2d(h, h), Eigen::Vector2d(h, -h),
          Eigen::Vector2d(-h, -h)};
}

namespace {

// 12 x 12 cell grid, row-major, 1 = dark, row 0 = texture top (+y edge of P).
std::vector<std::uint8_t> marker_grid(MarkerKind kind) {
  std::vector<std::uint8_t> grid(kMarkerGridCells * kMarkerGridCells, 0);
  if (kind == MarkerKind::AprilTag) {
    apriltag_family_t* fam = tag36h11_create();
    image_u8_t* im = apriltag_to_image(fam, kMarkerId);  // total_width cells, 1 px per cell
    const int w = im->width, off = (kMarkerGridCells - w) / 2;
    for (int r = 0; r < im->height; ++r) {
      for (int c = 0; c < w; ++c) {
        grid[(r + off) * kMarkerGridCells + (c + off)] = im->buf[r * im->stride + c] < 128;
      }
    }
    // image_u8_destroy() is not exported by Debian's libapriltag 3.3; it frees buf, then im.
    std::free(im->buf);
    std::free(im);
    tag36h11_destroy(fam);
  } else if (kind == MarkerKind::Aruco) {
    const auto dict = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_6X6_250);
    cv::Mat m;
    cv::aruco::drawMarker(dict, kMarkerId, kMarkerBlackCells, m, 1);  // 1 px per cell
    const int off = (kMarkerGridCells - kMarkerBlackCells) / 2;
    for (int r = 0; r < m.rows; ++r) {
      for (int c = 0; c < m.cols; ++c) {
        grid[(r + off) * kMarkerGridCells + (c + off)] = m.at<std::uint8_t>(r, c) < 128;
      }
    }
  }
  return grid;
}

inline double overlap_1d(double a0, double a1, double b0, double b1) {
  return std::max(0.0, std::min(a1, b1) - std::max(a0, b0));
}

}  // namespace

cv::Mat render_marker_texture(MarkerKind kind, const TargetGeometry& g) {
  if (kind == MarkerKind::Rings) return render_target_texture(g);
  const auto grid = marker_grid(kind);
  const int N = g.texture_px;
  const double cell = static_cast<double>(N) / kMarkerGridCells;  // texels per cell
  cv::Mat img(N, N, CV_8UC3);
  for (int v = 0; v < N; ++v) {
    const int r0 = static_cast<int>(v / cell), r1 = std::min(kMarkerGridCells - 1,
                                                             static_cast<int>((v + 1) / cell));
    for (int u = 0; u < N; ++u) {
      const int c0 = static_cast<int>(u / cell), c1 = std::min(kMarkerGridCells - 1,
                                                               static_cast<int>((u + 1) / cell));
      double dark = 0.0;  // area coverage of dark cells in this texel
      for (int r = r0; r <= r1; ++r) {
        for (int c = c0; c <= c1; ++c) {
          if (!grid[r * kMarkerGridCells + c]) continue;
          dark += overlap_1d(u, u + 1, c * cell, (c + 1) * cell) *
                  overlap_1d(v, v + 1, r * cell, (r + 1) * cell);
        }
      }
      const auto grey = cv::saturate_cast<std::uint8_t>(std::lround(255.0 * (1.0 - dark)));
      img.at<cv::Vec3b>(v, u) = cv::Vec3b(grey, grey, grey);
    }
  }
  return img;
}

void apply_motion_blur(cv::Mat& img, double length_px, double angle_deg) {
  if (length_px <= 0) return;
  const int n = 2 * static_cast<int>(std::ceil(0.5 * length_px)) + 3;
  cv::Mat k = cv::Mat::zeros(n, n, CV_32F);
  const double c = 0.5 * (n - 1), a = angle_deg * M_PI / 180;
  const int steps = std::max(50, static_cast<int>(length_px * 20));
  for (int i = 0; i <= steps; ++i) {  // box kernel along the segment, bilinear splats
    const double t = (static_cast<double>(i) / steps - 0.5) * length_px;
    const double x = c + t * std::cos(a), y = c + t * std::sin(a);
    const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
    const double fx = x - x0, fy = y - y0;
    k.at<float>(y0, x0) += static_cast<float>((1 - fx) * (1 - fy));
    k.at<float>(y0, x0 + 1) += static_cast<float>(fx * (1 - fy));
    k.at<float>(y0 + 1, x0) += static_cast<float>((1 - fx) * fy);
    k.at<float>(y0 + 1, x0 + 1) += static_cast<float>(fx * fy);
  }
  k /= cv::sum(k)[0];
  const cv::Mat src = img.clone();
  cv::filter2D(src, img, -1, k, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
}

SyntheticPlatformView::SyntheticPlatformView(const cv::Mat& texture_bgr, const TargetGeometry& g)
    : g_(g) {
  cv::Mat grey, f;
  if (texture_bgr.channels() == 3) {
    cv::cvtColor(texture_bgr, grey, cv::COLOR_BGR2GRAY);
  } else {
    grey = texture_bgr;
  }
  grey.convertTo(f, CV_32F);
  levels_.push_back(f);
  while (levels_.back().cols > 64) {
    cv::Mat half;
    cv::resize(levels_.back(), half, cv::Size(levels_.back().cols / 2, levels_.back().rows / 2), 0,
               0, cv::INTER_AREA);
    levels_.push_back(half);
  }
}

cv::Mat SyntheticPlatformView::render(const CameraModel& cam, const Eigen::Isometry3d& X_CP,
                                      double blur_px, double blur_angle_deg, int S,
                                      double ground_grey) const {
  const Eigen::Matrix3d K = cam.K();
  // Pyramid level: texel no larger than one sample's footprint on the nearest platform point.
  double depth_min = 1e9;
  for (double sx : {-1.0, 0.0, 1.0}) {
    for (double sy : {-1.0, 0.0, 1.0}) {
      const Eigen::Vector3d q = X_CP * Eigen::Vector3d(0.5 * sx * g_.platform_size_m.x(),
                                                       0.5 * sy * g_.platform_size_m.y(), 0);
      depth_min = std::min(depth_min, std::max(q.z(), 1e-3));
    }
  }
  const double footprint_texels = depth_min / (K(0, 0) * S) * g_.px_per_m();
  int k = static_cast<int>(std::floor(std::log2(std::max(1.0, footprint_texels))));
  k = std::clamp(k, 0, static_cast<int>(levels_.size()) - 1);
  const double f = std::ldexp(1.0, k) * g_.texture_px / levels_[0].cols, s = g_.px_per_m();
  Eigen::Matrix3d A;  // level-k texel -> platform (m)
  A << f / s, 0, 0.5 * f / s - 0.5 * g_.platform_size_m.x(), 0, -f / s,
      0.5 * g_.platform_size_m.y() - 0.5 * f / s, 0, 0, 1;
  Eigen::Matrix3d T;  // image px -> supersample px (pixel centres at integers in both)
  T << S, 0, 0.5 * S - 0.5, 0, S, 0.5 * S - 0.5, 0, 0, 1;
  const Eigen::Matrix3d M = T * plane_homography(K, X_CP) * A;
  cv::Mat Mcv(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) Mcv.at<double>(r, c) = M(r, c);
  }
  const float ground = static_cast<float>(ground_grey * 255.0);
  cv::Mat ss;
  cv::warpPerspective(levels_[k], ss, Mcv, cv::Size(cam.width_px * S, cam.height_px * S),
                      cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(ground));
  // Samples beyond the horizon (ray misses the plane in front of the camera) are ground.
  const Eigen::Matrix3d Mi = M.inverse();
  const Eigen::Vector3d ref = M * Eigen::Vector3d(0.5 * levels_[k].cols, 0.5 * levels_[k].rows, 1);
  const double sref = (Mi.row(2) * ref) > 0 ? 1.0 : -1.0;
  for (int y = 0; y < ss.rows; ++y) {
    float* row = ss.ptr<float>(y);
    for (int x = 0; x < ss.cols; ++x) {
      if (sref * (Mi(2, 0) * x + Mi(2, 1) * y + Mi(2, 2)) <= 0) row[x] = ground;
    }
  }
  cv::Mat img;
  cv::resize(ss, img, cv::Size(cam.width_px, cam.height_px), 0, 0, cv::INTER_AREA);
  if (blur_px > 0) apply_motion_blur(img, blur_px, blur_angle_deg);
  cv::Mat out8, bgr;
  img.convertTo(out8, CV_8U);
  cv::cvtColor(out8, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

}  // namespace lander::bench
