// The benchmark's shadow condition (issue 12): a band of the platform plane multiplied by its
// light in a rendered frame, and the ring sets a band's edges cross.
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/core.hpp>

#include "lander/bench/estimator_bench.h"

namespace lander::bench {
namespace {

const TargetGeometry& target() {
  static const TargetGeometry g = TargetGeometry::load(LANDER_MODELS_DIR "/target.yaml");
  return g;
}

// Given a camera 2.5 m straight above the platform and a 0.5 m band through the P origin at
// 20 % light, when the band is applied to a uniform frame, then the pixel on the origin is
// at 20 %, a pixel whose ray meets the plane 0.5 m from the band's centre line is untouched,
// and the band's edge pixels are blends (values between the two lights).
TEST(ShadowBand, MultipliesTheBandOfThePlane) {
  const CameraModel cam;
  const Eigen::Isometry3d X_CP = bench_camera_pose_P(2.5, 0.0, 0.0, 0.0, Eigen::Vector2d::Zero()).inverse();
  cv::Mat img(cam.height_px, cam.width_px, CV_8UC3, cv::Scalar::all(200));
  ShadowBand band;
  band.width_m = 0.5;
  band.light = 0.2;
  band.angle_rad = 0.0;  // normal along P x: the band is |x| < 0.25 m
  band.offset_m = 0.0;
  apply_shadow_band(img, cam, X_CP, band);
  auto pixel_of = [&](double x_m, double y_m) {
    const Eigen::Vector3d q = X_CP * Eigen::Vector3d(x_m, y_m, 0.0);
    return cv::Point(static_cast<int>(std::lround(cam.fx_px * q.x() / q.z() + cam.cx_px)),
                     static_cast<int>(std::lround(cam.fy_px * q.y() / q.z() + cam.cy_px)));
  };
  EXPECT_EQ(img.at<cv::Vec3b>(pixel_of(0.0, 0.0))[0], 40);    // 200 * 0.2
  EXPECT_EQ(img.at<cv::Vec3b>(pixel_of(0.0, 0.3))[1], 40);    // along the band
  EXPECT_EQ(img.at<cv::Vec3b>(pixel_of(0.75, 0.0))[2], 200);  // 0.5 m beyond its edge
  // Across the edge at x = 0.25 m (64 px from the centre line at 2.5 m): one monotonic ramp
  // of at most two pixels.
  int blends = 0;
  const cv::Point c = pixel_of(0.0, 0.0);
  for (int du = 60; du <= 68; ++du) {
    const int v = img.at<cv::Vec3b>(c.y, c.x + du)[0];
    const int v_prev = img.at<cv::Vec3b>(c.y, c.x + du - 1)[0];
    EXPECT_GE(v, v_prev);
    blends += v > 40 && v < 200;
  }
  EXPECT_LE(blends, 2);
}

// A band's edges cross the sets they cut: a narrow band along the P y axis through the centre
// set cuts only it; a band whose edges run through both hexagon columns cuts all but none.
TEST(ShadowBand, RingSetsCrossedByTheBandsEdges) {
  ShadowBand narrow;
  narrow.width_m = 0.1;
  narrow.angle_rad = 0.0;
  narrow.offset_m = 0.0;
  EXPECT_EQ(ring_sets_crossed(target(), narrow), std::vector<int>{0});
  ShadowBand wide = narrow;
  wide.width_m = 0.66;  // edges at x = +-0.33 m: through sets 2, 3, 5, 6 and the centre set
  const std::vector<int> ids = ring_sets_crossed(target(), wide);
  EXPECT_EQ(ids, (std::vector<int>{0, 2, 3, 5, 6}));
}

}  // namespace
}  // namespace lander::bench
