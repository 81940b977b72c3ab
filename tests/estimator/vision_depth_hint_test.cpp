// The least target depth the flight stack hands its detector (issue 53): its geometry
// (least_plane_depth_m against every pixel of the image) and what the detector does with it
// (the code map, unreadable beyond ~2 m, is not searched there without a pose or a track).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "estimator/support/vision_synth.h"
#include "lander/estimator/camera_cv.h"
#include "lander/estimator/vision_detector.h"

namespace lander {
namespace {

// least_plane_depth_m samples the border; the brute force samples every 4th pixel of the
// image including its border's samples: the two agree to rounding (1e-9 m) when the least
// depth is on a sample both take, and the sampled border can only miss a bowed border's
// extreme by its curvature between samples (distorted cameras: 1e-3 of the depth).
constexpr double kSameSampleTolM = 1e-9;
constexpr double kBowedBorderTolPerM = 1e-3;

// A downward camera (C's z along W's -z), then tilted by `tilt_deg` about W's axis `axis`.
Eigen::Matrix3d tilted_down(double tilt_deg, const Eigen::Vector3d& axis) {
  Eigen::Matrix3d nadir;
  nadir << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  return Eigen::AngleAxisd(tilt_deg * M_PI / 180.0, axis.normalized()).toRotationMatrix() * nadir;
}

// The least depth of the plane `h` below over a grid of pixels (every `step` px, the last
// row and column included), by undistorting each pixel.
double least_depth_over_pixels(const CameraModel& cam, const Eigen::Matrix3d& R_WC, double h, int step) {
  std::vector<cv::Point2d> px;
  auto coords = [step](int n) {
    std::vector<double> v;
    for (int i = 0; i < n - 1; i += step) v.push_back(i);
    v.push_back(n - 1.0);
    return v;
  };
  for (double y : coords(cam.height_px)) {
    for (double x : coords(cam.width_px)) px.emplace_back(x, y);
  }
  std::vector<cv::Point2d> rays;
  cv::undistortPoints(px, rays, camera_matrix_cv(cam), dist_coeffs_cv(cam));
  double least = std::numeric_limits<double>::infinity();
  for (const cv::Point2d& r : rays) {
    const double down = -(R_WC * Eigen::Vector3d(r.x, r.y, 1.0)).z();
    if (down > 0.0) least = std::min(least, h / down);
  }
  return std::isfinite(least) ? least : 0.0;
}

TEST(LeastPlaneDepth, NadirCameraSeesThePlaneAtItsHeightEverywhere) {
  const CameraModel cam{};
  for (double h : {0.5, 2.0, 9.2}) {
    EXPECT_NEAR(least_plane_depth_m(cam, tilted_down(0.0, Eigen::Vector3d::UnitX()), h), h, kSameSampleTolM);
  }
}

TEST(LeastPlaneDepth, IsTheLeastOverEveryPixelWhenTilted) {
  std::mt19937 rng(53);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  CameraModel distorted{};
  distorted.k1 = 0.08;  // pincushion: the undistorted border bows outward between corners
  distorted.k2 = -0.01;
  for (const CameraModel& cam : {CameraModel{}, distorted}) {
    for (double tilt : {0.0, 10.0, 30.0, 45.0, 60.0}) {
      const Eigen::Vector3d axis(U(rng), U(rng), 0.0);
      const Eigen::Matrix3d R = tilted_down(tilt, axis);
      const double h = 6.0;
      const double hint = least_plane_depth_m(cam, R, h);
      const double truth = least_depth_over_pixels(cam, R, h, 4);
      ASSERT_GT(truth, 0.0);
      const double tol = cam.has_distortion() ? kBowedBorderTolPerM * truth : kSameSampleTolM;
      // Never more than the truth beyond the tolerance: a hint above it could skip a search
      // that the frame needed.
      EXPECT_LE(hint, truth + tol) << "tilt " << tilt << " k1 " << cam.k1;
      EXPECT_GE(hint, truth - tol) << "tilt " << tilt << " k1 " << cam.k1;
    }
  }
}

TEST(LeastPlaneDepth, ZeroWhenThePlaneIsNotBelowOrNotInView) {
  const CameraModel cam{};
  EXPECT_EQ(least_plane_depth_m(cam, tilted_down(0.0, Eigen::Vector3d::UnitX()), 0.0), 0.0);
  EXPECT_EQ(least_plane_depth_m(cam, tilted_down(0.0, Eigen::Vector3d::UnitX()), -1.0), 0.0);
  // Looking straight up: no ray reaches a plane below.
  EXPECT_EQ(least_plane_depth_m(cam, tilted_down(180.0, Eigen::Vector3d::UnitX()), 3.0), 0.0);
}

// A frame with no target (the ground's texture and distractors): without a depth the code map
// is searched on the whole frame; at 9 m (cells 1.8 px at f = 640 px, code_min_cell_px 8) it is
// not; at 1.5 m (10.7 px) it is.
TEST(DetectorDepthHint, CodeMapSkippedWhereItsCellsCannotBeRead) {
  const CameraModel cam{};
  const cv::Mat frame = test::distractor_frame(cam, 7);
  const TargetGeometry& g = test::default_target();
  ASSERT_GT(g.code.cells, 0);
  struct Case {
    double min_depth_m;
    bool searched;
  };
  for (const Case c : {Case{0.0, true}, Case{9.0, false}, Case{1.5, true},
                       Case{std::numeric_limits<double>::quiet_NaN(), true}}) {
    RingTargetDetector det(cam, g);
    const RingDetection d = det.detect(frame, Eigen::Vector2d::Zero(), c.min_depth_m);
    EXPECT_FALSE(d.detected);
    EXPECT_EQ(d.code_searched, c.searched) << "min_depth_m " << c.min_depth_m;
  }
}

// Where the target is in view the hint changes nothing: the same pose with and without it.
TEST(DetectorDepthHint, SamePoseWithTheHintWhereTheTargetIsSeen) {
  const CameraModel cam{};
  const TargetGeometry& g = test::default_target();
  for (double h : {0.6, 1.5, 5.0}) {
    const Eigen::Isometry3d X = test::look_at_pose(h, 10.0, 30.0, 60.0, Eigen::Vector2d::Zero());
    const cv::Mat img = test::render_view(g, cam, X);
    RingTargetDetector a(cam, g), b(cam, g);
    const RingDetection da = a.detect(img), db = b.detect(img, Eigen::Vector2d::Zero(), 0.8 * h);
    ASSERT_EQ(da.detected, db.detected) << "h " << h;
    ASSERT_TRUE(da.detected) << "h " << h;
    EXPECT_EQ(da.code_searched, db.code_searched) << "h " << h;
    EXPECT_TRUE(da.X_CP.isApprox(db.X_CP, 0.0)) << "h " << h;
  }
}

}  // namespace
}  // namespace lander
