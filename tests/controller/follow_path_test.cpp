// follow_path (seed 003) in the mode machine, on a synthetic route: a kinematic vehicle sits
// on the controller's setpoints and a synthetic path stage delivers, at 30 Hz after 50 ms,
// the image points of the route's centre line sampled every 0.2 m (the grid's centre points
// stand-in), projected with the vehicle's true pose. Checks the entries and exits of the
// mode and the law's behaviour at the start and at the route's end against the route's truth.
#include <gtest/gtest.h>

#include <cmath>
#include <deque>
#include <functional>
#include <iostream>
#include <limits>
#include <vector>

#include "lander/controller/landing_controller.h"
#include "support/hex_model.h"
#include "support/kinematic_run.h"

namespace lander::ctl::test {
namespace {

// The route: a polyline on the ground (z = 0).
struct Polyline {
  std::vector<Eigen::Vector2d> pts;
  std::vector<Eigen::Vector2d> sample(double step) const {
    std::vector<Eigen::Vector2d> out;
    for (std::size_t i = 0; i + 1 < pts.size(); ++i) {
      const double len = (pts[i + 1] - pts[i]).norm();
      for (double s = 0; s < len; s += step) out.push_back(pts[i] + (pts[i + 1] - pts[i]) * (s / len));
    }
    out.push_back(pts.back());
    return out;
  }
  double distance(const Eigen::Vector2d& p) const {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i + 1 < pts.size(); ++i) {
      const Eigen::Vector2d d = pts[i + 1] - pts[i];
      const double u = std::clamp((p - pts[i]).dot(d) / d.squaredNorm(), 0.0, 1.0);
      best = std::min(best, (pts[i] + u * d - p).norm());
    }
    return best;
  }
};

struct PathRun {
  ControllerParams params;
  Polyline route;
  Eigen::Vector3d start{0.0, 0.3, 4.0};
  double max_time_s{40.0};
  std::function<bool(double)> route_visible = [](double) { return true; };
  bool with_platform{false};
  PlatformTruth platform;
  std::function<bool(double, const Eigen::Isometry3d&)> platform_visible;  // optional
  bool direction_given{true};
  std::function<bool(const LandingController&)> stop_when;

  std::vector<ModeTransition> transitions;
  std::vector<double> cross_track_m;  // while in follow_path
  Eigen::Vector3d final_p{Eigen::Vector3d::Zero()};
  bool route_ended{false};
  double route_end_t{0.0};
  double max_speed_mps{0.0};

  void run() {
    params.path.direction_given = direction_given;
    LandingController ctl(params, CameraMount{});
    const CameraMount mount;
    const Eigen::Isometry3d X_BC = mount.X_BC();
    const CameraModel cam;
    SyntheticVision vision(VisionModelParams{}, mount, cam);
    vision.visible = platform_visible;
    const std::vector<Eigen::Vector2d> centre = route.sample(0.2);
    std::deque<std::pair<double, PathPoints>> queue;  // (deliver time, points)
    Eigen::Vector3d p = start, v = Eigen::Vector3d::Zero();
    double next_frame = 0.0;
    constexpr double dt = 0.004, kLatency_s = 0.05, kFramePeriod_s = 1.0 / 30.0;
    for (int i = 0; i * dt < max_time_s; ++i) {
      const double t = i * dt;
      Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
      X_WB.translation() = p;
      if (t >= next_frame) {
        next_frame += kFramePeriod_s;
        PathPoints pp;
        pp.t_s = t;
        pp.fx = cam.fx_px;
        pp.fy = cam.fy_px;
        pp.cx = cam.cx_px;
        pp.cy = cam.cy_px;
        if (route_visible(t)) {
          GroundView g;
          g.R_WB = X_WB.linear();
          g.R_BC = X_BC.linear();
          g.t_BC_m = X_BC.translation();
          g.h_B_m = p.z();
          g.fx = cam.fx_px;
          g.fy = cam.fy_px;
          g.cx = cam.cx_px;
          g.cy = cam.cy_px;
          for (const Eigen::Vector2d& c : centre) {
            const auto px = ground_to_image(g, c - p.head<2>());
            if (px && px->x() >= 0 && px->x() < cam.width_px && px->y() >= 0 && px->y() < cam.height_px) {
              pp.points_px.push_back(*px);
            }
          }
        }
        queue.push_back({t + kLatency_s, pp});
      }
      while (!queue.empty() && queue.front().first <= t) {
        ctl.on_path(queue.front().second);
        queue.pop_front();
      }
      if (with_platform) {
        Eigen::Isometry3d X_WP = Eigen::Isometry3d::Identity();
        X_WP.translation() = platform.p_W(t);
        vision.update(t, X_WB, X_WP);
        for (const PlatformObservation& obs : vision.deliver(t)) ctl.on_vision(obs);
      }
      AltitudeEstimate alt;
      alt.t_s = t;
      alt.valid = true;
      alt.z_W_m = p.z();
      alt.h_surface_m = p.z();
      ctl.on_altitude(alt);
      NavState nav;
      nav.t_s = t;
      nav.valid = true;
      nav.p_W_m = p;
      nav.v_W_mps = v;
      ImuSample imu;
      imu.t_s = t;
      imu.accel_B_mps2 = Eigen::Vector3d(0, 0, kGravity_mps2);
      ctl.step(t, nav, imu);
      const Setpoint& sp = ctl.diagnostics().setpoint;
      v = sp.v_W_mps + kTrackGain_per_s * (sp.p_W_m - p);
      p += v * dt;
      max_speed_mps = std::max(max_speed_mps, v.head<2>().norm());
      if (ctl.mode() == Mode::kFollowPath && !ctl.route_ended()) cross_track_m.push_back(route.distance(p.head<2>()));
      if (stop_when && stop_when(ctl)) break;
    }
    transitions = ctl.transitions();
    final_p = p;
    route_ended = ctl.route_ended();
    route_end_t = ctl.route_end_t();
  }
};

// The synthetic points lie exactly on the centre line and the vehicle sits on its setpoint:
// what is left is the pursuit law's corner cutting, bounded by the annulus' inner radius on
// the ground (60 px at 4 m is 0.375 m) times sin(turn/2) for a right angle (0.27 m).
constexpr double kCornerCutTol_m = 0.3;
// Mean over the whole route: the corners are a small part of it.
constexpr double kMeanCrossTrackTol_m = 0.05;
// Where the route ends, the vehicle stops within the annulus' inner radius (0.375 m) plus
// the braking of 1 m/s in the kinematic model (tracking gain 15 1/s: 7 cm).
constexpr double kEndStopTol_m = 0.5;

TEST(FollowPath, FollowsAnLRouteFromItsStartToItsEndAndHoldsThere) {
  PathRun run;
  run.route.pts = {{0, 0}, {8, 0}, {8, 6}};
  run.run();
  SCOPED_TRACE(describe(run.transitions));
  ASSERT_GE(run.transitions.size(), 1u);
  EXPECT_EQ(run.transitions[0].to, Mode::kFollowPath);
  // enter_frames (3) frames at 30 Hz after the 50 ms latency.
  EXPECT_LT(run.transitions[0].t_s, 0.2);
  EXPECT_EQ(run.transitions.size(), 1u) << "no other mode after follow_path";
  EXPECT_TRUE(run.route_ended);
  EXPECT_LT((run.final_p.head<2>() - Eigen::Vector2d(8, 6)).norm(), kEndStopTol_m);
  ASSERT_FALSE(run.cross_track_m.empty());
  double sum = 0, mx = 0;
  for (double e : run.cross_track_m) {
    sum += e;
    mx = std::max(mx, e);
  }
  EXPECT_LT(sum / run.cross_track_m.size(), kMeanCrossTrackTol_m);
  EXPECT_LT(mx, kCornerCutTol_m + 0.3);  // + the start 0.3 m off the route
  // 14 m at the route speed (1 m/s), the corner's slow-down and the end's 2 s wait.
  EXPECT_LT(run.route_end_t, 14.0 / run.params.path.speed_mps + 6.0);
  EXPECT_LE(run.max_speed_mps, run.params.path.speed_mps + 0.2);
}

TEST(FollowPath, AnAcuteCornerIsTurnedNotTakenForTheEnd) {
  PathRun run;
  // 45 deg interior angle: a 135 deg turn.
  run.route.pts = {{0, 0}, {8, 0}, {8 - 5 * std::cos(M_PI / 4), 5 * std::sin(M_PI / 4)}};
  run.run();
  SCOPED_TRACE(describe(run.transitions));
  EXPECT_TRUE(run.route_ended);
  EXPECT_LT((run.final_p.head<2>() - run.route.pts.back()).norm(), kEndStopTol_m);
}

TEST(FollowPath, TheGivenDirectionDecidesAtTheStart) {
  // Starting in the middle of a straight route with direction 180 deg: it goes to x = -6.
  PathRun run;
  run.route.pts = {{-6, 0}, {6, 0}};
  run.start = Eigen::Vector3d(0, 0.2, 4);
  run.params.path.direction_rad = M_PI;
  run.run();
  EXPECT_TRUE(run.route_ended);
  EXPECT_LT((run.final_p.head<2>() - Eigen::Vector2d(-6, 0)).norm(), kEndStopTol_m);
}

TEST(FollowPath, LosingTheRouteGoesBackToSearch) {
  PathRun run;
  run.route.pts = {{0, 0}, {30, 0}};
  run.route_visible = [](double t) { return t < 3.0; };
  run.max_time_s = 8.0;
  run.run();
  SCOPED_TRACE(describe(run.transitions));
  ASSERT_EQ(run.transitions.size(), 2u);
  EXPECT_EQ(run.transitions[1].from, Mode::kFollowPath);
  EXPECT_EQ(run.transitions[1].to, Mode::kSearch);
  // The last frame with points is at ~3.0 s; route_lost_s (2 s) later.
  EXPECT_NEAR(run.transitions[1].t_s, 3.0 + run.params.path.route_lost_s, 0.2);
  EXPECT_FALSE(run.route_ended);
}

TEST(FollowPath, TheTargetComingIntoViewEndsFollowingForObserve) {
  PathRun run;
  run.route.pts = {{0, 0}, {20, 0}};
  run.with_platform = true;
  run.platform.p0_W_m = Eigen::Vector3d(12, 0, 0.8);
  run.stop_when = [](const LandingController& c) { return c.mode() == Mode::kObserve; };
  run.run();
  SCOPED_TRACE(describe(run.transitions));
  ASSERT_EQ(run.transitions.size(), 2u);
  EXPECT_EQ(run.transitions[1].from, Mode::kFollowPath);
  EXPECT_EQ(run.transitions[1].to, Mode::kObserve);
  // The platform enters the view (half-width along x: 2.25 m at 3.2 m above its top, less
  // the vision margin) when the vehicle is about 10 m along: it was followed there.
  EXPECT_GT(run.final_p.x(), 8.0);
  EXPECT_LT(run.final_p.x(), 12.0);
}

TEST(FollowPath, AfterALossTheCartsLastSeenMotionGivesTheDirection) {
  // The cart is seen driving towards -x, then lost; no direction is configured: the route is
  // followed towards -x, where the cart went, not towards +x.
  PathRun run;
  run.direction_given = false;
  run.route.pts = {{-14, 0}, {14, 0}};
  run.start = Eigen::Vector3d(0, 0.2, 6);
  run.with_platform = true;
  run.platform.p0_W_m = Eigen::Vector3d(0, 0, 0.8);
  run.platform.v_W_mps = Eigen::Vector3d(-0.8, 0, 0);
  run.platform_visible = [](double t, const Eigen::Isometry3d&) { return t < 2.5; };
  // Route frames only after the loss (the target is preferred while it is in view anyway).
  run.route_visible = [](double t) { return t > 3.0; };
  run.max_time_s = 40.0;
  run.run();
  SCOPED_TRACE(describe(run.transitions));
  ASSERT_GE(run.transitions.size(), 3u);
  EXPECT_EQ(run.transitions[0].to, Mode::kObserve);
  bool followed = false;
  for (const ModeTransition& tr : run.transitions) followed = followed || tr.to == Mode::kFollowPath;
  EXPECT_TRUE(followed);
  EXPECT_TRUE(run.route_ended);
  EXPECT_LT((run.final_p.head<2>() - Eigen::Vector2d(-14, 0)).norm(), kEndStopTol_m);
}

TEST(FollowPath, DisabledNeverFollows) {
  PathRun run;
  run.params.path.enabled = false;
  run.route.pts = {{0, 0}, {10, 0}};
  run.max_time_s = 3.0;
  run.run();
  for (const ModeTransition& tr : run.transitions) EXPECT_NE(tr.to, Mode::kFollowPath);
}

TEST(FollowPath, NonFinitePointsAreRejectedAndCounted) {
  LandingController ctl(ControllerParams{}, CameraMount{});
  PathPoints pp;
  pp.fx = pp.fy = 640;
  pp.points_px = {Eigen::Vector2d(std::nan(""), 3.0)};
  ctl.on_path(pp);
  EXPECT_EQ(ctl.rejected_inputs(), 1);
}

}  // namespace
}  // namespace lander::ctl::test
