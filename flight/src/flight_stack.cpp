#include "lander/flight/flight_stack.h"

#include <cmath>

#include "lander/estimator/altitude_vision.h"
#include "lander/estimator/target.h"

namespace lander::flight {

namespace {
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
  const NavState ns = nav_.state();
  if (fusion_started_) {
    fusion_.predict(s, ns.q_WB, config_.estimator.navigation.gravity_mps2);
    controller_.on_altitude(fusion_.estimate());
  }
  if (!ns.valid) return std::nullopt;
  return controller_.step(s.t_s, ns, s);
}

}  // namespace lander::flight
