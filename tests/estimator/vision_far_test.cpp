// Far and grazing views (issue 12): the unfiltered pass (on by default), and the zoomed pass
// and the layout identification (both off by default). On exactly drawn frames at 12-16 m
// and 40-60 deg from the platform normal, every pose a pass reports must be right (position
// and rotation against the truth), a frame the earlier passes detect must be detected the
// same way, and target-free frames with ring-like decoys must stay empty.
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "lander/estimator/vision_detector.h"
#include "support/vision_synth.h"

namespace lander {
namespace {

// A right pose at these ranges: the sweep's largest error of ours is 5.2 cm at 15 m (0.35 %
// of the range); 1 % leaves room for the zoomed pass' coarser edges. A wrong identity of the
// sets turns the pose by a multiple of 60 deg with the position right: 2 deg catches it.
constexpr double kMaxPosFrac = 0.01;
constexpr double kMaxRotDeg = 2.0;

VisionParams far_params() {
  VisionParams p;
  p.tracking = false;
  p.unfiltered_pass = false;  // the zoomed and layout passes alone (the unfiltered pass,
                              // which runs before them, finds these frames' poses first)
  p.zoom_pass = true;
  p.layout_identification = true;
  return p;
}

struct FarViewCounts {
  int detected{0};      // views `p` detects
  int detected_off{0};  // views `off` detects
  int extra{0};         // views whose pose came from the passes under test
};

// The 12 far views (12 and 16 m, 40-60 deg, exactly drawn, noise 2 grey levels), each
// detected with `p` and with `off`: every pose `p` reports must be right. `same(d, d0, where)`
// checks a view `off` detects against `p`'s result; `by_passes(d)` says `p`'s pose came from
// the passes under test.
template <class Same, class ByPasses>
FarViewCounts run_far_views(const VisionParams& p, const VisionParams& off, Same same,
                            ByPasses by_passes) {
  const TargetGeometry& g = test::default_target();
  const CameraModel cam;
  FarViewCounts n;
  int k = 0;
  for (double alt : {12.0, 16.0}) {
    for (double tilt : {40.0, 50.0, 60.0}) {
      for (double yaw : {15.0, 75.0}) {
        const Eigen::Isometry3d X = test::look_at_pose(alt, tilt, yaw, 30.0 * k++);
        test::SynthOptions opt;
        opt.noise_sigma = 2.0;
        opt.seed = static_cast<std::uint64_t>(k);
        const cv::Mat img = test::render_view(g, cam, X, opt);
        const RingDetection d = detect_ring_target(img, cam, g, p);
        const RingDetection d0 = detect_ring_target(img, cam, g, off);
        std::ostringstream os;
        os << alt << " m, " << tilt << " deg: ";
        const std::string where = os.str();
        n.detected_off += d0.detected;
        if (d0.detected) same(d, d0, where);
        if (!d.detected) continue;
        ++n.detected;
        n.extra += by_passes(d);
        const double range = X.translation().norm();
        EXPECT_LT(test::position_error_m(d.X_CP, X), kMaxPosFrac * range) << where << d.reason;
        EXPECT_LT(test::rotation_error_rad(d.X_CP, X) * 180.0 / M_PI, kMaxRotDeg)
            << where << d.reason;
      }
    }
  }
  return n;
}

// Target-free frames with ring-like decoys give no pose with `p`.
void expect_target_free(const VisionParams& p) {
  const CameraModel cam;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const cv::Mat img = test::distractor_frame(cam, seed);
    const RingDetection d = detect_ring_target(img, cam, test::default_target(), p);
    EXPECT_FALSE(d.detected) << "seed " << seed << ": " << d.reason;
  }
}

TEST(VisionFar, ZoomedAndLayoutPosesAreRightOrAbsent) {
  const VisionParams p = far_params();
  VisionParams off = p;
  off.zoom_pass = false;
  off.layout_identification = false;
  const FarViewCounts n = run_far_views(
      p, off,
      // A frame the default passes detect is detected the same way with them on.
      [](const RingDetection& d, const RingDetection& d0, const std::string& where) {
        if (d.detected && !d.zoomed && !d.by_layout) {
          EXPECT_EQ(test::position_error_m(d.X_CP, d0.X_CP), 0.0) << where << d.reason;
        }
      },
      [](const RingDetection& d) { return d.zoomed || d.by_layout; });
  EXPECT_GE(n.detected, n.detected_off);
  // The passes are exercised here: on these frames they give poses the default passes do not
  // (4 of 12 while developing, 8 with the photometric ratios; 2 without them).
  EXPECT_GT(n.extra, 0);
  std::cout << "far views: " << n.detected << " of 12 detected with the passes (" << n.extra
            << " by them), " << n.detected_off << " without\n";
}

TEST(VisionFar, TargetFreeFramesStayEmptyWithThePassesOn) { expect_target_free(far_params()); }

// The unfiltered pass, as shipped: without it the Gaussian pre-filter closes the inner
// circles of 5-8 px ring sets and reads their ratios low; with it more of these views give a
// pose, every one right, and the views the filtered passes detect are untouched.
TEST(VisionFar, UnfilteredPassPosesAreRightOrAbsent) {
  VisionParams p;
  p.tracking = false;
  ASSERT_TRUE(p.unfiltered_pass) << "the pass is on by default";
  p.platform_pass = false;  // it runs after the unfiltered pass and would find some of the
                            // views the comparison run leaves (its own test is below)
  VisionParams off = p;
  off.unfiltered_pass = false;
  const FarViewCounts n = run_far_views(
      p, off,
      [](const RingDetection& d, const RingDetection& d0, const std::string& where) {
        EXPECT_TRUE(d.detected && !d.unfiltered) << where << d.reason;
        EXPECT_EQ(test::position_error_m(d.X_CP, d0.X_CP), 0.0) << d.reason;
      },
      [](const RingDetection& d) { return d.unfiltered; });
  EXPECT_GE(n.detected, n.detected_off);
  EXPECT_GT(n.extra, 0) << "the pass should add poses on these frames (4 of 12 while developing)";
  std::cout << "far views, unfiltered pass: " << n.detected << " of 12 detected (" << n.extra
            << " by it), " << n.detected_off << " without\n";
}

TEST(VisionFar, TargetFreeFramesStayEmptyWithTheUnfilteredPass) {
  VisionParams p;
  p.tracking = false;
  ASSERT_TRUE(p.unfiltered_pass);
  expect_target_free(p);
}

// Grazing views as shipped (the layout identification with photometric ratios on by
// default): 5 and 10 m, 65-75 deg from the normal, exactly drawn with noise. Every pose is
// right, and the layout gives poses that the ratio path alone does not.
TEST(VisionFar, GrazingViewsByTheLayoutAreRightOrAbsent) {
  const TargetGeometry& g = test::default_target();
  const CameraModel cam;
  VisionParams p;
  p.tracking = false;
  ASSERT_TRUE(p.layout_identification) << "on by default";
  VisionParams off = p;
  off.layout_identification = false;
  int detected = 0, detected_off = 0, by_layout = 0, k = 0;
  for (double alt : {5.0, 10.0}) {
    for (double tilt : {65.0, 70.0, 75.0}) {
      for (double yaw : {20.0, 80.0, 140.0}) {
        const Eigen::Isometry3d X = test::look_at_pose(alt, tilt, yaw, 50.0 * k++);
        test::SynthOptions opt;
        opt.noise_sigma = 2.0;
        opt.seed = static_cast<std::uint64_t>(100 + k);
        const cv::Mat img = test::render_view(g, cam, X, opt);
        const RingDetection d = detect_ring_target(img, cam, g, p);
        const RingDetection d0 = detect_ring_target(img, cam, g, off);
        detected_off += d0.detected;
        if (!d.detected) continue;
        ++detected;
        by_layout += d.by_layout;
        const double range = X.translation().norm();
        EXPECT_LT(test::position_error_m(d.X_CP, X), kMaxPosFrac * range)
            << alt << " m, " << tilt << " deg: " << d.reason;
        EXPECT_LT(test::rotation_error_rad(d.X_CP, X) * 180.0 / M_PI, kMaxRotDeg)
            << alt << " m, " << tilt << " deg: " << d.reason;
      }
    }
  }
  EXPECT_GE(detected, detected_off);
  EXPECT_GT(by_layout, 0) << "the layout should name sets the ratio path cannot here";
  std::cout << "grazing views: " << detected << " of 18 detected (" << by_layout
            << " by the layout), " << detected_off << " without it\n";
}

// The platform pass's poses rest on ring sets 3-5 px across: the range comes from outer
// circles of 2-3 px semi-axes and centres 12-20 px apart, and came out up to 1.9 % off (20 m,
// 55 deg) where the other passes' stay within 1 %. A wrong identity of the sets or the wrong
// one of the plane's two tilts turns the pose by tens of degrees: kMaxRotDeg catches those.
constexpr double kMaxPosFracPlatform = 0.025;

// The platform pass: views where the ring sets are 3-6 px across (12-20 m, 50-65 deg from
// the normal), whose contours merge or break at every threshold. Every pose it gives is
// right, a view the other passes detect is detected as before, and it gives poses they do
// not.
TEST(VisionFar, PlatformPassPosesAreRightOrAbsent) {
  const TargetGeometry& g = test::default_target();
  const CameraModel cam;
  VisionParams p;
  p.tracking = false;
  ASSERT_TRUE(p.platform_pass) << "on by default";
  VisionParams off = p;
  off.platform_pass = false;
  struct View {
    double alt, tilt, yaw, azimuth;
    std::uint64_t seed;
  };
  std::vector<View> views;
  int k = 0;
  for (double alt : {12.0, 15.0, 20.0}) {
    for (double tilt : {50.0, 55.0, 60.0, 65.0}) {
      for (double yaw : {10.0, 70.0, 130.0}) {
        views.push_back({alt, tilt, yaw, 40.0 * k, static_cast<std::uint64_t>(301 + k)});
        ++k;
      }
    }
  }
  // The view where the closed form chose the wrong one of the plane's two tilts (109 deg
  // off, before the pass compared both): refused now, or right.
  views.push_back({20.0, 55.0, 70.0, 400.0, 311});
  int detected = 0, detected_off = 0, by_platform = 0;
  for (const View& v : views) {
    const Eigen::Isometry3d X = test::look_at_pose(v.alt, v.tilt, v.yaw, v.azimuth);
    test::SynthOptions opt;
    opt.noise_sigma = 2.0;
    opt.seed = v.seed;
    const cv::Mat img = test::render_view(g, cam, X, opt);
    const RingDetection d = detect_ring_target(img, cam, g, p);
    const RingDetection d0 = detect_ring_target(img, cam, g, off);
    std::ostringstream os;
    os << v.alt << " m, " << v.tilt << " deg, yaw " << v.yaw << ": ";
    detected_off += d0.detected;
    if (d0.detected) {
      EXPECT_FALSE(d.by_platform) << os.str() << d.reason;
      EXPECT_EQ(test::position_error_m(d.X_CP, d0.X_CP), 0.0) << os.str() << d.reason;
    }
    if (!d.detected) continue;
    ++detected;
    by_platform += d.by_platform;
    const double range = X.translation().norm();
    EXPECT_LT(test::position_error_m(d.X_CP, X),
              (d.by_platform ? kMaxPosFracPlatform : kMaxPosFrac) * range)
        << os.str() << d.reason;
    EXPECT_LT(test::rotation_error_rad(d.X_CP, X) * 180.0 / M_PI, kMaxRotDeg)
        << os.str() << d.reason;
  }
  EXPECT_GE(detected, detected_off);
  // 10 of the 37 while developing.
  EXPECT_GT(by_platform, 0) << "the pass should give poses the others do not on these views";
  std::cout << "views with 3-6 px ring sets: " << detected << " of " << views.size()
            << " detected (" << by_platform << " by the platform pass), " << detected_off
            << " without it\n";
}

// Target-free frames with the pass on: the ring-like decoys, and bright quadrilaterals that
// are not the platform (a plain white square; one with dark discs at the hexagon's places
// but none of the sets' inner circles; one with the discs elsewhere).
TEST(VisionFar, TargetFreeFramesStayEmptyWithThePlatformPass) {
  VisionParams p;
  p.tracking = false;
  p.platform_pass = true;
  expect_target_free(p);
  const CameraModel cam;
  for (int kind = 0; kind < 3; ++kind) {
    for (int seed = 1; seed <= 4; ++seed) {
      cv::Mat img(cam.height_px, cam.width_px, CV_8UC3, cv::Scalar::all(110));
      cv::RNG rng(static_cast<std::uint64_t>(seed * 7 + kind));
      const cv::Point2f c(500 + rng.uniform(0, 200), 250 + rng.uniform(0, 150));
      const float w = 30 + rng.uniform(0, 40), h = 18 + rng.uniform(0, 30);
      const float sh = rng.uniform(-10, 10);
      std::vector<cv::Point> quad{
          cv::Point(c.x - w + sh, c.y - h), cv::Point(c.x + w + sh, c.y - h),
          cv::Point(c.x + w - sh, c.y + h), cv::Point(c.x - w - sh, c.y + h)};
      cv::fillConvexPoly(img, quad, cv::Scalar::all(245), cv::LINE_AA);
      if (kind > 0) {
        for (int i = 0; i < 7; ++i) {
          const double a = M_PI / 3 * i;
          const double r = kind == 1 ? (i == 6 ? 0.0 : 0.37) : rng.uniform(0.1, 0.45);
          const cv::Point2f q(c.x + r * w * std::cos(a + (kind == 2 ? rng.uniform(0., 1.) : 0.)),
                              c.y + r * h * std::sin(a));
          cv::ellipse(img, q, cv::Size2f(0.11f * w, 0.11f * h), 0, 0, 360, cv::Scalar::all(40),
                      cv::FILLED, cv::LINE_AA);
        }
      }
      const RingDetection d = detect_ring_target(img, cam, test::default_target(), p);
      EXPECT_FALSE(d.detected) << "kind " << kind << ", seed " << seed << ": " << d.reason;
    }
  }
}

}  // namespace
}  // namespace lander
