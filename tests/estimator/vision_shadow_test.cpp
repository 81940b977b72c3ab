// Hard shadow bands across the ring target (issue 12): a band of the platform plane gets 20 %
// or 50 % of the light, as under the shadow of a vehicle arm or the cart's frame in sun. Under
// one global threshold the shadowed white reads as dark and merges with every ring set the
// band's edge crosses; the shadow pass (VisionParams::shadow_pass) segments at lower levels and
// fits each illumination's edges at its own level. Frames are drawn with exact projective
// geometry (support/vision_synth.h), so the true centres and pose are known.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>

#include "estimator/support/vision_synth.h"
#include "lander/estimator/vision_detector.h"

namespace lander {
namespace {

const CameraModel kCam{};

// Band widths on the plane (m): an arm's shadow across one annulus (0.05), about one outer
// set (0.2, the sets are 0.4 m across), the central set (0.5) and half the target (1.0).
constexpr double kWidthsM[] = {0.05, 0.2, 0.5, 1.0};
// Light left in the band: a hard shadow in sun (20 %) and a softer one (50 %).
constexpr double kLights[] = {0.2, 0.5};

// Views from 1.5 to 10 m with the whole target in view (at 1.5 m the hexagon's long axis lies
// along the image's long side).
struct View {
  double altitude_m, tilt_deg, yaw_deg, azimuth_deg;
};
const View kViews[] = {{1.5, 0.0, 90.0, 0.0}, {2.5, 30.0, 40.0, 20.0}, {5.0, 20.0, 130.0, 60.0},
                       {10.0, 0.0, 17.0, 0.0}};

std::string describe(const View& v, const test::ShadowBand& b) {
  return "altitude " + std::to_string(v.altitude_m) + " m, tilt " + std::to_string(v.tilt_deg) +
         " deg, band " + std::to_string(b.width_m) + " m at " + std::to_string(b.light) +
         " light, angle " + std::to_string(b.angle_deg) + " deg, offset " +
         std::to_string(b.offset_m) + " m";
}

// Tolerances under a band. A shadowed edge has a fifth (20 % light) or half of the clean
// contrast, and the edge profiles next to the shadow's edge are not used, so a shadowed
// centre is less precise than a clean one (0.03-0.1 px): measured worst 0.54 px, on ring 1,
// whose hole is 2.5-5 px across at 5-10 m, cut by a band's edge; most are within 0.05 px.
constexpr double kShadowCentreTolPx = 0.6;
// Position: the pose weighs every set's edges, so it is far better than the worst centre:
// measured worst 8.5e-4 of the distance (8.5 mm at 10 m; clean frames: 1e-3 tolerance);
// 2e-3 of the distance leaves a margin of two.
constexpr double kShadowPosTolPerMetre = 2e-3;
// Rotation: a centre error e px tilts the target plane by up to e d^2 / (f r^2) rad (r = 0.66 m
// hexagon radius, f = 640 px), evaluated at e = 0.2 px (the pose's effective centre error, as
// for the position), at least 0.3 deg: 2 deg at 10 m straight down where the tilt is weakly
// observed (measured worst 0.7 deg), 0.5 deg at 5 m (measured 0.12 deg).
double shadow_rot_tol_rad(double distance_m) {
  const double f = 640.0, r = 0.66, e = 0.2;
  return std::max(0.3 * M_PI / 180.0, e * distance_m * distance_m / (f * r * r));
}

// Band directions (deg of the band's normal in P) and the offset of its centre line (m):
// with every width, the band's edges cut two to five ring sets.
constexpr double kAnglesDeg[] = {10.0, 75.0, 140.0};
constexpr double kOffsetM = 0.15;

test::ShadowBand band(double width_m, double light, double angle_deg) {
  test::ShadowBand b;
  b.width_m = width_m;
  b.light = light;
  b.angle_deg = angle_deg;
  b.offset_m = kOffsetM;
  return b;
}

int ring_index(const TargetGeometry& g, int id) {
  for (std::size_t i = 0; i < g.rings.size(); ++i) {
    if (g.rings[i].id == id) return static_cast<int>(i);
  }
  return -1;
}

// Given a hard shadow band of each width (0.05-1 m) at 20 % and 50 % light crossing ring sets,
// seen from 1.5 to 10 m, when the detector runs with default parameters, then the target is
// detected in every frame, each identified centre lies within kShadowCentreTolPx of its true
// projection and the pose is within the shadow tolerances of the truth.
TEST(VisionShadow, BandsAcrossTheTargetAreDetectedWithTheTruePose) {
  const TargetGeometry& g = test::default_target();
  const VisionParams params;
  for (const View& v : kViews) {
    const auto X = test::look_at_pose(v.altitude_m, v.tilt_deg, v.yaw_deg, v.azimuth_deg);
    const auto truth = test::true_centres(g, kCam, X);
    const double dist = X.translation().norm();
    for (double w : kWidthsM) {
      for (double light : kLights) {
        for (double angle : kAnglesDeg) {
          const test::ShadowBand b = band(w, light, angle);
          SCOPED_TRACE(describe(v, b));
          ASSERT_FALSE(test::ring_sets_crossed(g, b).empty());
          test::SynthOptions opt;
          opt.noise_sigma = 1.0;
          opt.shadows = {b};
          const RingDetection d = detect_ring_target(test::render_view(g, kCam, X, opt), kCam, g, params);
          ASSERT_TRUE(d.detected) << d.reason;
          EXPECT_LE(d.reproj_err_px, params.max_reproj_err_px);
          for (const auto& c : d.centres) {
            const int i = ring_index(g, c.ring_id);
            ASSERT_GE(i, 0);
            EXPECT_LT((c.centre_px - truth[i]).norm(), kShadowCentreTolPx) << "ring " << c.ring_id;
          }
          EXPECT_LT(test::position_error_m(d.X_CP, X), kShadowPosTolPerMetre * dist);
          EXPECT_LT(test::rotation_error_rad(d.X_CP, X), shadow_rot_tol_rad(dist));
        }
      }
    }
  }
}

// The same frames at 20 % light with one global threshold only (shadow_pass off): the
// shadowed white reads as dark and merges with the rings, and the target is lost in many of
// them; this is what the shadow pass is for.
TEST(VisionShadow, OneGlobalThresholdLosesTheTargetUnderHardShadows) {
  const TargetGeometry& g = test::default_target();
  VisionParams global_only;
  global_only.shadow_pass = false;
  int frames = 0, lost = 0;
  for (const View& v : kViews) {
    const auto X = test::look_at_pose(v.altitude_m, v.tilt_deg, v.yaw_deg, v.azimuth_deg);
    for (double w : kWidthsM) {
      for (double angle : kAnglesDeg) {
        test::SynthOptions opt;
        opt.noise_sigma = 1.0;
        opt.shadows = {band(w, 0.2, angle)};
        ++frames;
        lost += !detect_ring_target(test::render_view(g, kCam, X, opt), kCam, g, global_only).detected;
      }
    }
  }
  EXPECT_EQ(frames, 48);
  // Measured: 27 of 48 lost. With the shadow pass (the test above) none is.
  EXPECT_GE(lost, 12) << "the global threshold alone now survives hard shadows; "
                         "the premise of the shadow pass changed";
}

// Given a clean frame, the shadow pass never runs (the global threshold's pose stands, so
// clean-frame accuracy is that of the global threshold); given the same view under a band,
// a tracking detector keeps the target in its predicted region.
TEST(VisionShadow, CleanFramesKeepTheGlobalPoseAndTrackingEntersABand) {
  const TargetGeometry& g = test::default_target();
  for (const View& v : kViews) {
    const auto X = test::look_at_pose(v.altitude_m, v.tilt_deg, v.yaw_deg, v.azimuth_deg);
    test::SynthOptions opt;
    opt.noise_sigma = 1.0;
    const cv::Mat clean = test::render_view(g, kCam, X, opt);
    VisionParams global_only;
    global_only.shadow_pass = false;
    const RingDetection d = detect_ring_target(clean, kCam, g, VisionParams{});
    const RingDetection d0 = detect_ring_target(clean, kCam, g, global_only);
    ASSERT_TRUE(d.detected) << d.reason;
    EXPECT_EQ(d.reason.find("shadow"), std::string::npos) << d.reason;
    EXPECT_TRUE(d.X_CP.isApprox(d0.X_CP, 1e-12));

    // Where the predicted region is most of the frame (1.5 m), the full frame is searched.
    RingTargetDetector tracker(kCam, g, VisionParams{});
    ASSERT_TRUE(tracker.detect(clean).detected);
    const bool roi = tracker.detect(clean).used_roi;
    opt.shadows = {band(0.5, 0.2, 75.0)};
    const RingDetection t = tracker.detect(test::render_view(g, kCam, X, opt));
    ASSERT_TRUE(t.detected) << t.reason;
    EXPECT_EQ(t.used_roi, roi);
    EXPECT_LT(test::position_error_m(t.X_CP, X), kShadowPosTolPerMetre * X.translation().norm());
  }
}

// Given frames with no target, only ring-like decoys (annuli of no ring set's ratio, discs,
// off-centre holes, outlines), crossed by hard and soft shadow bands of several widths, when
// the detector runs (single frame and tracking), then it reports no pose.
TEST(VisionShadow, TargetFreeFramesWithDecoysAndBandsGiveNoDetection) {
  const TargetGeometry& g = test::default_target();
  RingTargetDetector tracker(kCam, g, VisionParams{});
  int frames = 0;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    const cv::Mat decoys = test::distractor_frame(kCam, seed);
    for (double width_px : {12.0, 60.0, 240.0}) {
      for (double light : kLights) {
        cv::Mat img = decoys.clone();
        // Bands through the image centre and through a third of the width, at two angles.
        test::apply_image_band(img, Eigen::Vector2d(640, 360), 25.0 * seed, width_px, light);
        test::apply_image_band(img, Eigen::Vector2d(420, 200), 25.0 * seed + 70.0, 0.5 * width_px,
                               light);
        SCOPED_TRACE("seed " + std::to_string(seed) + ", band " + std::to_string(width_px) +
                     " px at " + std::to_string(light) + " light");
        const RingDetection d = detect_ring_target(img, kCam, g, VisionParams{});
        EXPECT_FALSE(d.detected) << d.reason;
        EXPECT_FALSE(tracker.detect(img).detected);
        ++frames;
      }
    }
  }
  EXPECT_EQ(frames, 48);
}

// The shadow parameters are checked and named in the error.
TEST(VisionShadow, ShadowParamsAreValidated) {
  VisionParams p;
  EXPECT_NO_THROW(p.validate());
  p.shadow_levels = {0.3, 1.2};
  EXPECT_THROW(p.validate(), ConfigError);
  p.shadow_levels.clear();
  try {
    p.validate();
    FAIL() << "empty shadow_levels accepted with shadow_pass on";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("shadow_levels"), std::string::npos) << e.what();
  }
  p.shadow_pass = false;
  EXPECT_NO_THROW(p.validate());
  p.shadow_split_ratio = 1.0;
  try {
    p.validate();
    FAIL() << "shadow_split_ratio 1 accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("shadow_split_ratio"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace lander
