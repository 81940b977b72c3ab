// The ring-target pose estimator on frames drawn with exact projective geometry
// (tests/estimator/support/vision_synth.h): centres, identities and poses against the truth,
// keyframes, tracking, distortion and garbage input.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "common/json_checks.h"
#include "estimator/support/vision_synth.h"
#include "lander/estimator/vision_detector.h"

namespace lander {
namespace {

// Centre error on rendered frames: the sub-pixel edge model (mid-level crossing with a
// curvature correction) leaves about 0.03 px on these frames, up to 0.09 px on the thinnest
// ellipses (2-3 px minor axes at 60-70 deg tilt); 0.1 px keeps every centre within a
// tenth of a pixel, five times below the 0.5 px bias of a naive ellipse-centre detector.
constexpr double kRenderedCentreTolPx = 0.1;
// Issue 3 target: mean centre error at 2.5 m at most 0.05 px.
constexpr double kMeanCentreTolAt2p5mPx = 0.05;
// Position error as a fraction of the camera-target distance: a 0.1 px centre error over the
// 1.3 m hexagon seen from d metres moves the pose by about 0.1 px * d / 640 px = 1.6e-4 d;
// 1e-3 d allows six times that.
constexpr double kPosTolPerMetre = 1e-3;
// Rotation error bound (rad): tilting the target plane by delta shifts the outer centres by
// about f (r / d)^2 delta px (perspective foreshortening, r = 0.66 m hexagon radius), so a
// centre error e px allows delta = e d^2 / (f r^2). Evaluated at kRenderedCentreTolPx.
double rot_tol_rad(double distance_m) {
  const double f = 640.0, r = 0.66;
  return std::max(1e-3, kRenderedCentreTolPx * distance_m * distance_m / (f * r * r));
}

const CameraModel kCam{};

struct View {
  double altitude_m, tilt_deg, yaw_deg;
};

// Views inside the working envelope (1-15 m, 0-60 deg; at 1 m the camera is yawed so the
// long image side spans the hexagon and five ring sets are whole in view).
std::vector<View> pose_views() {
  return {{1.0, 0, 90},  {1.0, 45, 90}, {2.5, 0, 17},  {2.5, 30, 40}, {2.5, 60, 75},
          {5.0, 0, 17},  {5.0, 45, 130}, {5.0, 60, 10}, {10.0, 0, 200}, {10.0, 30, 17},
          {10.0, 45, 60}, {15.0, 0, 17}, {15.0, 30, 300}};
}

int ring_index(const TargetGeometry& g, int id) {
  for (std::size_t i = 0; i < g.rings.size(); ++i) {
    if (g.rings[i].id == id) return static_cast<int>(i);
  }
  return -1;
}

// Given rendered views from 1 to 15 m and 0 to 60 deg, when the detector runs, then it finds
// at least four ring sets, their centres lie within kRenderedCentreTolPx of the true
// projections, the harmonic-ratio centre agrees with the closed form on the same fitted
// conics, and the pose is within the named tolerances of the truth.
TEST(VisionDetector, CentresAndPoseMatchTruthOnRenderedViews) {
  const TargetGeometry& g = test::default_target();
  double sum_2p5 = 0.0;
  int n_2p5 = 0;
  for (const auto& v : pose_views()) {
    SCOPED_TRACE("altitude " + std::to_string(v.altitude_m) + " m, tilt " +
                 std::to_string(v.tilt_deg) + " deg");
    const auto X = test::look_at_pose(v.altitude_m, v.tilt_deg, v.yaw_deg, 20.0);
    test::SynthOptions opt;
    opt.noise_sigma = 1.0;
    opt.seed = static_cast<std::uint64_t>(v.altitude_m * 100 + v.tilt_deg);
    const cv::Mat img = test::render_view(g, kCam, X, opt);
    const RingDetection d = detect_ring_target(img, kCam, g, VisionParams{});
    ASSERT_TRUE(d.detected) << d.reason;
    EXPECT_EQ(d.status, VisionStatus::Detected);
    EXPECT_GE(d.centres.size(), 4u);
    const auto truth = test::true_centres(g, kCam, X);
    for (const auto& c : d.centres) {
      const int i = ring_index(g, c.ring_id);
      ASSERT_GE(i, 0);
      const double err = (c.centre_px - truth[i]).norm();
      EXPECT_LT(err, kRenderedCentreTolPx) << "ring " << c.ring_id;
      const auto cf = closed_form_centre(d.ellipses[c.outer_index].C, d.ellipses[c.inner_index].C);
      ASSERT_TRUE(cf.has_value());
      EXPECT_LT((*cf - truth[i]).norm(), kRenderedCentreTolPx) << "closed form, ring " << c.ring_id;
      if (v.altitude_m == 2.5) {
        sum_2p5 += err;
        ++n_2p5;
      }
    }
    const double dist = X.translation().norm();
    EXPECT_LT(test::position_error_m(d.X_CP, X), kPosTolPerMetre * dist);
    EXPECT_LT(test::rotation_error_rad(d.X_CP, X), rot_tol_rad(dist));
    EXPECT_LT(d.reproj_err_px, kRenderedCentreTolPx);
    // The covariance is a usable 6x6 SPD matrix.
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> es(d.cov);
    EXPECT_GT(es.eigenvalues().minCoeff(), 0.0);
  }
  ASSERT_GT(n_2p5, 0);
  EXPECT_LT(sum_2p5 / n_2p5, kMeanCentreTolAt2p5mPx);
}

// Partial view: ring set 1 is cut by the image border; the other six still give a pose.
TEST(VisionDetector, PartialViewWithFourOrMoreRingsGivesPose) {
  const TargetGeometry& g = test::default_target();
  const auto X = test::look_at_pose(2.5, 0.0, 0.0, 0.0, Eigen::Vector2d(-1.9, 0.0));
  const RingDetection d = detect_ring_target(test::render_view(g, kCam, X), kCam, g, {});
  ASSERT_TRUE(d.detected) << d.reason;
  EXPECT_GE(d.centres.size(), 4u);
  for (const auto& c : d.centres) EXPECT_NE(c.ring_id, 1) << "ring 1 is cut by the border";
  EXPECT_LT(test::position_error_m(d.X_CP, X), kPosTolPerMetre * X.translation().norm());
}

// Given a sharp keyframe, when a heavily blurred frame yields a wrong pose, then eq. (18)
// gives a large rho and the frame is rejected (reported, not used); a later sharp frame is
// accepted again. The blur is the simulator's: the average of renders while the camera yaws
// 10-20 deg during the exposure. Such a frame can mislead the ring identities; our layout,
// reprojection and rotation checks then refuse it or find the right pose (checked), so here
// they are opened, as in the paper's pipeline, which has none, to exercise the keyframe test
// on the wrong pose.
// (The camera-in-front check stays: the paper's pipeline gave the pose from behind the top
// in the 3 m frames, which the detector no longer reports with any gates.)
TEST(VisionDetector, KeyframeSelectionRejectsBlurredFrameWithWrongPose) {
  const TargetGeometry& g = test::default_target();
  VisionParams p;
  p.max_centre_reproj_px = 1e3;
  p.max_reproj_err_px = 1e3;
  p.max_edge_residual_px = 1e3;
  p.rotation_check = false;
  p.tracking = false;
  // A grossly wrong pose, the kind eq. (18) is there to catch: more than 20 cm or 10 deg off
  // (a sharp frame here is within 2 mm, 0.05 deg; a pose 10 cm and 3 deg off at 4 m gives a
  // rho under rho_max). A right one: within 5 cm and 2 deg.
  constexpr double kWrongPosM = 0.2, kWrongRotRad = 10.0 * M_PI / 180.0;
  constexpr double kRightPosM = 0.05, kRightRotRad = 2.0 * M_PI / 180.0;
  constexpr double kYawDeg = 17.0, kTiltDeg = 30.0, kAzimuthDeg = 20.0;

  cv::Mat blurred;
  double altitude = 0.0;
  for (double h : {3.0, 4.0, 5.0}) {
    for (double span : {10.0, 12.0, 14.0}) {
      if (!blurred.empty()) break;
      std::vector<Eigen::Isometry3d> during;
      constexpr int kSubFrames = 8;
      for (int i = 0; i < kSubFrames; ++i) {
        const double f = (i + 0.5) / kSubFrames - 0.5;
        during.push_back(test::look_at_pose(h, kTiltDeg, kYawDeg + span * f, kAzimuthDeg));
      }
      const cv::Mat img = test::render_exposure(g, kCam, during);
      const auto X_mid = test::look_at_pose(h, kTiltDeg, kYawDeg, kAzimuthDeg);
      const RingDetection d = detect_ring_target(img, kCam, g, p);
      if (d.detected && (test::position_error_m(d.X_CP, X_mid) > kWrongPosM ||
                         test::rotation_error_rad(d.X_CP, X_mid) > kWrongRotRad)) {
        blurred = img;
        altitude = h;
      }
    }
  }
  ASSERT_FALSE(blurred.empty()) << "no blurred frame gave a wrong pose; the test needs one";
  // With the default gates the same frame gives no pose, or the right one.
  {
    const RingDetection dd = detect_ring_target(blurred, kCam, g, VisionParams{});
    const auto X_mid = test::look_at_pose(altitude, kTiltDeg, kYawDeg, kAzimuthDeg);
    if (dd.detected) {
      EXPECT_LT(test::position_error_m(dd.X_CP, X_mid), kRightPosM) << dd.reason;
      EXPECT_LT(test::rotation_error_rad(dd.X_CP, X_mid), kRightRotRad) << dd.reason;
    }
  }

  RingTargetDetector det(kCam, g, p);
  const auto X = test::look_at_pose(altitude, kTiltDeg, kYawDeg, kAzimuthDeg);
  const RingDetection first = det.detect(test::render_view(g, kCam, X));
  ASSERT_TRUE(first.detected) << first.reason;
  EXPECT_TRUE(first.keyframe);
  EXPECT_EQ(first.keyframe_status, KeyframeStatus::First);

  const RingDetection bad = det.detect(blurred);
  ASSERT_TRUE(bad.detected);
  EXPECT_FALSE(bad.keyframe);
  EXPECT_EQ(bad.keyframe_status, KeyframeStatus::Rejected);
  EXPECT_GT(bad.rho, p.rho_max);
  EXPECT_FALSE(to_platform_observation(bad, 1.0).keyframe);

  // The next sharp frame, slightly moved, is consistent with the keyframe.
  const auto X2 = test::look_at_pose(altitude - 0.02, kTiltDeg + 0.2, kYawDeg + 0.5, kAzimuthDeg);
  const RingDetection good = det.detect(test::render_view(g, kCam, X2));
  ASSERT_TRUE(good.detected) << good.reason;
  EXPECT_EQ(good.keyframe_status, KeyframeStatus::Accepted);
  EXPECT_LT(good.rho, p.rho_max);
}

// After a detection the next frame is searched in the predicted region first; when the
// target jumps out of it, the full frame is searched.
TEST(VisionDetector, TrackingUsesPredictedRegionAndFallsBack) {
  const TargetGeometry& g = test::default_target();
  RingTargetDetector det(kCam, g, VisionParams{});
  const auto X1 = test::look_at_pose(6.0, 10.0, 5.0, 0.0);
  const RingDetection d1 = det.detect(test::render_view(g, kCam, X1));
  ASSERT_TRUE(d1.detected) << d1.reason;
  EXPECT_FALSE(d1.used_roi);
  const auto X2 = test::look_at_pose(6.0, 11.0, 6.0, 0.0, Eigen::Vector2d(0.05, 0.02));
  const RingDetection d2 = det.detect(test::render_view(g, kCam, X2));
  ASSERT_TRUE(d2.detected) << d2.reason;
  EXPECT_TRUE(d2.used_roi);
  EXPECT_LT(d2.roi.area(), kCam.width_px * kCam.height_px / 2);
  EXPECT_LT(test::position_error_m(d2.X_CP, X2), kPosTolPerMetre * X2.translation().norm());
  // The target jumps to another part of the image: ROI misses, full frame finds it.
  const auto X3 = test::look_at_pose(6.0, 0.0, 5.0, 0.0, Eigen::Vector2d(4.0, 1.5));
  const RingDetection d3 = det.detect(test::render_view(g, kCam, X3));
  ASSERT_TRUE(d3.detected) << d3.reason;
  EXPECT_FALSE(d3.used_roi);
  EXPECT_EQ(d3.roi.area(), kCam.width_px * kCam.height_px);
  EXPECT_LT(test::position_error_m(d3.X_CP, X3), kPosTolPerMetre * X3.translation().norm());
}

// With lens distortion the edge points are undistorted before fitting: the calibrated model
// recovers the pose; ignoring the distortion does markedly worse.
TEST(VisionDetector, DistortedFrameWithCalibratedModel) {
  const TargetGeometry& g = test::default_target();
  CameraModel cam;
  cam.k1 = -0.12;
  cam.k2 = 0.03;
  cam.p1 = 0.0008;
  cam.p2 = -0.0005;
  const auto X = test::look_at_pose(3.0, 35.0, 20.0, 40.0, Eigen::Vector2d(0.6, 0.3));
  test::SynthOptions opt;
  opt.supersample = 2;
  const cv::Mat img = test::render_view(g, cam, X, opt);
  const RingDetection d = detect_ring_target(img, cam, g, {});
  ASSERT_TRUE(d.detected) << d.reason;
  const double dist = X.translation().norm();
  EXPECT_LT(test::position_error_m(d.X_CP, X), kPosTolPerMetre * dist);
  EXPECT_LT(test::rotation_error_rad(d.X_CP, X), rot_tol_rad(dist));
  CameraModel pinhole;  // same intrinsics, distortion ignored
  const RingDetection wrong = detect_ring_target(img, pinhole, g, {});
  if (wrong.detected) {
    EXPECT_GT(test::position_error_m(wrong.X_CP, X), 5 * test::position_error_m(d.X_CP, X));
  }
}

// Garbage in: no crash, no pose, a reason.
TEST(VisionDetector, GarbageInputGivesNoPoseAndAReason) {
  const TargetGeometry& g = test::default_target();
  const cv::Size sz(kCam.width_px, kCam.height_px);
  cv::Mat noise(sz, CV_8UC3);
  cv::RNG(7).fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat half = test::render_view(
      g, kCam, test::look_at_pose(2.5, 0.0, 0.0, 0.0, Eigen::Vector2d(2.5, 0.0)));
  struct Case {
    const char* name;
    cv::Mat img;
  };
  const std::vector<Case> cases = {
      {"black", cv::Mat(sz, CV_8UC3, cv::Scalar::all(0))},
      {"white", cv::Mat(sz, CV_8UC3, cv::Scalar::all(255))},
      {"noise", noise},
      {"distractors", test::distractor_frame(kCam, 3)},
      {"distractors2", test::distractor_frame(kCam, 11)},
      {"1x1", cv::Mat(1, 1, CV_8UC3, cv::Scalar::all(128))},
      {"empty", cv::Mat()},
      {"float", cv::Mat(sz, CV_32FC1, cv::Scalar::all(0.5))},
  };
  RingTargetDetector det(kCam, g, VisionParams{});
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    RingDetection d;
    ASSERT_NO_THROW(d = det.detect(c.img));
    EXPECT_FALSE(d.detected);
    EXPECT_NE(d.status, VisionStatus::Detected);
    EXPECT_FALSE(d.reason.empty());
    EXPECT_FALSE(d.keyframe);
    EXPECT_FALSE(to_platform_observation(d, 0.0).detected);
  }
  EXPECT_EQ(det.detect(cv::Mat()).status, VisionStatus::EmptyImage);
  EXPECT_EQ(det.detect(cv::Mat(1, 1, CV_8UC1)).status, VisionStatus::ImageSizeMismatch);
  EXPECT_EQ(det.detect(cv::Mat(sz, CV_32FC1)).status, VisionStatus::UnsupportedImage);
  VisionParams no3;
  no3.three_ring_pose = false;
  EXPECT_EQ(RingTargetDetector(kCam, g, no3).detect(half).status, VisionStatus::TooFewRings);
}

// Given half the target in view (three ring sets whole, the central one cut by the frame's
// edge), the three-set pose (P3P on their centres, decided by the six conics) gives the pose
// within the tolerance of a full-target frame; switched off, the frame gives none.
TEST(VisionDetector, ThreeRingSetsGiveAPose) {
  const TargetGeometry& g = test::default_target();
  const auto X = test::look_at_pose(2.5, 0.0, 0.0, 0.0, Eigen::Vector2d(2.5, 0.0));
  const cv::Mat half = test::render_view(g, kCam, X);
  const RingDetection d = detect_ring_target(half, kCam, g, VisionParams{});
  ASSERT_TRUE(d.detected) << d.reason;
  EXPECT_EQ(d.centres.size(), 3u) << d.reason;
  EXPECT_LT(test::position_error_m(d.X_CP, X), kPosTolPerMetre * X.translation().norm());
  EXPECT_LT(test::rotation_error_rad(d.X_CP, X), rot_tol_rad(X.translation().norm()));
  EXPECT_LE(d.reproj_err_px, VisionParams{}.max_reproj_err_px);
}

// Issue 12's blur-aware path. Position error of a pose from the deconvolved frame, as a fraction
// of the range: deconvolution restores the edges only approximately (its ringing shifts them
// by a fraction of a pixel), so these poses are centimetres, not millimetres, at 10 m; the
// full-sweep views it recovered stayed within 0.45 % of the range (README), 1 % leaves a
// margin and is still five times inside the 5 % of a gross pose.
constexpr double kDeblurredPosTolPerMetre = 0.01;

// Given a 10 m view smeared by 15 px of motion blur (the inner circles closed), when the
// detector is told the blur the vehicle predicts for the exposure, then the frame that gave no
// pose gives one from its deconvolution, within kDeblurredPosTolPerMetre; told nothing (or a
// blur below deblur_min_px), the result is the plain one.
TEST(VisionDetector, PredictedBlurRecoversASmearedFrame) {
  const TargetGeometry& g = test::default_target();
  const auto X = test::look_at_pose(10.0, 0.0, 17.0, 0.0);
  test::SynthOptions opt;
  opt.blur_px = 15.0;
  opt.blur_angle_deg = 20.0;
  const cv::Mat img = test::render_view(g, kCam, X, opt);
  const VisionParams p;
  const RingDetection plain = detect_ring_target(img, kCam, g, p);
  ASSERT_FALSE(plain.detected) << "the blurred frame must defeat the plain passes: " << plain.reason;
  const double a = opt.blur_angle_deg * M_PI / 180.0;
  const Eigen::Vector2d blur = opt.blur_px * Eigen::Vector2d(std::cos(a), std::sin(a));
  const RingDetection d = detect_ring_target(img, kCam, g, p, blur);
  ASSERT_TRUE(d.detected) << d.reason;
  EXPECT_TRUE(d.deblurred);
  EXPECT_NE(d.reason.find("deconvolved"), std::string::npos) << d.reason;
  EXPECT_GE(d.centres.size(), 4u);
  EXPECT_LT(test::position_error_m(d.X_CP, X), kDeblurredPosTolPerMetre * X.translation().norm());
  EXPECT_LE(d.reproj_err_px, p.max_reproj_err_px);
  // Below deblur_min_px (or with the pass off) nothing changes.
  const RingDetection small = detect_ring_target(img, kCam, g, p, blur * (0.9 * p.deblur_min_px / opt.blur_px));
  EXPECT_FALSE(small.detected);
  EXPECT_EQ(small.reason, plain.reason);
  VisionParams off = p;
  off.deblur_min_px = 0.0;
  EXPECT_FALSE(detect_ring_target(img, kCam, g, off, blur).detected);
  // A non-finite prediction is ignored, not used.
  EXPECT_FALSE(detect_ring_target(img, kCam, g, p, Eigen::Vector2d(NAN, 3.0)).detected);
}

// Given target-free frames with ring-like decoys, when the detector is told a blur that did not
// happen (the frames are sharp: the deconvolution rings at its worst), then it still reports
// nothing.
TEST(VisionDetector, PredictedBlurInventsNoTarget) {
  const TargetGeometry& g = test::default_target();
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const cv::Mat frame = test::distractor_frame(kCam, seed);
    for (const Eigen::Vector2d& blur : {Eigen::Vector2d(5, 0), Eigen::Vector2d(0, 12), Eigen::Vector2d(10.6, 10.6)}) {
      const RingDetection d = detect_ring_target(frame, kCam, g, VisionParams{}, blur);
      EXPECT_FALSE(d.detected) << "seed " << seed << " blur " << blur.transpose() << ": " << d.reason;
    }
  }
}

// The paper's Canny + close chain and the adaptive (local) threshold are options; both find
// the target and its pose too.
TEST(VisionDetector, CannyAndAdaptiveThresholdVariantsDetect) {
  const TargetGeometry& g = test::default_target();
  const auto X = test::look_at_pose(3.0, 25.0, 30.0, 60.0);
  test::SynthOptions opt;
  opt.noise_sigma = 1.0;
  const cv::Mat img = test::render_view(g, kCam, X, opt);
  VisionParams canny;
  canny.canny_edges = true;
  canny.close_kernel_px = 3;
  VisionParams adaptive;
  adaptive.adaptive_threshold = true;
  for (const auto& p : {canny, adaptive}) {
    const RingDetection d = detect_ring_target(img, kCam, g, p);
    ASSERT_TRUE(d.detected) << d.reason << (p.canny_edges ? " (canny)" : " (adaptive)");
    EXPECT_GE(d.centres.size(), 6u);
    EXPECT_LT(test::position_error_m(d.X_CP, X), kPosTolPerMetre * X.translation().norm());
  }
}

TEST(VisionDetector, ObservationAndJson) {
  const TargetGeometry& g = test::default_target();
  const auto X = test::look_at_pose(4.0, 20.0, 0.0);
  const RingDetection d = detect_ring_target(test::render_view(g, kCam, X), kCam, g, {});
  ASSERT_TRUE(d.detected) << d.reason;
  const PlatformObservation o = to_platform_observation(d, 12.5);
  EXPECT_EQ(o.t_s, 12.5);
  EXPECT_TRUE(o.detected);
  EXPECT_TRUE(o.keyframe);
  EXPECT_EQ(o.rings_identified, static_cast<int>(d.centres.size()));
  EXPECT_TRUE(o.X_CP.isApprox(d.X_CP));
  const nlohmann::json j = test::parse_json(to_json(d));
  EXPECT_TRUE(test::bool_at(j, "detected"));
  ASSERT_EQ(test::at_path(j, "p_CP_m").size(), 3u);
  for (int i = 0; i < 3; ++i) EXPECT_DOUBLE_EQ(j["p_CP_m"][i].get<double>(), d.X_CP.translation()[i]);
  EXPECT_EQ(test::at_path(j, "centres").size(), d.centres.size());
  EXPECT_EQ(test::at_path(j, "cov_rot_trans").size(), 6u);
  EXPECT_GT(d.time_ms, 0.0);
  // The same frame as 8-bit grey, 16-bit BGR and BGRA gives the same pose.
  const cv::Mat bgr = test::render_view(g, kCam, X);
  cv::Mat grey, bgr16, bgra;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  bgr.convertTo(bgr16, CV_16U, 256.0);
  cv::cvtColor(bgr, bgra, cv::COLOR_BGR2BGRA);
  for (const cv::Mat& img : {grey, bgr16, bgra}) {
    const RingDetection e = detect_ring_target(img, kCam, g, {});
    ASSERT_TRUE(e.detected) << e.reason;
    EXPECT_LT(test::position_error_m(e.X_CP, d.X_CP), 1e-6);
  }
}

}  // namespace
}  // namespace lander
