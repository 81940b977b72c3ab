#include "lander/flight/flight_stack.h"

#include <cmath>

#include "lander/estimator/altitude_vision.h"
#include "lander/estimator/motion_blur.h"
#include "lander/estimator/target.h"

namespace lander::flight {

namespace {
// The optical axis this far from the vertical and beyond counts as this tilted (a grazing
// view's depth along the axis is not what the blur of the target follows).
constexpr double kMinAxisCosine = 0.5;
// Depths below this count as this: the camera at touchdown sits ~0.2 m above the platform.
constexpr double kMinBlurDepthM = 0.2;
// A platform fix older than this no longer gives the depth and the platform's velocity (the
// tracker's relative vector is extrapolated from it); a second is ~30 frames.
constexpr double kFreshFixS = 1.0;

const FlightConfig& validated(const FlightConfig& c) {
  c.validate();
  return c;
}
}  // namespace

FlightStack::FlightStack(const FlightConfig& config)
    : config_(validated(config)),
      detector_(config_.camera, TargetGeometry::load(config_.target_path), config_.estimator.vision),
      path_extractor_(config_.camera, config_.estimator.path),
      nav_(config_.estimator.navigation),
      fusion_(config_.estimator.altitude),
      screen_(config_.estimator.sample_limits),
      controller_(config_.controller, config_.mount) {}

VisionResult FlightStack::vision_result(const RingDetection& det, double t_mid_s) const {
  VisionResult vr;
  vr.obs = to_platform_observation(det, t_mid_s);
  if (det.detected && det.keyframe) vr.h_plane_m = height_above_target_m(det.X_CP, config_.mount.X_BC());
  return vr;
}

Eigen::Vector2d FlightStack::predicted_blur_px(const ExposureInterval& exposure) const {
  const double T = exposure.t_end_s - exposure.t_start_s;
  const NavState nav = nav_state();
  if (!config_.estimator.vision.predict_blur || !nav.valid || !(T > 0.0)) return Eigen::Vector2d::Zero();
  const Eigen::Matrix3d R_BC = config_.mount.X_BC().linear();
  const Eigen::Matrix3d R_WC = nav.q_WB.toRotationMatrix() * R_BC;
  const Eigen::Vector3d w_C = R_BC.transpose() * nav.omega_B_radps;
  const ctl::PlatformTracker& tracker = controller_.tracker();
  const bool fix = tracker.has_fix() && nav.t_s - tracker.latest().t_s < kFreshFixS;
  const Eigen::Vector3d v_platform_W = fix ? tracker.velocity() : Eigen::Vector3d::Zero();
  const Eigen::Vector3d v_C = R_WC.transpose() * (nav.v_W_mps - v_platform_W);
  // Depth of the platform along the optical axis: from the tracker's relative vector, else
  // the height above the surface over the cosine of the optical axis' tilt.
  double Z = 0.0;
  if (fix) {
    Z = (R_WC.transpose() * tracker.relative_now(nav.t_s)).z();
  } else {
    const double h = fusion_started_ ? fusion_.estimate().h_surface_m : nav.p_W_m.z();
    Z = h / std::max(kMinAxisCosine, -R_WC.col(2).z());
  }
  Z = std::max(Z, kMinBlurDepthM);
  const Eigen::Vector2d blur = axis_point_motion_blur_px(w_C, v_C, Z, config_.camera.fx_px, config_.camera.fy_px, T);
  return blur.allFinite() ? blur : Eigen::Vector2d::Zero();
}

bool FlightStack::wants_path() const {
  if (!config_.estimator.path.enabled || !config_.controller.path.enabled) return false;
  const ctl::Mode m = controller_.mode();
  return (m == ctl::Mode::kSearch && !controller_.route_ended()) || m == ctl::Mode::kFollowPath;
}

PathObservation FlightStack::detect_path(const cv::Mat& bgr, double t_mid_s) const {
  PathObservation o = path_extractor_.extract(bgr);
  o.t_s = t_mid_s;
  return o;
}

void FlightStack::on_baro(const BaroSample& b) {
  if (!screen_.accept(b)) return;
  if (!fusion_started_) {
    // In the air at start: the first reading fixes height + baro bias, not their split.
    fusion_.reset_from_baro(b);
    fusion_started_ = true;
  }
  fusion_.update_baro(b);
}

void FlightStack::on_gps(const GpsSample& g) {
  if (!screen_.accept(g)) return;
  nav_.add_gps(g);
  if (fusion_started_) fusion_.update_gps(g);
}

void FlightStack::on_platform_telemetry(const GpsSample& g) {
  // Not the vehicle's own GPS: the sample screen's GPS state must not see it. The controller
  // drops a non-finite message and counts it.
  controller_.on_platform_telemetry(g);
}

void FlightStack::on_ultrasonic(const UltrasonicSample& u) {
  if (!screen_.accept(u)) return;
  if (fusion_started_) fusion_.update_ultrasonic(u);
}

void FlightStack::on_mag(const MagSample& m) {
  if (screen_.accept(m)) nav_.add_mag(m);
}

void FlightStack::on_vision(const VisionResult& vr) {
  if (vr.path) {
    ctl::PathPoints pp;
    pp.t_s = vr.path->t_s;
    pp.points_px = vr.path->points_px;
    pp.fx = vr.path->fx;
    pp.fy = vr.path->fy;
    pp.cx = vr.path->cx;
    pp.cy = vr.path->cy;
    controller_.on_path(pp);
  }
  if (!screen_.accept(vr.obs)) return;
  if (fusion_started_ && std::isfinite(vr.h_plane_m)) fusion_.update_vision(vr.obs.t_s, vr.h_plane_m);
  controller_.on_vision(vr.obs);
}

std::optional<ctl::RotorCommand> FlightStack::on_imu(const ImuSample& raw) {
  // A rejected sample is replaced by the last good one (zero-order hold).
  const std::optional<ImuSample> screened = screen_.imu(raw);
  if (!screened) return std::nullopt;
  const ImuSample& s = *screened;
  nav_.add_imu(s);
  if (fusion_started_) {
    fusion_.predict(s, nav_.state().q_WB, config_.estimator.navigation.gravity_mps2);
    controller_.on_altitude(fusion_.estimate());
  }
  const NavState ns = nav_state();
  if (!ns.valid) return std::nullopt;
  return controller_.step(s.t_s, ns, s);
}

// The GPS-only vertical channel follows the receiver's slowly varying height error (metres
// with a degraded GPS: a hold on it drifts with the error); the fusion's height is anchored by
// the barometer, the ultrasonic and vision.
NavState FlightStack::nav_state() const {
  if (config_.estimator.navigation.height_from_altitude_fusion && fusion_started_) {
    return with_altitude(nav_.state(), fusion_.estimate());
  }
  return nav_.state();
}

}  // namespace lander::flight
