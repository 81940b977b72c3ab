// One acceptance rule for every pose source (issue 12): whatever the view, a reported pose has
// its ring centres' reprojection error within its gate (VisionParams::max_reproj_err_px, grown
// with the target's extent in the image by max_reproj_fraction). Grazing views
// from far away, where the ellipses are a few pixels across and a small outer ring can pass
// for the centre ring, are where a source without the gate reported a pose 115 deg off.
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

}  // namespace
}  // namespace lander
