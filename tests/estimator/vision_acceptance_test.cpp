// One acceptance rule for every pose source (issue 12): whatever the view, a reported pose has
// its ring centres' reprojection error within its gate (VisionParams::max_reproj_err_px, grown
// with the target's extent in the image by max_reproj_fraction). Grazing views
// from far away, where the ellipses are a few pixels across and a small outer ring can pass
// for the centre ring, are where a source without the gate reported a pose 115 deg off.
#include <iostream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "lander/estimator/vision_detector.h"
#include "support/vision_synth.h"

namespace lander {
namespace {

// A reported pose may be imprecise at grazing views (ellipses a few px across) but not wrong:
// 3 % of the range and 3 deg are ten times the errors seen at these views, and a tenth of the
// gross errors a misidentified ring gives.
constexpr double kMaxRangeError = 0.03;
constexpr double kMaxRotationErrorDeg = 3.0;
// Half the diagonal of the 1280 x 720 frame (px): the largest extent a target can have in it.
const double kHalfDiagonalPx = 0.5 * std::hypot(1280.0, 720.0);

TEST(VisionAcceptance, NoReportedPoseExceedsTheReprojectionGate) {
  const TargetGeometry& g = test::default_target();
  const CameraModel cam;
  const VisionParams params;
  int detected = 0, views = 0;
  for (double alt : {4.0, 8.0, 12.0}) {
    for (double tilt : {55.0, 65.0, 72.0, 78.0}) {
      for (double yaw : {0.0, 37.0, 115.0}) {
        // The aim point off-centre pushes the target towards the edge of a tilted view.
        for (const Eigen::Vector2d& aim : {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(1.5, -0.8)}) {
          const Eigen::Isometry3d X_CP = test::look_at_pose(alt, tilt, yaw, 20.0 + yaw, aim);
          test::SynthOptions opt;
          opt.supersample = 2;
          const RingDetection d = detect_ring_target(test::render_view(g, cam, X_CP, opt), cam, g, params);
          ++views;
          if (!d.detected) continue;
          ++detected;
          // The gate the pose passed is reported; it grows with the sets' extent in the image
          // (max_reproj_fraction) but never beyond that fraction of the frame's half-diagonal.
          EXPECT_LE(d.reproj_gate_px, std::max(params.max_reproj_err_px,
                                               params.max_reproj_fraction * kHalfDiagonalPx));
          EXPECT_GE(d.reproj_gate_px, params.max_reproj_err_px);
          EXPECT_LE(d.reproj_err_px, d.reproj_gate_px)
              << "alt " << alt << " tilt " << tilt << " yaw " << yaw << ": " << to_string(d.source) << ", "
              << d.reason;
          // Never a wrong pose: the position within kMaxRangeError of the range, the rotation
          // within kMaxRotationErrorDeg (gross errors are tens of percent and degrees).
          const double range = X_CP.translation().norm();
          EXPECT_LE((d.X_CP.translation() - X_CP.translation()).norm(), kMaxRangeError * range)
              << "alt " << alt << " tilt " << tilt << " yaw " << yaw << ": " << to_string(d.source);
          const double rot_deg =
              Eigen::AngleAxisd(d.X_CP.linear() * X_CP.linear().transpose()).angle() * 180.0 / M_PI;
          EXPECT_LE(rot_deg, kMaxRotationErrorDeg)
              << "alt " << alt << " tilt " << tilt << " yaw " << yaw << ": " << to_string(d.source);
        }
      }
    }
  }
  EXPECT_EQ(views, 72);
  EXPECT_GT(detected, 0);  // the sweep is not all misses: the gate was exercised
}

// The plane's two tilts under an uneven light. At 10-14 m and 20-40 deg from the normal the
// two poses IPPE gives for the centres (the normal tilted either way about the line of sight)
// reproject them within a pixel of each other; a light falling across the target to 30 % moves
// the central set's fitted centre by 1-2 px, and the centres alone then chose the mirrored tilt
// (independent ray-traced frames: 3 of 44 poses 44-75 deg off, within the reprojection gate).
// The conics tell the tilts apart (the right one fitted them 1.7-3.3 times better there).
TEST(VisionAcceptance, AnUnevenLightDoesNotFlipThePlaneTilt) {
  const TargetGeometry& g = test::default_target();
  const CameraModel cam;
  const VisionParams params;
  int detected = 0, views = 0, other_tilt = 0;
  for (double alt : {10.0, 12.0, 14.0}) {
    for (double tilt : {20.0, 30.0, 40.0}) {
      for (double light_deg : {0.0, 75.0, 150.0, 225.0, 300.0}) {
        const double yaw = 40.0 + 7.0 * views, azimuth = 110.0 + 53.0 * views;
        const Eigen::Isometry3d X_CP = test::look_at_pose(alt, tilt, yaw, azimuth);
        test::SynthOptions opt;
        opt.supersample = 2;
        opt.noise_sigma = 1.0;
        opt.seed = static_cast<std::uint64_t>(views + 1);
        opt.light_ramp = {light_deg, 0.9, 0.3};
        const RingDetection d =
            detect_ring_target(test::render_view(g, cam, X_CP, opt), cam, g, params);
        ++views;
        if (!d.detected) continue;
        ++detected;
        other_tilt += d.reason.find("other tilt") != std::string::npos;
        const double range = X_CP.translation().norm();
        const double rot_deg = test::rotation_error_rad(d.X_CP, X_CP) * 180.0 / M_PI;
        EXPECT_LE(test::position_error_m(d.X_CP, X_CP), kMaxRangeError * range)
            << "alt " << alt << " tilt " << tilt << " light " << light_deg << ": " << d.reason;
        EXPECT_LE(rot_deg, kMaxRotationErrorDeg)
            << "alt " << alt << " tilt " << tilt << " light " << light_deg << ": " << d.reason;
      }
    }
  }
  std::cout << "uneven light: " << detected << " of " << views << " detected, " << other_tilt
            << " with the closed form's other tilt\n";
  EXPECT_EQ(views, 45);
  // These views are plain for the detector (all seven sets 9-25 px across): a fix that refused
  // the frames instead of choosing the right tilt would fail here.
  EXPECT_GE(detected, 40);
}

// A pose must show the camera in front of the target's top. A platform misprinted with ring
// sets 3 and 5 swapped and sets 2 and 6 missing shows the believed layout mirrored about P's x
// axis (sets 0, 1 and 4 lie on it): a planar fit matches it exactly from behind the top (an
// independent ray-traced frame at 14.8 m, where noise made sets 3 and 5 read as each other,
// gave that pose, 180 deg off, with 0.05 px of reprojection error). From the front no pose
// fits, so nothing may be reported, or, where the layout identification places the sets by
// their positions alone, the true pose.
// The layout identification's pose of the misprinted target fits the swapped sets' inner
// circles with the believed radii, which tilts it by a few degrees (5.5 deg seen at 14 m,
// looking straight down); a mirrored or turned pose is 60-180 deg off.
constexpr double kMisprintMaxRotationErrorDeg = 10.0;

TEST(VisionAcceptance, NoPosePutsTheCameraBehindTheTarget) {
  const TargetGeometry& g = test::default_target();
  TargetGeometry printed = g;
  std::vector<RingSet> kept;
  for (RingSet r : printed.rings) {
    if (r.id == 2 || r.id == 6) continue;
    if (r.id == 3) r.inner_radius_m = g.ring(5).inner_radius_m;
    if (r.id == 5) r.inner_radius_m = g.ring(3).inner_radius_m;
    kept.push_back(r);
  }
  printed.rings = kept;
  const TargetGeometry seen = g;  // a distinct object: its texture is the misprinted one
  test::set_texture_override(seen, render_target_texture(printed));
  const CameraModel cam;
  const VisionParams params;
  int views = 0, detected = 0;
  for (double alt : {3.0, 8.0, 14.0}) {
    for (double tilt : {0.0, 25.0, 50.0}) {
      for (double yaw : {10.0, 130.0}) {
        const Eigen::Isometry3d X_CP = test::look_at_pose(alt, tilt, yaw, 35.0 + yaw);
        test::SynthOptions opt;
        opt.supersample = 2;
        const RingDetection d =
            detect_ring_target(test::render_view(seen, cam, X_CP, opt), cam, g, params);
        ++views;
        if (!d.detected) continue;
        ++detected;
        const Eigen::Vector3d t = d.X_CP.translation();
        EXPECT_LT(d.X_CP.linear().col(2).dot(t), 0.0)
            << "alt " << alt << " tilt " << tilt << ": the camera behind the top; " << d.reason;
        const double rot_deg = test::rotation_error_rad(d.X_CP, X_CP) * 180.0 / M_PI;
        EXPECT_LE(rot_deg, kMisprintMaxRotationErrorDeg)
            << "alt " << alt << " tilt " << tilt << ": " << d.reason;
      }
    }
  }
  std::cout << "misprinted target: " << detected << " of " << views << " views gave a pose\n";
  EXPECT_EQ(views, 18);
}

// A frame smeared by the camera's yaw during the exposure (the simulator's blur: the mean of
// renders along the motion) reads the inner circles wrongly, and the outer sets sit on a
// regular hexagon: a set taken for another turns the pose by 60-180 deg while every centre,
// conic and layout gate passes (before the rotation check, 16 of 69 poses over 3-7 m, tilts
// 0-35 deg and 12-24 deg of yaw were turned). Eight of those views and eight that gave the
// right pose: with the check, no turned pose and no right one lost; without it, turned poses.
// Right: within 5 % of the range and 5 deg (the smeared right poses were within 2 % and
// 1.5 deg; a turned one is 58-180 deg off).
constexpr double kSmearMaxRangeError = 0.05;
constexpr double kSmearMaxRotationErrorDeg = 5.0;

TEST(VisionAcceptance, AYawSmearedFrameGivesNoTurnedPose) {
  const TargetGeometry& g = test::default_target();
  const CameraModel cam;
  struct View {
    double alt, tilt, yaw, span_deg;
  };
  const std::vector<View> views = {// turned without the check
                                   {3, 20, 47, 12},
                                   {4, 0, 47, 16},
                                   {5, 0, 222, 12},
                                   {5, 20, 163, 16},
                                   {5, 35, 5, 20},
                                   {5, 35, 222, 16},
                                   {6, 35, 222, 20},
                                   {7, 35, 290, 24},
                                   // right without the check
                                   {3, 35, 101, 12},
                                   {4, 20, 5, 12},
                                   {5, 20, 101, 16},
                                   {5, 35, 163, 16},
                                   {6, 0, 163, 12},
                                   {6, 35, 290, 12},
                                   {7, 0, 222, 12},
                                   {7, 20, 47, 12}};
  VisionParams unchecked;
  unchecked.rotation_check = false;
  int turned_unchecked = 0, right_unchecked = 0, right_checked = 0, detected_checked = 0;
  for (const View& v : views) {
    std::vector<Eigen::Isometry3d> during;
    constexpr int kSubFrames = 8;
    for (int i = 0; i < kSubFrames; ++i) {
      const double f = (i + 0.5) / kSubFrames - 0.5;
      during.push_back(test::look_at_pose(v.alt, v.tilt, v.yaw + v.span_deg * f, 0.7 * v.yaw));
    }
    test::SynthOptions opt;
    opt.supersample = 2;
    const cv::Mat img = test::render_exposure(g, cam, during, opt);
    const Eigen::Isometry3d X = test::look_at_pose(v.alt, v.tilt, v.yaw, 0.7 * v.yaw);
    auto right = [&](const RingDetection& d) {
      return test::position_error_m(d.X_CP, X) <= kSmearMaxRangeError * X.translation().norm() &&
             test::rotation_error_rad(d.X_CP, X) * 180.0 / M_PI <= kSmearMaxRotationErrorDeg;
    };
    const RingDetection off = detect_ring_target(img, cam, g, unchecked);
    if (off.detected) (right(off) ? right_unchecked : turned_unchecked)++;
    const RingDetection on = detect_ring_target(img, cam, g, VisionParams{});
    if (!on.detected) continue;
    ++detected_checked;
    EXPECT_TRUE(right(on)) << "alt " << v.alt << " tilt " << v.tilt << " yaw " << v.yaw << " span "
                           << v.span_deg << ": "
                           << test::rotation_error_rad(on.X_CP, X) * 180.0 / M_PI << " deg off; "
                           << on.reason;
    if (right(on)) ++right_checked;
  }
  std::cout << "yaw-smeared views: without the rotation check " << turned_unchecked << " turned, "
            << right_unchecked << " right; with it " << right_checked << " right of "
            << detected_checked << "\n";
  EXPECT_GE(turned_unchecked, 4) << "the views no longer provoke turned poses: the test needs some";
  EXPECT_GE(right_checked, right_unchecked) << "the check refused right poses";
}

}  // namespace
}  // namespace lander
