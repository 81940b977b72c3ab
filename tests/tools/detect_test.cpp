// `lander detect` on image files: a synthetic close-range PNG with a known pose gives that
// pose in the JSON output (from the code map: no ring set is whole at 0.4 m); a missing file
// or an image of the wrong size gives exit code 2 and a message naming the problem.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/json_checks.h"
#include "lander/estimator/target.h"
#include "tools/support/cli.h"
#include "lander/core/types.h"
#include "lander/estimator/vision_conic.h"
#include "lander/estimator/vision_params.h"

namespace lander {
namespace {

using lander::test::run_lander;

std::string temp_dir() { return lander::test::make_temp_dir("lander_detect"); }

const std::string kCamera = LANDER_MODELS_DIR "/camera_default.yaml";

// Camera straight above the point (x, y) of the platform at `height_m`, yawed `yaw_deg`
// (optical axis along -z of P; camera x = P x rotated by the yaw).
Eigen::Isometry3d above(double x, double y, double height_m, double yaw_deg) {
  const double a = yaw_deg * M_PI / 180;
  Eigen::Isometry3d X_PC = Eigen::Isometry3d::Identity();
  X_PC.linear().col(0) = Eigen::Vector3d(std::cos(a), std::sin(a), 0);
  X_PC.linear().col(2) = Eigen::Vector3d(0, 0, -1);
  X_PC.linear().col(1) = X_PC.linear().col(2).cross(X_PC.linear().col(0));
  X_PC.translation() = Eigen::Vector3d(x, y, height_m);
  return X_PC.inverse();
}

// Exact projective render of the target texture: supersampled 3x warp, area downsampling.
cv::Mat render(const TargetGeometry& g, const CameraModel& cam, const Eigen::Isometry3d& X_CP) {
  constexpr int S = 3;
  cv::Mat tex = render_target_texture(g), grey;
  cv::cvtColor(tex, grey, cv::COLOR_BGR2GRAY);
  const double s = g.px_per_m();
  Eigen::Matrix3d A;  // texel -> P (m), texture convention of target.h
  A << 1 / s, 0, 0.5 / s - 0.5 * g.platform_size_m.x(), 0, -1 / s,
      0.5 * g.platform_size_m.y() - 0.5 / s, 0, 0, 1;
  Eigen::Matrix3d T;  // image px -> supersample px
  T << S, 0, 0.5 * S - 0.5, 0, S, 0.5 * S - 0.5, 0, 0, 1;
  const Eigen::Matrix3d M = T * plane_homography(cam.K(), X_CP) * A;
  cv::Mat Mcv(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) Mcv.at<double>(r, c) = M(r, c);
  }
  cv::Mat ss, img;
  cv::warpPerspective(grey, ss, Mcv, cv::Size(cam.width_px * S, cam.height_px * S),
                      cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(115));
  cv::resize(ss, img, cv::Size(cam.width_px, cam.height_px), 0, 0, cv::INTER_AREA);
  return img;
}

// Position tolerance (m): the code pose at 0.4 m is within ~0.1 mm on exact renders
// (tests/estimator/vision_close_range_test.cpp); the PNG is 8-bit and the render here is a
// 3x supersampled bilinear warp, so 2 mm (1/200 of the distance) allows for its aliasing.
constexpr double kPosTolM = 2e-3;
// Rotation tolerance (rad), same reasoning: ~0.3 deg.
constexpr double kRotTolRad = 5e-3;

TEST(DetectCli, SyntheticCloseRangePngGivesItsPose) {
  const TargetGeometry g = TargetGeometry::load(LANDER_MODELS_DIR "/target.yaml");
  const CameraModel cam{};
  const Eigen::Isometry3d X = above(0.04, -0.06, 0.4, 35.0);
  const std::string dir = temp_dir();
  const std::string png = dir + "/close.png";
  ASSERT_TRUE(cv::imwrite(png, render(g, cam, X)));
  const auto r = run_lander("detect " + png + " --camera " + kCamera + " --json");
  ASSERT_EQ(r.code, 0) << r.output;
  const nlohmann::json j = test::parse_json(r.out);
  EXPECT_TRUE(test::bool_at(j, "detected")) << r.output;
  EXPECT_EQ(test::string_at(j, "source"), "code") << r.output;
  const nlohmann::json& p = test::at_path(j, "p_CP_m");
  const nlohmann::json& q = test::at_path(j, "q_CP_wxyz");
  ASSERT_EQ(p.size(), 3u);
  ASSERT_EQ(q.size(), 4u);
  const Eigen::Vector3d p_CP(p.at(0).get<double>(), p.at(1).get<double>(), p.at(2).get<double>());
  EXPECT_LT((p_CP - X.translation()).norm(), kPosTolM) << r.output;
  const Eigen::Quaterniond qd(q.at(0).get<double>(), q.at(1).get<double>(), q.at(2).get<double>(),
                              q.at(3).get<double>());
  EXPECT_LT(qd.angularDistance(Eigen::Quaterniond(X.linear())), kRotTolRad) << r.output;
  // The pose reports the gate it passed: at least the absolute code gate (1 px), and the
  // error within it.
  const double gate = test::number_at(j, "reproj_gate_px");
  EXPECT_GE(gate, VisionParams{}.code_max_reproj_px) << r.output;
  EXPECT_LE(test::number_at(j, "reproj_err_px"), gate) << r.output;
  EXPECT_EQ(test::number_at(j, "code.reproj_gate_px"), gate) << r.output;
}

TEST(DetectCli, MissingImageIsNamedWithExitCode2) {
  const std::string dir = temp_dir();
  const auto r = run_lander("detect " + dir + "/nope.png --camera " + kCamera + " --json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("nope.png"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("\"detected\""), std::string::npos) << "no partial output";
}

TEST(DetectCli, WrongSizeImageIsRefusedWithExitCode2) {
  const std::string dir = temp_dir();
  const std::string png = dir + "/small.png";
  ASSERT_TRUE(cv::imwrite(png, cv::Mat(360, 640, CV_8UC3, cv::Scalar::all(128))));
  const auto r = run_lander("detect " + png + " --camera " + kCamera + " --json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("640x360"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("1280x720"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace lander
