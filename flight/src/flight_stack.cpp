#include "lander/flight/flight_stack.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "internal.h"
#include "lander/estimator/altitude_vision.h"
#include "lander/estimator/camera_cv.h"
#include "lander/estimator/motion_blur.h"
#include "lander/estimator/target.h"

namespace lander::flight {

namespace {
// The optical axis this far from the vertical and beyond counts as this tilted (a grazing
// view's depth along the axis is not what the blur of the target follows).
constexpr double kMinAxisCosine = 0.5;
// Depths below this count as this: the camera at touchdown sits ~0.2 m above the platform.
constexpr double kMinBlurDepthM = 0.2;
// The target plane's least depth (min_target_depth_m) allows this many std of the fused height
// and of the plane's prior height, and this much more (m): a sea state 4 deck heaves ~1 m
// peak to peak, a cart's platform bounces centimetres.
constexpr double kDepthSigmas = 3.0;
constexpr double kDepthMargin_m = 1.0;
// A platform fix older than this no longer gives the depth and the platform's velocity (the
// tracker's relative vector is extrapolated from it); a second is ~30 frames.
constexpr double kFreshFixS = 1.0;

static_assert(kRotorCount == ctl::kNumRotors, "the seam's rotor count is the mixer's");

}  // namespace

// ------------------------------------------------------------------------------ frame job
RingFrameJob::RingFrameJob(FlightStack& stack, const CameraFrameIn& frame, bool run_path, const Eigen::Vector2d& blur_px,
                           double min_depth_m)
    : stack_(stack), frame_(frame), run_path_(run_path), blur_px_(blur_px), min_depth_m_(min_depth_m) {}

void RingFrameJob::process() {
  const double t_mid = frame_.exposure.mid();
  if (stack_.user_detector_) {
    Detection d = stack_.user_detector_->detect(frame_.image, frame_, blur_px_);
    vr_.obs = d.obs;
    if (vr_.obs.detected && vr_.obs.keyframe) vr_.h_plane_m = height_above_target_m(vr_.obs.X_CP, stack_.mount().X_BC());
    report_ = std::move(d.report);
  } else {
    const cv::Mat bgr = as_mat(frame_.image);
    const auto t0 = Clock::now();
    const double c0 = thread_cpu_ms();
    const RingDetection det = stack_.detect(bgr, blur_px_, min_depth_m_);
    const double cpu_ms = thread_cpu_ms() - c0, wall_ms = ms_since(t0);
    vr_ = stack_.vision_result(det, t_mid);
    report_ = detection_report(det, stack_.mount().X_BC());
    report_.detector_ms = wall_ms;
    report_.detector_cpu_ms = cpu_ms;
  }
  // Whichever detector found it, the pose's time is the flight stack's to say.
  vr_.obs.t_s = stack_.observation_time(frame_.exposure, vr_.obs, frame_.image.height_px);
  if (run_path_) {
    const auto t1 = Clock::now();
    vr_.path = stack_.detect_path(as_mat(frame_.image), t_mid);
    report_.path_ms = ms_since(t1);
    report_.route_searched = true;
    report_.route_points_px = vr_.path->points_px;
  }
}

bool RingFrameJob::inject(const VisionFault& fault) {
  // A pushed pose moves the recorder's vision height too; a NaN pose goes only to the
  // filters (the report keeps the detector's).
  apply_vision_fault(vr_.obs, fault);
  const double h = height_above_target_m(vr_.obs.X_CP, stack_.mount().X_BC());
  if (vr_.obs.detected && vr_.obs.keyframe) vr_.h_plane_m = h;
  if (fault.kind == VisionFault::Kind::kOffsetAlongAxis && report_.detected) report_.vision_height_m = h;
  return true;
}

// ---------------------------------------------------------------------------- the stack

FlightStack::FlightStack(const FlightConfig& config, std::unique_ptr<VisionDetector> detector)
    : config_(validated(config)),
      detector_(config_.camera, TargetGeometry::load(config_.target_path), config_.estimator.vision),
      user_detector_(std::move(detector)),
      path_extractor_(config_.camera, config_.estimator.path),
      border_rays_(image_border_rays(config_.camera)),
      est_(config_.estimator),
      controller_(config_.controller, config_.mount) {}

FlightStack::~FlightStack() = default;

FlightSoftwareInfo FlightStack::info() const { return {"lander", LANDER_VERSION}; }

std::unique_ptr<FrameJob> FlightStack::begin_frame(const CameraFrameIn& frame) {
  // The path stage (seed 003) runs only while the controller can use it; the blur is
  // predicted from the state the flight software has when the frame arrives.
  // The exposure as the flight software reads the driver's metadata (flight.camera).
  CameraFrameIn believed = frame;
  believed.exposure = config_.camera.believed_exposure(frame.exposure, frame.stamp_s);
  return std::make_unique<RingFrameJob>(*this, believed, wants_path(), predicted_blur_px(believed.exposure),
                                        min_target_depth_m());
}

void FlightStack::deliver_frame(std::unique_ptr<FrameJob> job) {
  on_vision(static_cast<const RingFrameJob&>(*job).result());
}

FlightStatus FlightStack::status() const {
  FlightStatus st;
  st.mode = ctl::to_string(controller_.mode());
  st.motors_cut = controller_.diagnostics().motors_cut;
  st.aborted = controller_.aborted();
  st.following_route = controller_.mode() == ctl::Mode::kFollowPath;
  st.route_ended = controller_.route_ended();
  if (st.route_ended) st.route_end_t_s = controller_.route_end_t();
  st.altitude_valid = est_.altitude_started();
  st.altitude = est_.altitude();
  return st;
}

FlightTelemetry FlightStack::telemetry() const {
  FlightTelemetry t;
  t.nav = est_.nav_state();
  const ctl::LandingDiagnostics& dg = controller_.diagnostics();
  t.platform_W_m = dg.platform_W_m;
  t.platform_v_W_mps = dg.platform_v_W_mps;
  t.horizontal_error_m = dg.horizontal_error_m;
  t.setpoint_W_m = dg.setpoint.p_W_m;
  return t;
}

FlightReport FlightStack::report() const {
  const ctl::LandingController& c = controller_;
  FlightReport r;
  for (const auto& tr : c.transitions()) r.transitions.push_back({tr.t_s, ctl::to_string(tr.from), ctl::to_string(tr.to), tr.reason});
  r.final_mode = ctl::to_string(c.mode());
  const ctl::LandingDecisionLog& dl = c.decision_log();
  r.attempts = dl.attempts;
  r.decision = dl.decision;
  r.decision_reason = dl.reason;
  r.decision_t_s = dl.t_s;
  r.wide_gate_m = dl.wide_gate_m;
  for (const ctl::LandingEvent& e : dl.events) r.events.push_back({e.t_s, e.attempt, e.what, e.reason});
  for (const ctl::Reacquisition& q : c.reacquisitions()) {
    r.reacquisitions.push_back({q.t_last_seen_s, q.t_lost_s, ctl::to_string(q.lost_in), q.t_reacquired_s, q.prediction_error_m});
  }
  r.telemetry_received = c.telemetry_received();
  r.telemetry_search_s = static_cast<double>(c.telemetry_search_steps()) / c.params().cascade.outer_rate_hz;
  r.rejected = est_.rejected();
  r.altitude_height_resets = est_.height_resets();
  r.altitude_baro_fallback_updates = est_.baro_fallback_updates();
  r.path_steps = c.path_steps();
  r.path_target_steps = c.path_target_steps();
  return r;
}

std::optional<RotorSpeeds> FlightStack::on_imu(const ImuSample& raw) {
  const std::optional<ctl::RotorCommand> cmd = step_imu(raw);
  if (!cmd) return std::nullopt;
  RotorSpeeds out;
  out.t_s = cmd->t_s;
  out.motors_cut = cmd->motors_cut;
  for (int r = 0; r < kRotorCount; ++r) out.w_radps[r] = cmd->w_radps[r];
  return out;
}

VisionResult FlightStack::vision_result(const RingDetection& det, double t_mid_s) const {
  VisionResult vr;
  vr.obs = to_platform_observation(det, t_mid_s);
  if (det.detected && det.keyframe) vr.h_plane_m = height_above_target_m(det.X_CP, config_.mount.X_BC());
  return vr;
}

double FlightStack::observation_time(const ExposureInterval& e, const PlatformObservation& obs, int image_rows) const {
  const Eigen::Vector3d p_C = obs.X_CP.translation();
  if (!config_.estimator.vision.rolling_shutter_row_time || !(e.readout_s > 0) || !obs.detected || image_rows <= 0 ||
      !p_C.allFinite() || !(p_C.z() > 0)) {
    return e.mid();
  }
  const double row = config_.camera.fy_px * p_C.y() / p_C.z() + config_.camera.cy_px;
  const double fraction = std::clamp(row / image_rows, 0.0, 1.0);
  return e.t_start_s + e.readout_s * fraction + 0.5 * e.row_exposure_s();
}

Eigen::Vector2d FlightStack::predicted_blur_px(const ExposureInterval& exposure) const {
  const double T = exposure.row_exposure_s();
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
    const double h = est_.altitude_started() ? est_.altitude().h_surface_m : nav.p_W_m.z();
    Z = h / std::max(kMinAxisCosine, -R_WC.col(2).z());
  }
  Z = std::max(Z, kMinBlurDepthM);
  const Eigen::Vector2d blur = axis_point_motion_blur_px(w_C, v_C, Z, config_.camera.fx_px, config_.camera.fy_px, T);
  return blur.allFinite() ? blur : Eigen::Vector2d::Zero();
}

double FlightStack::min_target_depth_m() const {
  const NavState nav = nav_state();
  if (!config_.estimator.vision.predict_min_depth || !nav.valid || !est_.altitude_started()) return 0.0;
  const AltitudeEstimate alt = est_.altitude();
  const AltitudeFusionParams& ap = config_.estimator.altitude;
  const Eigen::Isometry3d X_BC = config_.mount.X_BC();
  const Eigen::Matrix3d R_WB = nav.q_WB.toRotationMatrix();
  const Eigen::Matrix3d R_WC = R_WB * X_BC.linear();
  const double z_camera = alt.z_W_m + (R_WB * X_BC.translation()).z();
  const double std_m = std::sqrt(std::max(0.0, alt.var_m2) + ap.platform_height_std_m * ap.platform_height_std_m);
  const double dh = z_camera - ap.platform_height_m - kDepthSigmas * std_m - kDepthMargin_m;
  return least_plane_depth_m(border_rays_, R_WC, dh);
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

void FlightStack::on_platform_telemetry(const GpsSample& g) {
  // Not the vehicle's own GPS: the sample screen's GPS state must not see it. The controller
  // drops a non-finite message and counts it.
  controller_.on_platform_telemetry(g);
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
  if (est_.on_vision(vr.obs, vr.h_plane_m)) controller_.on_vision(vr.obs);
}

std::optional<ctl::RotorCommand> FlightStack::step_imu(const ImuSample& raw) {
  // A rejected sample is replaced by the last good one (zero-order hold).
  const std::optional<ImuSample> s = est_.on_imu(raw);
  if (!s) return std::nullopt;
  if (est_.altitude_started()) controller_.on_altitude(est_.altitude());
  const NavState ns = est_.nav_state();
  if (!ns.valid) return std::nullopt;
  return controller_.step(s->t_s, ns, *s);
}

}  // namespace lander::flight
