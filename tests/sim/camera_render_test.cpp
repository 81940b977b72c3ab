// Offscreen camera: projection geometry, determinism and motion blur, on real renders.
//
// One GL context per process, so one World + Renderer serve every test in this file; tests
// swap the platform texture (checkerboards, edges) and re-upload it.
#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <iostream>
#include <memory>
#include <random>
#include <cstring>

#include <opencv2/imgproc.hpp>

#include "lander/sim/sensors/camera.h"
#include "lander/sim/plant/mujoco_errors.h"
#include "lander/sim/render/renderer.h"
#include "lander/sim/plant/world.h"

namespace lander::sim {
namespace {

// Projection: a rendered feature must land within this of K X_CW p_W. It pins the frame
// conventions and the intrinsics: OpenCV puts pixel centres at integers, OpenGL at
// half-integers, so a half-pixel slip fails by a factor of five.
constexpr double kProjectionTolPx = 0.1;
// Blur: the measured smear length must be within 20 % of fx * v * T / Z (issue 2).
constexpr double kBlurLengthRelTol = 0.20;

class RenderFixture : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    world_ = std::make_unique<World>(WorldParams{}, CameraModel{});
    world_->reserve_offscreen(2048, 1280);  // the larger pinhole view of a distorted camera
    renderer_ = std::make_unique<Renderer>(world_->model(), RenderParams{});
    tex_id_ = mj_name2id(world_->model(), mjOBJ_TEXTURE, "target_tex");
    // Camera mount in the body from the model itself: X_BC = X_WB^-1 X_WC.
    world_->set_vehicle_state(Eigen::Isometry3d::Identity(), Eigen::Vector3d::Zero(),
                              Eigen::Vector3d::Zero());
    world_->forward();
    X_BC_ = world_->X_WB().inverse() * world_->X_WC();
  }
  static void TearDownTestSuite() {
    renderer_.reset();
    world_.reset();
  }

  // Puts the camera at X_WC (OpenCV convention) by placing the vehicle body.
  static void place_camera(const Eigen::Isometry3d& X_WC) {
    world_->set_cart_state(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
    world_->set_vehicle_state(X_WC * X_BC_.inverse(), Eigen::Vector3d::Zero(),
                              Eigen::Vector3d::Zero());
    world_->forward();
  }

  static cv::Mat render() {
    cv::Mat img;
    const CameraModel& c = world_->camera();
    renderer_->render_camera(world_->model(), world_->data(), world_->camera_id(), c.width_px,
                             c.height_px, img);
    return img;
  }

  // Texture of the platform as a function of the P-frame point (x, y) -> grey in [0, 1],
  // drawn with 2x2 supersampling per texel.
  template <class F>
  static void set_platform_texture(F shade) {
    const TargetGeometry& g = world_->target();
    const int N = g.texture_px;
    cv::Mat tex(N, N, CV_8UC3);
    const double h = 1.0 / g.px_per_m();
    for (int v = 0; v < N; ++v) {
      for (int u = 0; u < N; ++u) {
        const Eigen::Vector2d p = texture_to_platform(g, u, v);
        double acc = 0;
        for (int a = 0; a < 2; ++a) {
          for (int b = 0; b < 2; ++b) acc += shade(p.x() + (a - 0.5) * h / 2, p.y() + (b - 0.5) * h / 2);
        }
        const auto grey = cv::saturate_cast<std::uint8_t>(std::lround(255.0 * acc / 4));
        tex.at<cv::Vec3b>(v, u) = cv::Vec3b(grey, grey, grey);
      }
    }
    world_->set_texture("target_tex", tex);
    renderer_->upload_texture(world_->model(), tex_id_);
  }

  static Eigen::Vector2d project(const Eigen::Vector3d& p_W) {
    const Eigen::Vector3d p_C = world_->X_WC().inverse() * p_W;
    const Eigen::Vector3d uv = world_->camera().K() * p_C;
    return uv.head<2>() / uv.z();
  }

  static inline std::unique_ptr<World> world_;
  static inline std::unique_ptr<Renderer> renderer_;
  static inline int tex_id_ = -1;
  static inline Eigen::Isometry3d X_BC_ = Eigen::Isometry3d::Identity();
};

// A camera `height_m` above the platform centre's plane, optical axis tilted by tilt_rad
// from the platform normal, towards azimuth az_rad, rolled by roll_rad about its axis,
// looking at `look_P` on the platform.
Eigen::Isometry3d camera_looking_at(const Eigen::Isometry3d& X_WP, const Eigen::Vector2d& look_P,
                                    double height_m, double tilt_rad, double az_rad,
                                    double roll_rad) {
  const Eigen::Vector3d d_P(std::sin(tilt_rad) * std::cos(az_rad),
                            std::sin(tilt_rad) * std::sin(az_rad), -std::cos(tilt_rad));
  const Eigen::Vector3d target_P(look_P.x(), look_P.y(), 0.0);
  const Eigen::Vector3d c_P = target_P - d_P * (height_m / std::cos(tilt_rad));
  // Camera z along d; x perpendicular, rotated by roll.
  Eigen::Vector3d x0 = d_P.cross(Eigen::Vector3d::UnitZ());
  if (x0.norm() < 1e-6) x0 = Eigen::Vector3d::UnitX();
  x0.normalize();
  const Eigen::Vector3d y0 = d_P.cross(x0);
  const Eigen::Vector3d x = std::cos(roll_rad) * x0 + std::sin(roll_rad) * y0;
  Eigen::Matrix3d R_PC;
  R_PC.col(0) = x;
  R_PC.col(1) = d_P.cross(x);
  R_PC.col(2) = d_P;
  Eigen::Isometry3d X_PC = Eigen::Isometry3d::Identity();
  X_PC.linear() = R_PC;
  X_PC.translation() = c_P;
  return X_WP * X_PC;
}

TEST_F(RenderFixture, ModelCameraMountMatchesTheFlightSoftwareDefault) {
  // The estimator is told X_BC by CameraMount's defaults; the MJCF must agree with it.
  const Eigen::Isometry3d X_BC_flight = CameraMount{}.X_BC();
  EXPECT_LT((X_BC_flight.translation() - X_BC_.translation()).norm(), 1e-9);
  EXPECT_LT((X_BC_flight.linear() - X_BC_.linear()).norm(), 1e-9);
}

TEST_F(RenderFixture, CheckerCornersLandOnTheirProjection) {
  // For each pose, checker corners are refined with cornerSubPix and compared with
  // K X_CW p_W. A single corner carries ~0.05-0.1 px rms of measurement noise (cornerSubPix on
  // a texture-filtered render: llvmpipe filters with 8-bit weights), so the convention check
  // is on what the corners agree on: the best translation + scale about the principal point
  // mapping projections to measurements. A wrong pixel-centre convention shifts every corner
  // by 0.5 px; a wrong focal length or principal point scales or shifts them all.
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  const Eigen::Isometry3d X_WP = world_->X_WP();
  const double side = world_->target().platform_size_m.x();
  const Eigen::Vector2d c0(world_->camera().cx_px, world_->camera().cy_px);
  int poses = 0;
  for (double h : {1.0, 2.5, 5.0, 10.0, 15.0}) {
    for (double tilt_deg : {0.0, 30.0, 60.0}) {
      // Squares of about 24 px at the distance along the optical axis, a whole number of
      // them across the platform.
      const double dist = h / std::cos(tilt_deg * M_PI / 180);
      const int n_sq = std::max(2, static_cast<int>(std::floor(side / std::max(0.05, dist * 24.0 / 640.0))));
      const double sq = side / n_sq;
      set_platform_texture([&](double x, double y) {
        const int i = static_cast<int>(std::floor((x + 0.5 * side) / sq));
        const int j = static_cast<int>(std::floor((y + 0.5 * side) / sq));
        return ((i + j) % 2 == 0) ? 0.9 : 0.1;
      });
      const double yaw = angle(rng), roll = angle(rng);
      place_camera(camera_looking_at(X_WP, {0.05, -0.03}, h, tilt_deg * M_PI / 180, yaw, roll));
      cv::Mat grey;
      cv::cvtColor(render(), grey, cv::COLOR_BGR2GRAY);
      std::vector<Eigen::Vector2d> proj, meas;
      for (int i = 1; i < n_sq; ++i) {
        for (int j = 1; j < n_sq; ++j) {
          const double x = -0.5 * side + i * sq, y = -0.5 * side + j * sq;
          const Eigen::Vector2d uv = project(X_WP * Eigen::Vector3d(x, y, 0));
          const double du = (project(X_WP * Eigen::Vector3d(x + sq, y, 0)) - uv).norm();
          const double dv = (project(X_WP * Eigen::Vector3d(x, y + sq, 0)) - uv).norm();
          const double local = std::min(du, dv);
          if (local < 8) continue;  // too small for a reliable sub-pixel corner
          const int win = std::clamp(static_cast<int>(0.45 * local), 3, 20);
          if (uv.x() < win + 3 || uv.y() < win + 3 || uv.x() > grey.cols - win - 4 ||
              uv.y() > grey.rows - win - 4) {
            continue;
          }
          std::vector<cv::Point2f> c{cv::Point2f(uv.x() + 0.6, uv.y() - 0.4)};
          cv::cornerSubPix(grey, c, cv::Size(win, win), cv::Size(-1, -1),
                           cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 100, 1e-4));
          proj.push_back(uv);
          meas.emplace_back(c[0].x, c[0].y);
        }
      }
      const std::string where = "h " + std::to_string(h) + " m, tilt " + std::to_string(tilt_deg);
      ASSERT_GE(proj.size(), 1u) << where << ": no corner in view";
      // Least squares for meas - proj = t + (s - 1) (proj - c0).
      Eigen::MatrixXd A(2 * proj.size(), 3);
      Eigen::VectorXd b(2 * proj.size());
      double spread = 0, reach = 0;
      for (std::size_t k = 0; k < proj.size(); ++k) {
        const Eigen::Vector2d r = proj[k] - c0;
        A.row(2 * k) << 1, 0, r.x();
        A.row(2 * k + 1) << 0, 1, r.y();
        b.segment<2>(2 * k) = meas[k] - proj[k];
        spread = std::max(spread, (proj[k] - proj[0]).norm());
        reach = std::max(reach, r.norm());
        // Gross error per corner: 5x the per-corner noise.
        EXPECT_LT((meas[k] - proj[k]).norm(), 0.5) << where << " corner at " << proj[k].transpose();
      }
      Eigen::Vector3d sol;
      if (spread > 200) {
        sol = A.colPivHouseholderQr().solve(b);
      } else {  // corners too close together to separate scale from shift: shift only
        sol << A.leftCols<2>().colPivHouseholderQr().solve(b), 0.0;
      }
      EXPECT_LT(sol.head<2>().norm(), kProjectionTolPx) << where << ": systematic shift " << sol.head<2>().transpose();
      // Scale error as a displacement at the farthest measured corner from the principal point.
      EXPECT_LT(std::abs(sol.z()) * reach, kProjectionTolPx) << where << ": scale error " << sol.z();
      ++poses;
    }
  }
  EXPECT_EQ(poses, 15);
}

// Lens distortion (issue 10): the camera pipeline renders a larger pinhole view and remaps it
// through the Brown-Conrady model, so a checker corner must appear where the distorted
// projection puts it. Tolerance: the undistorted check's 0.5 px gross limit per corner; the
// remap adds bilinear interpolation (1/32 px steps) on top of the render's own error.
constexpr double kDistortedCornerTolPx = 0.5;

TEST_F(RenderFixture, DistortedImageCornersLandOnTheDistortedProjection) {
  CameraParams cp;
  cp.intrinsics.k1 = -0.08;
  cp.intrinsics.k2 = 0.01;
  cp.intrinsics.p1 = 0.001;
  CameraPipeline pipeline(cp, 1);
  const cv::Size rs = pipeline.render_size();
  ASSERT_GT(rs.width, cp.intrinsics.width_px);  // barrel distortion looks beyond the image
  mjModel* m = world_->model();
  const double fovy0 = m->cam_fovy[world_->camera_id()];
  m->cam_fovy[world_->camera_id()] = 2.0 * std::atan(0.5 * rs.height / cp.intrinsics.fy_px) * 180.0 / M_PI;
  const Eigen::Isometry3d X_WP = world_->X_WP();
  const double side = world_->target().platform_size_m.x();
  const int n_sq = 24;
  const double sq = side / n_sq;
  set_platform_texture([&](double x, double y) {
    const int i = static_cast<int>(std::floor((x + 0.5 * side) / sq));
    const int j = static_cast<int>(std::floor((y + 0.5 * side) / sq));
    return ((i + j) % 2 == 0) ? 0.9 : 0.1;
  });
  place_camera(camera_looking_at(X_WP, {0.0, 0.0}, 1.1, 0.0, 0.3, 0.0));
  cv::Mat raw;
  renderer_->render_camera(m, world_->data(), world_->camera_id(), rs.width, rs.height, raw);
  m->cam_fovy[world_->camera_id()] = fovy0;
  pipeline.begin(0.0);
  pipeline.add(raw);
  const CameraFrame frame = pipeline.finish(0, world_->X_WC());
  ASSERT_EQ(frame.bgr.cols, cp.intrinsics.width_px);
  cv::Mat grey;
  cv::cvtColor(frame.bgr, grey, cv::COLOR_BGR2GRAY);
  int checked = 0;
  double max_shift = 0;  // distortion's displacement of the checked corners (px)
  for (int i = 1; i < n_sq; ++i) {
    for (int j = 1; j < n_sq; ++j) {
      const Eigen::Vector2d und = project(X_WP * Eigen::Vector3d(-0.5 * side + i * sq, -0.5 * side + j * sq, 0));
      const Eigen::Vector2d uv = cp.intrinsics.distort_px(und);
      const int win = 8;
      if (uv.x() < win + 3 || uv.y() < win + 3 || uv.x() > grey.cols - win - 4 || uv.y() > grey.rows - win - 4) continue;
      std::vector<cv::Point2f> c{cv::Point2f(uv.x() + 0.6, uv.y() - 0.4)};
      cv::cornerSubPix(grey, c, cv::Size(win, win), cv::Size(-1, -1),
                       cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 100, 1e-4));
      EXPECT_LT((Eigen::Vector2d(c[0].x, c[0].y) - uv).norm(), kDistortedCornerTolPx)
          << "corner at " << uv.transpose() << " (undistorted " << und.transpose() << ")";
      max_shift = std::max(max_shift, (uv - und).norm());
      ++checked;
    }
  }
  EXPECT_GE(checked, 100);
  EXPECT_GT(max_shift, 10.0);  // the check saw real distortion, not a near-pinhole centre
}

TEST_F(RenderFixture, SameStateRendersTheSameImageTwice) {
  world_->set_texture("target_tex", render_target_texture(world_->target()));
  renderer_->upload_texture(world_->model(), tex_id_);
  place_camera(camera_looking_at(world_->X_WP(), {0.2, 0.1}, 4.0, 0.4, 1.0, 0.3));
  const cv::Mat a = render();
  place_camera(camera_looking_at(world_->X_WP(), {-0.3, 0.1}, 7.0, 0.2, 2.0, 0.3));
  render();  // something else in between
  place_camera(camera_looking_at(world_->X_WP(), {0.2, 0.1}, 4.0, 0.4, 1.0, 0.3));
  const cv::Mat b = render();
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
}

// Width of a dark-to-bright transition along the image line through `centre` in direction
// `dir` (unit, pixels), sampled every pixel over +-half_len, from 10 % to 90 % of the step.
double edge_width_10_90(const cv::Mat& grey, const Eigen::Vector2d& centre,
                        const Eigen::Vector2d& dir, int half_len) {
  std::vector<double> p;
  for (int k = -half_len; k <= half_len; ++k) {
    const Eigen::Vector2d q = centre + k * dir;
    cv::Mat px;
    cv::getRectSubPix(grey, cv::Size(1, 1), cv::Point2f(q.x(), q.y()), px, CV_32F);
    p.push_back(px.at<float>(0, 0));
  }
  const double lo = *std::min_element(p.begin(), p.end());
  const double hi = *std::max_element(p.begin(), p.end());
  auto first_crossing = [&](double level) {
    for (std::size_t i = 1; i < p.size(); ++i) {
      if ((p[i - 1] - level) * (p[i] - level) <= 0 && p[i] != p[i - 1]) {
        return (i - 1) + (level - p[i - 1]) / (p[i] - p[i - 1]);
      }
    }
    return -1.0;
  };
  const double a = first_crossing(lo + 0.1 * (hi - lo)), b = first_crossing(lo + 0.9 * (hi - lo));
  return std::abs(b - a);
}

TEST_F(RenderFixture, TranslationDuringExposureSmearsAnEdgeByTheExpectedLength) {
  // Platform: dark for P x < 0, bright for x > 0. The camera moves along P x, across the
  // edge, so the edge smears along P x's direction in the image.
  set_platform_texture([](double x, double) { return x < 0 ? 0.1 : 0.9; });
  const double speed = 2.0, height = 3.0;  // m/s along P x, m above the platform
  CameraParams cp;
  cp.exposure_s = 0.02;
  cp.blur_samples = 16;
  const Eigen::Isometry3d X_WP = world_->X_WP();
  auto camera_at = [&](double t) {
    Eigen::Isometry3d X = camera_looking_at(X_WP, {speed * t, 0.0}, height, 0.0, 0.0, 0.0);
    return X;
  };
  CameraPipeline blur(cp, 1);
  blur.begin(0.0);
  for (double t : exposure_sample_times(cp, 0.0, 0.001)) {
    place_camera(camera_at(t - 0.5 * cp.exposure_s));
    blur.add(render());
  }
  place_camera(camera_at(0.0));
  const CameraFrame frame = blur.finish(0, world_->X_WC());
  cv::Mat sharp_grey, blur_grey;
  cv::cvtColor(render(), sharp_grey, cv::COLOR_BGR2GRAY);
  cv::cvtColor(frame.bgr, blur_grey, cv::COLOR_BGR2GRAY);
  // Where the edge is, and which way the image sees P x (the motion direction).
  const Eigen::Vector2d e0 = project(X_WP * Eigen::Vector3d(0, 0, 0));
  const Eigen::Vector2d dir = (project(X_WP * Eigen::Vector3d(0.1, 0, 0)) - e0).normalized();
  const double depth = (world_->X_WC().inverse() * X_WP.translation()).z();
  const double expected_px = world_->camera().fy_px * speed * cp.exposure_s / depth;
  const double sharp_w = edge_width_10_90(sharp_grey, e0, dir, 30);
  const double blur_w = edge_width_10_90(blur_grey, e0, dir, 30);
  EXPECT_LT(sharp_w, 2.0) << "unblurred edge should be about one pixel wide";
  // A linear ramp of length L has a 10-90 % width of 0.8 L.
  const double measured_px = blur_w / 0.8;
  EXPECT_NEAR(measured_px / expected_px, 1.0, kBlurLengthRelTol)
      << "measured " << measured_px << " px, expected " << expected_px << " px";
}

// Column (px) of the dark-to-bright edge in row `row` of `grey` within [u0, u1): the centroid
// of the row's rise (grey[u + 1] - grey[u], at u + 0.5), which uses every grey level of the
// ramp rather than the two pixels around its middle; -1 if the row does not rise.
double row_edge_column(const cv::Mat& grey, int row, int u0, int u1) {
  double weight = 0.0, moment = 0.0;
  for (int u = u0; u + 1 < u1; ++u) {
    const double rise = static_cast<double>(grey.at<std::uint8_t>(row, u + 1)) - grey.at<std::uint8_t>(row, u);
    if (rise <= 0) continue;
    weight += rise;
    moment += rise * (u + 0.5);
  }
  return weight > 0 ? moment / weight : -1.0;
}

// A rolling shutter (issue 54) frame of a camera translating sideways over a straight edge:
// each row shows the edge where the camera was at that row's own time. The frame is assembled
// as the rig assembles it (exposure_renders' bands, CameraPipeline::add_rows) with the
// physics step at 1 us, so that the render times are the rows' times. The edge's column in
// each row is checked against the analytic projection at t0 + readout row / H + exposure / 2:
// within kProjectionTolPx with fine bands (below); within that plus half of
// rolling_shutter_px_per_band with the adaptive band count. A global shutter shows the edge
// straight (within kProjectionTolPx of the mid-exposure projection in every row). The fine
// frame takes 180 bands of 4 rows (a quarter of the renders of one band a row): a row is then
// off its own time by at most 2 rows' readout, 0.026 px here (kFineBandPx).
TEST_F(RenderFixture, RollingShutterShiftsEachRowToItsOwnTime) {
  set_platform_texture([](double x, double) { return x < 0 ? 0.1 : 0.9; });
  constexpr double kSpeed_mps = 2.0, kHeight_m = 3.0, kReadout_s = 0.03, kDt_s = 1e-6;
  const Eigen::Isometry3d X_WP = world_->X_WP();
  auto camera_at = [&](double t) { return camera_looking_at(X_WP, {kSpeed_mps * t, 0.0}, kHeight_m, 0.0, 0.0, 0.0); };
  const CameraModel& cam = world_->camera();
  // The edge (P x = 0) at time t: camera x is P x, so it is the column cx - fx v t / Z.
  const double depth = kHeight_m;
  auto analytic_column = [&](double t) { return cam.cx_px - cam.fx_px * kSpeed_mps * t / depth; };
  auto frame_with = [&](const CameraParams& cp, int n_bands) {
    CameraPipeline pipe(cp, 1);
    const std::vector<ExposureRender> renders =
        exposure_renders(cp, 0.0, kDt_s, pipe.render_size().height, cam.height_px, n_bands, 1);
    pipe.begin(0.0, n_bands > 1 ? 1 : 0);
    cv::Mat buf;
    for (const ExposureRender& r : renders) {
      place_camera(camera_at(r.t_s));
      add_exposure_render(*renderer_, *world_, pipe, r, buf);
    }
    cv::Mat grey;
    cv::cvtColor(pipe.finish(0, world_->X_WC()).bgr, grey, cv::COLOR_BGR2GRAY);
    return grey;
  };
  CameraParams cp;
  cp.rolling_shutter_readout_s = kReadout_s;
  cp.rolling_shutter_max_bands = cam.height_px;
  const double motion_px = cam.fx_px * kSpeed_mps * kReadout_s / depth;  // over the readout
  const int adaptive = rolling_shutter_bands(cp, motion_px);
  EXPECT_EQ(adaptive, static_cast<int>(std::ceil(motion_px / cp.rolling_shutter_px_per_band)));
  constexpr int kFineBands = 180;
  const double kFineBandPx = motion_px / (2.0 * kFineBands);
  const cv::Mat per_row = frame_with(cp, kFineBands), banded = frame_with(cp, adaptive);
  CameraParams global;
  const cv::Mat straight = frame_with(global, 1);
  const int u0 = static_cast<int>(cam.cx_px) - 40, u1 = static_cast<int>(cam.cx_px) + 40;
  double worst_row = 0, worst_band = 0, worst_global = 0, spread = 0;
  for (int v = 200; v <= 520; v += 20) {  // rows that see the platform at 3 m
    const double expected = analytic_column(kReadout_s * v / cam.height_px + 0.5 * cp.exposure_s);
    const double row_col = row_edge_column(per_row, v, u0, u1);
    ASSERT_GE(row_col, 0.0) << "row " << v;
    worst_row = std::max(worst_row, std::abs(row_col - expected));
    worst_band = std::max(worst_band, std::abs(row_edge_column(banded, v, u0, u1) - expected));
    const double g = row_edge_column(straight, v, u0, u1);
    worst_global = std::max(worst_global, std::abs(g - analytic_column(0.5 * global.exposure_s)));
    spread = std::max(spread, std::abs(row_col - g));
  }
  std::cout << "rolling shutter: worst row " << worst_row << " px (180 bands), " << worst_band << " px ("
            << adaptive << " bands), global " << worst_global << " px; largest shift " << spread << " px\n";
  EXPECT_LT(worst_row, kProjectionTolPx + kFineBandPx);
  EXPECT_LT(worst_band, kProjectionTolPx + 0.5 * cp.rolling_shutter_px_per_band);
  EXPECT_LT(worst_global, kProjectionTolPx);
  // The shift over rows 200-520 is fx v readout (320 / 720) / Z = 5.7 px: it is there.
  EXPECT_GT(spread, 5.0);
}

// A band drawn alone (Renderer::render_camera_rows: the frustum cut to its rows) is the full
// render's rows: the same state renders the same pixels but for the rasteriser's and the
// texture filter's rounding at another viewport: observed 0.0005-0.001 DN on average and 1 DN
// at most; kBandRenderMeanDn is ten times the mean, kBandRenderMaxDn the largest seen.
constexpr double kBandRenderMeanDn = 0.01;
constexpr double kBandRenderMaxDn = 1.0;
TEST_F(RenderFixture, ABandRenderedAloneIsTheFullRendersRows) {
  world_->set_texture("target_tex", render_target_texture(world_->target()));
  renderer_->upload_texture(world_->model(), tex_id_);
  place_camera(camera_looking_at(world_->X_WP(), {0.2, 0.1}, 4.0, 0.3, 1.0, 0.3));
  const cv::Mat full = render();
  const CameraModel& c = world_->camera();
  for (const auto& [row0, row1] : {std::pair<int, int>{0, 45}, {300, 341}, {675, 720}}) {
    cv::Mat band(c.height_px, c.width_px, CV_8UC3, cv::Scalar::all(7));
    renderer_->render_camera_rows(world_->model(), world_->data(), world_->camera_id(), c.width_px, c.height_px, row0,
                                  row1, band);
    cv::Mat diff;
    cv::absdiff(full.rowRange(row0, row1), band.rowRange(row0, row1), diff);
    const double mean = cv::mean(diff.reshape(1))[0];
    double max = 0;
    cv::minMaxLoc(diff.reshape(1), nullptr, &max);
    std::cout << "rows " << row0 << "-" << row1 << ": mean " << mean << " DN, max " << max << " DN\n";
    EXPECT_LT(mean, kBandRenderMeanDn) << "rows " << row0 << "-" << row1;
    EXPECT_LE(max, kBandRenderMaxDn) << "rows " << row0 << "-" << row1;
    // The rows outside the band are left as they were.
    if (row0 > 0) EXPECT_EQ(cv::norm(band.rowRange(0, row0), cv::Mat(row0, c.width_px, CV_8UC3, cv::Scalar::all(7)), cv::NORM_INF), 0.0);
  }
  EXPECT_THROW(renderer_->render_camera_rows(world_->model(), world_->data(), world_->camera_id(), c.width_px,
                                             c.height_px, 10, 10, *std::make_unique<cv::Mat>()),
               std::invalid_argument);
}

TEST(MujocoHandlers, AWarningThrowsInsteadOfPrinting) {
  install_mujoco_handlers();
  char err[512] = "";
  // Tiny inline model (MuJoCo test-fixture style): a free body.
  const char* xml = "<mujoco><worldbody><body><freejoint/><geom size='0.1'/></body></worldbody></mujoco>";
  mjVFS vfs;
  mj_defaultVFS(&vfs);
  ASSERT_EQ(mj_makeEmptyFileVFS(&vfs, "tiny.xml", static_cast<int>(std::strlen(xml))), 0);
  const int idx = mj_findFileVFS(&vfs, "tiny.xml");
  std::memcpy(vfs.filedata[idx], xml, std::strlen(xml));
  mjModel* m = mj_loadXML("tiny.xml", &vfs, err, sizeof(err));
  mj_deleteVFS(&vfs);
  ASSERT_NE(m, nullptr) << err;
  mjData* d = mj_makeData(m);
  d->qpos[0] = std::nan("");  // MuJoCo warns about a bad qpos
  EXPECT_THROW(mj_step(m, d), MujocoError);
  mj_deleteData(d);
  mj_deleteModel(m);
}

// A large grey texture goes to GL as one channel (issue 53: the ring target's 4096 px with
// mipmaps holds 22 MB as luminance, 89 MB as llvmpipe's RGB); its frames are the RGB upload's.
// The ring target from 3 m and from 12 m (minified: mipmaps), against the same target with one
// corner texel tinted, which keeps the RGB path: at most one grey level apart, and only where
// that texel's mipmap averages reach (a handful of pixels).
TEST_F(RenderFixture, GreyTextureUploadedAsLuminanceRendersAsRgb) {
  constexpr int kMaxDiffDn = 1;         // the tinted texel's share of a mipmap average
  constexpr int kMaxDifferingPx = 200;  // of 921 600: the corner's footprint at most
  const cv::Mat grey = render_target_texture(world_->target());
  cv::Mat tinted = grey.clone();
  tinted.at<cv::Vec3b>(0, 0)[2] ^= 1;
  Eigen::Isometry3d X_WP = world_->X_WP();
  for (double height : {3.0, 12.0}) {
    place_camera(camera_looking_at(X_WP, Eigen::Vector2d(0.05, -0.03), height, 0.3, 0.7, 0.2));
    world_->set_texture("target_tex", grey);
    renderer_->upload_texture(world_->model(), tex_id_);
    ASSERT_EQ(renderer_->luminance_textures(), std::vector<int>{tex_id_});
    const cv::Mat a = render();
    world_->set_texture("target_tex", tinted);
    renderer_->upload_texture(world_->model(), tex_id_);
    ASSERT_TRUE(renderer_->luminance_textures().empty());
    const cv::Mat b = render();
    cv::Mat diff;
    cv::absdiff(a, b, diff);
    double max_dn = 0;
    cv::minMaxLoc(diff.reshape(1), nullptr, &max_dn);
    EXPECT_LE(max_dn, kMaxDiffDn) << height << " m";
    EXPECT_LE(cv::countNonZero(diff.reshape(1)), kMaxDifferingPx) << height << " m";
  }
  world_->set_texture("target_tex", grey);
  renderer_->upload_texture(world_->model(), tex_id_);
}

}  // namespace
}  // namespace lander::sim
