#include "lander/sim/recorder/recorder.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "lander/estimator/altitude_fusion.h"
#include "loop/overlay.h"

namespace lander::sim {

using Json = nlohmann::ordered_json;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Draws the flight software's overlays of one frame on a (downscaled) camera frame.
void draw_overlays(cv::Mat& img, const flight::FrameReport& rep, double scale) {
  for (const auto& e : rep.ellipses) {
    const cv::Scalar colour = e.identified ? cv::Scalar(0, 220, 0) : cv::Scalar(0, 140, 255);
    const cv::RotatedRect r(cv::Point2f(e.centre_px.x() * scale, e.centre_px.y() * scale),
                            cv::Size2f(2 * e.a_px * scale, 2 * e.b_px * scale),
                            static_cast<float>(e.angle_rad * 180.0 / M_PI));
    cv::ellipse(img, r, colour, 1, cv::LINE_AA);
  }
  for (const auto& c : rep.points) {
    const cv::Point p(static_cast<int>(c.px.x() * scale), static_cast<int>(c.px.y() * scale));
    cv::drawMarker(img, p, cv::Scalar(0, 0, 255), cv::MARKER_CROSS, 8, 1);
    cv::putText(img, c.label, p + cv::Point(4, -4), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 255), 1,
                cv::LINE_AA);
  }
  // The route stage's candidate points (seed 003; undistorted pixels, drawn on the frame as
  // delivered: exact for the default camera, which has no distortion).
  for (const Eigen::Vector2d& p : rep.route_points_px) {
    cv::circle(img, cv::Point2d(p.x() * scale, p.y() * scale), 4, cv::Scalar(255, 255, 0), 2, cv::LINE_AA);
  }
}

int geom_id(const mjModel* m, const char* name) { return mj_name2id(m, mjOBJ_GEOM, name); }

double tilt_to_platform_rad(const Eigen::Isometry3d& X_WB, const Eigen::Isometry3d& X_WP) {
  return std::acos(std::clamp(X_WB.linear().col(2).dot(X_WP.linear().col(2)), -1.0, 1.0));
}

}  // namespace

// ------------------------------------------------------------------------------ judge
LandingJudge::LandingJudge(const World& world)
    : world_(world),
      skid_left_(geom_id(world.model(), "skid_left")),
      skid_right_(geom_id(world.model(), "skid_right")),
      platform_geom_(geom_id(world.model(), "platform")),
      ground_geom_(geom_id(world.model(), "ground")) {}

// Velocity in W of the platform's point under the vehicle at p_W: the cart's x, y and yaw
// rates (the deck's six components when it moves).
Eigen::Vector3d LandingJudge::platform_velocity_below(const Eigen::Vector3d& p_W, const Eigen::Isometry3d& X_WP) const {
  if (world_.has_deck()) {  // at the platform's point under p_W
    Eigen::Vector3d p_P = X_WP.inverse() * p_W;
    p_P.z() = 0.0;
    return world_.cart_point_velocity_W(X_WP * p_P);
  }
  const Eigen::Vector3d qd = world_.cart_qd();
  const Eigen::Vector3d r = p_W - X_WP.translation();
  return Eigen::Vector3d(qd.x() - qd.z() * r.y(), qd.y() + qd.z() * r.x(), 0.0);
}

std::optional<Outcome> LandingJudge::update(double tn, const VehicleTruth& truth, const flight::FlightStatus& st,
                                            const flight::FlightSoftware& fs) {
  const mjModel* m = world_.model();
  const mjData* d = world_.data();
  const int vb = world_.vehicle_body();
  const Eigen::Isometry3d X_WP = world_.X_WP();
  bool on_platform = false, on_ground = false;
  for (int i = 0; i < d->ncon; ++i) {
    const mjContact& con = d->contact[i];
    const bool ours = con.geom1 == skid_left_ || con.geom1 == skid_right_ ||
                      con.geom2 == skid_left_ || con.geom2 == skid_right_ ||
                      m->geom_bodyid[con.geom1] == vb || m->geom_bodyid[con.geom2] == vb;
    if (!ours) continue;
    const int other = m->geom_bodyid[con.geom1] == vb ? con.geom2 : con.geom1;
    if (other == platform_geom_) on_platform = true;
    if (other == ground_geom_) on_ground = true;
  }
  if ((on_platform || on_ground) && t_first_contact_ < 0) {
    t_first_contact_ = tn;
    const Eigen::Vector3d p_PB = X_WP.inverse() * truth.X_WB.translation();
    const Eigen::Vector3d v_platform = platform_velocity_below(truth.X_WB.translation(), X_WP);
    touchdown_["surface"] = on_platform ? "platform" : "ground";
    touchdown_["t_s"] = tn;
    touchdown_["offset_m"] = p_PB.head<2>().norm();
    touchdown_["offset_P_m"] = {p_PB.x(), p_PB.y()};
    touchdown_["rel_speed_mps"] = (truth.v_W_mps - v_platform).norm();
    touchdown_["rel_vertical_speed_mps"] = truth.v_W_mps.z() - v_platform.z();
    touchdown_["tilt_deg"] = tilt_to_platform_rad(truth.X_WB, X_WP) * 180.0 / M_PI;
    touchdown_["mode_at_contact"] = st.mode;
    if (world_.has_deck()) {  // the deck at contact: its tilt, heave and vertical speed there
      touchdown_["deck_tilt_deg"] = std::acos(std::clamp(X_WP.linear()(2, 2), -1.0, 1.0)) * 180.0 / M_PI;
      touchdown_["deck_heave_m"] = world_.deck_q().x();
      touchdown_["deck_vz_mps"] = v_platform.z();
    }
  }
  if (on_ground) touched_ground_ = true;
  const double tilt_now = tilt_to_platform_rad(truth.X_WB, X_WP);
  const bool resting = on_platform && !on_ground && st.motors_cut &&
                       tilt_now < 20.0 * M_PI / 180.0;
  if (resting) {
    if (t_landed_confirm_ < 0) t_landed_confirm_ = tn;
  } else {
    t_landed_confirm_ = -1;
  }
  if (tilt_now > 80.0 * M_PI / 180.0 && (on_ground || on_platform)) {
    return Outcome{"tipped_over", fmt::format("vehicle tipped over (tilt {:.0f} deg) at t = {:.2f} s",
                                              tilt_now * 180 / M_PI, tn)};
  }
  if (touched_ground_ && !on_platform && truth.X_WB.translation().z() < 0.5) {
    return Outcome{"touched_ground", fmt::format("the landing gear touched the ground at t = {:.2f} s", tn)};
  }
  if (t_landed_confirm_ >= 0 && tn - t_landed_confirm_ >= 1.0) {
    return Outcome{"landed", "resting on the platform with motors cut for 1 s"};
  }
  if (st.aborted) {
    const flight::FlightReport r = fs.report();
    return Outcome{"aborted", fmt::format("the flight software aborted the landing at t = {:.2f} s after {} "
                                          "attempts: {}", tn, r.attempts, r.decision_reason)};
  }
  return std::nullopt;
}

// ---------------------------------------------------------------------------- recorder
Recorder::Recorder(const Scenario& s, const RunOptions& o, World& world, Renderer* renderer)
    : s_(s),
      world_(world),
      renderer_(renderer),
      video_(o.video),
      video_w_(s.camera.intrinsics.width_px / s.video.camera_scale_div / 2 * 2),
      video_h_(s.camera.intrinsics.height_px / s.video.camera_scale_div / 2 * 2),
      trace_(o.out_dir + "/trace.csv",
             {"t_s", "mode", "x_WB_m", "y_WB_m", "z_WB_m", "roll_rad", "pitch_rad", "yaw_rad",
              "vx_W_mps", "vy_W_mps", "vz_W_mps", "x_WP_m", "y_WP_m", "z_WP_m", "yaw_WP_rad",
              "vx_cart_mps", "vy_cart_mps", "nav_x_m", "nav_y_m", "nav_z_m", "nav_vx_mps",
              "nav_vy_mps", "nav_vz_mps", "nav_roll_rad", "nav_pitch_rad", "nav_yaw_rad",
              "fused_z_m", "fused_h_surface_m", "true_h_surface_m", "ctl_platform_x_m",
              "ctl_platform_y_m", "ctl_platform_z_m", "ctl_platform_vx_mps", "ctl_platform_vy_mps",
              "ctl_horizontal_error_m", "true_horizontal_error_m", "sp_x_m", "sp_y_m", "sp_z_m",
              "vision_detected", "w0_radps", "w1_radps", "w2_radps", "w3_radps", "w4_radps",
              "w5_radps"}),
      trace_every_(std::max(1, static_cast<int>(std::lround(1.0 / (s.trace_rate_hz * s.world.physics_dt_s))))),
      judge_(world) {
  if (video_ && renderer_ == nullptr) throw std::logic_error("Recorder: video needs a renderer");
  if (video_) {
    cam_video_ = std::make_unique<VideoWriter>(o.out_dir + "/camera.mp4", video_w_, video_h_, s.camera.rate_hz);
    chase_video_ = std::make_unique<VideoWriter>(o.out_dir + "/chase.mp4", s.video.chase_width_px,
                                                 s.video.chase_height_px, s.camera.rate_hz);
  }
}

Recorder::FrameCapture Recorder::capture_frame(const CameraFrame& frame, const flight::FlightSoftware& fs) {
  FrameCapture cap;
  // Truth at mid-exposure (the state now is the exposure end).
  cap.z_mid_m = world_.X_WB().translation().z() -
                world_.v_WB().z() * (frame.exposure.t_end_s - frame.exposure.mid());
  cap.h_ray_m = world_.ray_distance(world_.X_WB().translation(), -Eigen::Vector3d::UnitZ());
  cap.platform_z_m = world_.X_WP().translation().z();
  if (!video_) return cap;
  const flight::FlightStatus st = fs.status();
  cap.mode = st.mode;
  cap.altitude_started = st.altitude_valid;
  cap.altitude = st.altitude;
  renderer_->render_free(world_.model(), world_.data(), chase_camera(world_, s_.video), s_.video.chase_width_px,
                         s_.video.chase_height_px, cap.chase);
  return cap;
}

void Recorder::on_frame(const CameraFrame& frame, const FrameCapture& cap, const flight::FrameReport& rep) {
  ++frames_;
  if (rep.detected) {
    ++detections_;
    if (rep.deblurred) ++detections_deblurred_;
    if (rep.unfiltered) ++detections_unfiltered_;
    if (rep.zoomed) ++detections_zoomed_;
    if (rep.by_layout) ++detections_by_layout_;
    if (rep.by_platform) ++detections_by_platform_;
    if (rep.keyframe) ++keyframes_;
    if (rep.keyframe_rejected) ++keyframes_rejected_;
  } else {
    ++not_detected_reasons_[rep.reason];
  }
  const double t_mid = frame.exposure.mid();
  if (rep.detected && rep.keyframe && std::isfinite(rep.vision_height_m)) {
    alt_metrics_.add("vision", rep.vision_height_m - (cap.z_mid_m - cap.platform_z_m),
                     cap.h_ray_m > 0 ? cap.h_ray_m : cap.z_mid_m);
  }
  if (!video_) return;
  const CameraModel& cam = s_.camera.intrinsics;
  cv::Mat small;
  cv::resize(frame.bgr, small, cv::Size(video_w_, video_h_), 0, 0, cv::INTER_AREA);
  if (s_.video.overlays) {
    const double scale = static_cast<double>(video_w_) / cam.width_px;
    draw_overlays(small, rep, scale);
    put_text(small, fmt::format("t {:.2f} s   mode {}{}", t_mid, cap.mode,
                                rep.route_searched ? fmt::format("   route points {}", rep.route_points_px.size())
                                                   : std::string()),
             0);
    if (cap.altitude_started) {
      const AltitudeEstimate& a = cap.altitude;
      put_text(small, fmt::format("fused height above surface {:.2f} m   z {:.2f} m", a.h_surface_m, a.z_W_m), 1);
    } else {
      put_text(small, "fused height: no estimate yet", 1);
    }
    put_text(small, rep.overlay_text, 2);
  }
  cam_video_->write(small);
  cv::Mat chase = cap.chase;
  if (s_.video.overlays) put_text(chase, fmt::format("t {:.2f} s  mode {}", t_mid, cap.mode), 0);
  chase_video_->write(chase);
}

void Recorder::on_samples(const SensorSuite::Sampled& smp, const VehicleTruth& truth) {
  const double true_z = truth.X_WB.translation().z();
  const double true_h = std::isfinite(truth.h_surface_m) ? truth.h_surface_m : true_z;
  const SensorSuiteParams& sp = s_.sensors;
  if (smp.baro) {
    const double p = smp.baro->pressure_pa;
    const double h_baro = p > 0 && std::isfinite(p) ? isa_altitude_m(p) : kNaN;  // counted, unused
    alt_metrics_.add("baro", h_baro - sp.baro.origin_msl_m - true_z, true_h);
  }
  if (smp.gps && smp.gps->valid) alt_metrics_.add("gps", smp.gps->p_W_m.z() - true_z, true_h);
  if (smp.ultrasonic) {
    // Only while the true range is inside the sensor's range (eq. 12): outside it the reading
    // is garbage by design, and garbage that happens to look valid is not "in range".
    if (std::isfinite(truth.range_m) && truth.range_m >= sp.ultrasonic.min_range_m &&
        truth.range_m <= sp.ultrasonic.max_range_m) {
      alt_metrics_.add("ultrasonic", smp.ultrasonic->range_m * truth.X_WB.linear()(2, 2) - true_h, true_h);
    }
  }
}

std::optional<Outcome> Recorder::on_step(int k, const VehicleTruth& truth, const flight::FlightSoftware& fs,
                                         const RotorArray& rotor_speeds_radps) {
  const double tn = truth.t_s;
  const flight::FlightStatus st = fs.status();
  const bool alt_started = st.altitude_valid;
  const AltitudeEstimate& a = st.altitude;
  if (alt_started) {
    fused_z_err_.add(a.z_W_m - truth.X_WB.translation().z());
    if (k % 10 == 0) {  // 100 Hz, the rate of the fastest height sensor
      alt_metrics_.add("fused", a.z_W_m - truth.X_WB.translation().z(),
                       std::isfinite(truth.h_surface_m) ? truth.h_surface_m : truth.X_WB.translation().z());
    }
    if (std::isfinite(truth.h_surface_m)) fused_h_err_.add(a.h_surface_m - truth.h_surface_m);
  }
  if (std::optional<Outcome> out = judge_.update(tn, truth, st, fs)) return out;
  // The route's end, reached and held (seed 003): the run is over.
  constexpr double kRouteEndHold_s = 3.0;  // long enough to show the hold is stable
  if (st.route_ended && tn - st.route_end_t_s >= kRouteEndHold_s) {
    return Outcome{"route_end", fmt::format("the end of the route was reached at t = {:.2f} s and held for "
                                            "{:.0f} s; no target found", st.route_end_t_s, kRouteEndHold_s)};
  }
  // Cross-track error at 100 Hz while following the route, until it is covered (the vehicle's
  // ground point within kCovered_m of the route's end by arc length).
  // The law stops where the last candidate leaves the annulus: its inner radius on the
  // ground (60 px at 4 m: 0.375 m) before the end, plus the hold's drift.
  constexpr double kCovered_m = 0.5;
  const RouteGeometry& route = world_.route();
  if (!route.empty() && k % 10 == 0 && path_covered_t_ < 0 && st.following_route) {
    if (path_t0_ < 0) path_t0_ = tn;
    double s_on = 0;
    cross_track_m_.push_back(route.distance(truth.X_WB.translation().head<2>(), &s_on));
    path_s_max_ = std::max(path_s_max_, s_on);
    if (s_on >= route.length() - kCovered_m) path_covered_t_ = tn;
  }
  if (k % trace_every_ != 0) return std::nullopt;
  const flight::FlightTelemetry tm = fs.telemetry();
  const NavState& ns = tm.nav;
  const Eigen::Isometry3d X_WP = world_.X_WP();
  const Eigen::Vector3d rpy = rpy_of(truth.X_WB.linear());
  // The flight software's estimates only once it has them (NaN before).
  const Eigen::Vector3d nrpy = ns.valid ? rpy_of(ns.q_WB.toRotationMatrix()) : Eigen::Vector3d::Constant(kNaN);
  const Eigen::Vector3d np = ns.valid ? ns.p_W_m : Eigen::Vector3d::Constant(kNaN);
  const Eigen::Vector3d nv = ns.valid ? ns.v_W_mps : Eigen::Vector3d::Constant(kNaN);
  const double fz = alt_started ? a.z_W_m : kNaN, fh = alt_started ? a.h_surface_m : kNaN;
  const Eigen::Vector3d pw = truth.X_WB.translation(), pp = X_WP.translation();
  const Eigen::Vector3d cart_v = world_.cart_qd();  // (x, y, yaw) rates
  trace_.num(tn, 4).text(st.mode);
  for (double v : {pw.x(), pw.y(), pw.z(), rpy.x(), rpy.y(), rpy.z(), truth.v_W_mps.x(), truth.v_W_mps.y(),
                   truth.v_W_mps.z(), pp.x(), pp.y(), pp.z(), rpy_of(X_WP.linear()).z(), cart_v.x(),
                   cart_v.y(), np.x(), np.y(), np.z(), nv.x(), nv.y(), nv.z(), nrpy.x(), nrpy.y(), nrpy.z(),
                   fz, fh, std::isfinite(truth.h_surface_m) ? truth.h_surface_m : -1.0,
                   tm.platform_W_m.x(), tm.platform_W_m.y(), tm.platform_W_m.z(), tm.platform_v_W_mps.x(),
                   tm.platform_v_W_mps.y(), tm.horizontal_error_m, (pw - pp).head<2>().norm(),
                   tm.setpoint_W_m.x(), tm.setpoint_W_m.y(), tm.setpoint_W_m.z()}) {
    trace_.num(v, 5);
  }
  trace_.integer(last_detected_ ? 1 : 0);
  for (double w : rotor_speeds_radps) trace_.num(w, 2);
  trace_.end_row();
  return std::nullopt;
}

void Recorder::finish(const Outcome& outcome, const flight::FlightSoftware& fs, Json& summary) {
  if (cam_video_) cam_video_->close();
  if (chase_video_) chase_video_->close();
  trace_.commit();
  const flight::FlightReport c = fs.report();
  const Json& td = judge_.touchdown();
  summary["landed"] = outcome.name == "landed";
  summary["outcome"] = outcome.name;
  summary["outcome_detail"] = outcome.detail;
  // Null (NaN) when there was no contact.
  auto touchdown_value = [&](const char* key) { return td.contains(key) ? td[key].get<double>() : kNaN; };
  summary["touchdown_offset_m"] = touchdown_value("offset_m");
  summary["touchdown_rel_speed_mps"] = touchdown_value("rel_speed_mps");
  summary["touchdown_tilt_deg"] = touchdown_value("tilt_deg");
  summary["time_to_land_s"] = judge_.t_first_contact_s() >= 0 ? judge_.t_first_contact_s() : kNaN;
  summary["touchdown"] = td;
  Json transitions = Json::array();
  for (const auto& tr : c.transitions) {
    transitions.push_back({{"t_s", tr.t_s}, {"from", tr.from}, {"to", tr.to}, {"reason", tr.reason}});
  }
  // Who flew (the seam's info; where it came from, builtin or a plugin's file, is in
  // flight_software.json beside it, so that one software gives one summary either way).
  const flight::FlightSoftwareInfo who = fs.info();
  summary["flight_software"] = {{"name", who.name}, {"version", who.version}};
  summary["mode_transitions"] = transitions;
  summary["final_mode"] = c.final_mode;
  // The landing decisions (attempts, the latest decision and every event) and each loss of
  // the target with its re-acquisition (NaN written as null).
  Json events = Json::array();
  for (const auto& e : c.events) {
    events.push_back({{"t_s", e.t_s}, {"attempt", e.attempt}, {"what", e.what}, {"reason", e.reason}});
  }
  summary["landing_decision"] = {{"attempts", c.attempts}, {"decision", c.decision}, {"reason", c.decision_reason},
                                 {"t_s", c.decision_t_s}, {"wide_gate_m", c.wide_gate_m}, {"events", events}};
  Json reacq = Json::array();
  for (const auto& r : c.reacquisitions) {
    reacq.push_back({{"t_last_seen_s", r.t_last_seen_s}, {"t_lost_s", r.t_lost_s}, {"lost_in", r.lost_in},
                     {"t_reacquired_s", r.t_reacquired_s}, {"duration_s", r.t_reacquired_s - r.t_lost_s},
                     {"prediction_error_m", r.prediction_error_m}});
  }
  summary["reacquisitions"] = reacq;
  // The platform's broadcast (sensors.platform_telemetry): messages the flight software
  // accepted, and how long its search flew to one (s).
  summary["platform_telemetry"] = {{"enabled", s_.sensors.platform_telemetry.enabled},
                                   {"received", c.telemetry_received},
                                   {"search_s", c.telemetry_search_s}};
  Json vision = Json::object();
  vision["frames"] = frames_;
  vision["detections"] = detections_;
  vision["detections_deblurred"] = detections_deblurred_;
  vision["detections_unfiltered"] = detections_unfiltered_;
  vision["detections_zoomed"] = detections_zoomed_;
  vision["detections_by_layout"] = detections_by_layout_;
  vision["detections_by_platform"] = detections_by_platform_;
  vision["keyframes"] = keyframes_;
  vision["keyframes_rejected"] = keyframes_rejected_;
  Json reasons = Json::object();
  for (const auto& kv : not_detected_reasons_) reasons[kv.first] = kv.second;
  vision["not_detected_by_reason"] = reasons;
  vision["outliers_injected"] = outliers_injected_;
  summary["vision"] = vision;
  const RejectedSamples& rej = c.rejected;
  summary["rejected_samples"] = {{"imu", rej.imu},
                                 {"baro", rej.baro},
                                 {"gps", rej.gps},
                                 {"ultrasonic", rej.ultrasonic},
                                 {"magnetometer", rej.magnetometer},
                                 {"vision", rej.vision},
                                 {"total", rej.total()}};
  Json alt = Json::object();
  alt["fused_z_rmse_m"] = fused_z_err_.rmse_m();
  alt["fused_z_max_m"] = fused_z_err_.max_abs_m;
  alt["fused_h_surface_rmse_m"] = fused_h_err_.rmse_m();
  alt["fused_h_surface_max_m"] = fused_h_err_.max_abs_m;
  alt["by_sensor"] = alt_metrics_.json();
  alt["height_resets"] = c.altitude_height_resets;  // see height_reset_count
  alt["baro_fallback_updates"] = c.altitude_baro_fallback_updates;  // see baro_fallback_s
  summary["altitude_fusion"] = alt;
  if (!world_.route().empty()) {
    // Path following (seed 003, issue 14): null where there is nothing to measure.
    Json pf = Json::object();
    const SampleSummary xt = summarize(cross_track_m_);
    pf["route_length_m"] = world_.route().length();
    pf["followed_from_s"] = path_t0_ >= 0 ? path_t0_ : kNaN;
    pf["covered"] = path_covered_t_ >= 0;
    pf["time_to_cover_s"] = path_covered_t_ >= 0 ? path_covered_t_ - path_t0_ : kNaN;
    pf["covered_m"] = path_s_max_;
    pf["cross_track_samples"] = static_cast<int>(xt.n);
    pf["cross_track_mean_m"] = xt.mean;
    pf["cross_track_median_m"] = xt.median;
    pf["cross_track_p95_m"] = xt.p95;
    pf["cross_track_max_m"] = xt.max;
    // The largest error once the vehicle first came within kCaptured_m of the centre line
    // (the max above includes the approach from the start point).
    constexpr double kCaptured_m = 0.1;  // half the paper's route width
    double after = kNaN;
    bool captured = false;
    for (double x : cross_track_m_) {
      captured = captured || x < kCaptured_m;
      if (captured) after = std::isnan(after) ? x : std::max(after, x);
    }
    pf["cross_track_max_after_capture_m"] = after;
    const flight::FlightStatus st = fs.status();
    pf["guidance_steps"] = c.path_steps;
    pf["target_share"] = c.path_steps > 0 ? static_cast<double>(c.path_target_steps) / c.path_steps : kNaN;
    pf["route_end_t_s"] = st.route_ended ? st.route_end_t_s : kNaN;
    summary["path_following"] = pf;
  }
}

}  // namespace lander::sim
