// The closed loop (DESIGN.md, "The loop"): one deterministic fixed-step scheduler.
//
// Every physics step (1 kHz by default):
//   cart drive forces (PD + feed-forward on the scripted path), rotor thrust and torque with
//   motor lag and per-rotor ground effect (one ray per rotor), wind drag -> mj_step;
//   truth -> sensors at their own rates -> delay queues (latency) -> navigation and altitude
//   fusion; the camera exposes at its rate, rendering sub-frames at physics steps inside the
//   exposure (motion blur), and its frame goes to the ring detector, whose result reaches
//   the controller after the processing latency; the controller's inner loop runs on each
//   IMU sample and its rotor commands drive the motors.
// The simulator keeps the truth; the flight software (estimator/, controller/) sees only
// the samples.
#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <optional>

#include <opencv2/imgproc.hpp>

#include "lander/controller/landing_controller.h"
#include "lander/estimator/altitude_fusion.h"
#include "lander/estimator/altitude_vision.h"
#include "lander/estimator/navigation.h"
#include "lander/estimator/sample_screen.h"
#include "lander/estimator/vision_detector.h"
#include "lander/sim/altitude_metrics.h"
#include "lander/sim/ground_effect.h"
#include "lander/sim/loop.h"
#include "lander/sim/mujoco_errors.h"
#include "lander/sim/output_files.h"
#include "lander/sim/rotor.h"
#include "lander/sim/sensors.h"
#include "lander/sim/truth.h"
#include "lander/sim/video.h"
#include "lander/sim/wind.h"
#include "fault_hooks.h"
#include "overlay.h"

namespace lander::sim {

using Json = nlohmann::ordered_json;

namespace {

// Beyond this distance from the origin the vehicle state counts as diverged (m).
constexpr double kDivergedRange_m = 1e4;

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

double wrap_pi(double a) { return std::atan2(std::sin(a), std::cos(a)); }

// Draws the detector's view on a (downscaled) camera frame.
void draw_detection(cv::Mat& img, const RingDetection& det, double scale) {
  for (const auto& e : det.ellipses) {
    const cv::Scalar colour = e.ring_id >= 0 ? cv::Scalar(0, 220, 0) : cv::Scalar(0, 140, 255);
    const cv::RotatedRect r(cv::Point2f(e.image.centre.x() * scale, e.image.centre.y() * scale),
                            cv::Size2f(2 * e.image.a * scale, 2 * e.image.b * scale),
                            static_cast<float>(e.image.angle_rad * 180.0 / M_PI));
    cv::ellipse(img, r, colour, 1, cv::LINE_AA);
  }
  for (const auto& c : det.centres) {
    const cv::Point p(static_cast<int>(c.centre_image_px.x() * scale),
                      static_cast<int>(c.centre_image_px.y() * scale));
    cv::drawMarker(img, p, cv::Scalar(0, 0, 255), cv::MARKER_CROSS, 8, 1);
    cv::putText(img, std::to_string(c.ring_id), p + cv::Point(4, -4), cv::FONT_HERSHEY_SIMPLEX,
                0.45, cv::Scalar(0, 0, 255), 1, cv::LINE_AA);
  }
}

// Platform (cart) drive: PD + feed-forward per joint so the cart follows its path whatever
// lands on it. Gains in N/m, N s/m (x, y) and N m/rad, N m s/rad (yaw).
struct CartDrive {
  double mass_kg, yaw_inertia;
  void apply(World& w, const CartReference& ref) const {
    const Eigen::Vector3d q = w.cart_q(), qd = w.cart_qd();
    const double kp[3] = {4000.0, 4000.0, 3000.0}, kd[3] = {1200.0, 1200.0, 500.0};
    const double inertia[3] = {mass_kg, mass_kg, yaw_inertia};
    const mjModel* m = w.model();
    mjData* d = w.data();
    for (int i = 0; i < 3; ++i) {
      double e = ref.q[i] - q[i];
      if (i == 2) e = wrap_pi(e);
      const double damping = m->dof_damping[w.cart_dof(i)];
      d->ctrl[i] = inertia[i] * ref.qdd[i] + kp[i] * e + kd[i] * (ref.qd[i] - qd[i]) +
                   damping * ref.qd[i];
    }
  }
};

}  // namespace

LoopResult run_closed_loop(const Scenario& s, const RunOptions& o, World& world,
                           Renderer& renderer, Json& summary) {
  const mjModel* m = world.model();
  mjData* d = world.data();
  const double dt = s.world.physics_dt_s;
  const CameraModel& cam = s.camera.intrinsics;
  const int vb = world.vehicle_body();
  const double mass = m->body_subtreemass[vb];

  // ---- initial state: cart on its path, vehicle hovering at the start point ----
  const CartReference ref0 = cart_reference(s.cart, 0.0);
  world.set_cart_state(ref0.q, ref0.qd);
  Eigen::Isometry3d X_WB0 = Eigen::Isometry3d::Identity();
  X_WB0.linear() = Eigen::AngleAxisd(s.vehicle.start_yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  X_WB0.translation() = s.vehicle.start_p_W_m;
  world.set_vehicle_state(X_WB0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  world.forward();

  const RotorParams& rp = s.vehicle.model.rotor;
  MotorBank motors(rp);
  const double w_hover = hover_speed_radps(rp, mass, -m->opt.gravity[2]);
  RotorArray w_cmd;
  w_cmd.fill(w_hover);
  motors.reset(w_cmd);
  WindModel wind(s.wind, derive_seed(s.seed, "wind"));
  const CartDrive cart_drive{m->body_mass[world.cart_body()], m->body_inertia[3 * world.cart_body() + 2]};

  // ---- sensors (truth side) and their delivery queues ----
  ImuModel imu(s.sensors.imu, derive_seed(s.seed, "imu"));
  BaroModel baro(s.sensors.baro, derive_seed(s.seed, "baro"));
  GpsModel gps(s.sensors.gps, derive_seed(s.seed, "gps"));
  UltrasonicModel sonar(s.sensors.ultrasonic, derive_seed(s.seed, "ultrasonic"));
  MagnetometerModel mag(s.sensors.magnetometer, derive_seed(s.seed, "magnetometer"));
  if (s.faults.gps_step_t_s >= 0) {
    gps.inject_offset(s.faults.gps_step_t_s, s.faults.gps_step_duration_s, s.faults.gps_step_W_m);
  }
  if (s.faults.ultrasonic_garbage_t_s >= 0) {
    sonar.inject_garbage(s.faults.ultrasonic_garbage_t_s, s.faults.ultrasonic_garbage_duration_s);
  }
  DelayQueue<ImuSample> imu_q;
  DelayQueue<BaroSample> baro_q;
  DelayQueue<GpsSample> gps_q;
  DelayQueue<UltrasonicSample> sonar_q;
  DelayQueue<MagSample> mag_q;
  // A vision result and, for a keyframe, its height above the target plane (else NaN).
  struct VisionResult {
    PlatformObservation obs;
    double h_plane_m{std::numeric_limits<double>::quiet_NaN()};
  };
  DelayQueue<VisionResult> vision_q;

  // ---- flight software ----
  const CameraMount mount;  // the vehicle's calibrated camera mount (matches the MJCF)
  RingTargetDetector detector(cam, world.target(), s.estimator.vision);
  Navigation nav(s.estimator.navigation);
  AltitudeFusion fusion(s.estimator.altitude);
  // Every sample and vision result passes the screen before any filter sees it.
  SampleScreen screen(s.estimator.sample_limits);
  // The vehicle starts in the air: the filter starts from the first barometer reading, with
  // the split between height and barometer bias left to GPS and vision.
  bool fusion_started = false;
  ctl::LandingController controller(s.controller, mount);

  // ---- camera schedule ----
  CameraPipeline camera(s.camera, derive_seed(s.seed, "camera"));
  const double frame_period = 1.0 / s.camera.rate_hz;
  int frame_index = 0;
  double next_frame_t = 0.0;
  std::vector<double> sample_times;
  std::size_t next_sample = 0;
  bool exposing = false;
  cv::Mat render;

  // ---- outputs ----
  std::unique_ptr<VideoWriter> cam_video, chase_video;
  const int vw = cam.width_px / s.video.camera_scale_div / 2 * 2;
  const int vh = cam.height_px / s.video.camera_scale_div / 2 * 2;
  if (o.video) {
    cam_video = std::make_unique<VideoWriter>(o.out_dir + "/camera.mp4", vw, vh, s.camera.rate_hz);
    chase_video = std::make_unique<VideoWriter>(o.out_dir + "/chase.mp4", s.video.chase_width_px,
                                                s.video.chase_height_px, s.camera.rate_hz);
  }
  CsvWriter trace(
      o.out_dir + "/trace.csv",
      {"t_s", "mode", "x_WB_m", "y_WB_m", "z_WB_m", "roll_rad", "pitch_rad", "yaw_rad",
       "vx_W_mps", "vy_W_mps", "vz_W_mps", "x_WP_m", "y_WP_m", "z_WP_m", "yaw_WP_rad",
       "vx_cart_mps", "vy_cart_mps", "nav_x_m", "nav_y_m", "nav_z_m", "nav_vx_mps",
       "nav_vy_mps", "nav_vz_mps", "nav_roll_rad", "nav_pitch_rad", "nav_yaw_rad", "fused_z_m",
       "fused_h_surface_m", "true_h_surface_m", "ctl_platform_x_m", "ctl_platform_y_m",
       "ctl_platform_z_m", "ctl_platform_vx_mps", "ctl_platform_vy_mps",
       "ctl_horizontal_error_m", "true_horizontal_error_m", "sp_x_m", "sp_y_m", "sp_z_m",
       "vision_detected", "w0_radps", "w1_radps", "w2_radps", "w3_radps", "w4_radps",
       "w5_radps"});
  const int trace_every = std::max(1, static_cast<int>(std::lround(1.0 / (s.trace_rate_hz * dt))));

  // ---- statistics ----
  LoopResult res;
  int frames = 0, detections = 0, keyframes = 0, keyframes_rejected = 0;
  std::map<std::string, int> not_detected_reasons;
  ErrorStats fused_z_err, fused_h_err;
  AltitudeMetrics alt_metrics;  // per-sensor height errors against truth (seed 004 figures)
  double t_first_contact = -1, t_landed_confirm = -1;
  bool touched_ground = false;
  Json touchdown = Json::object();
  RingDetection last_det;
  double last_det_t = -1;
  int vision_outliers_left = 0;
  std::string outcome = "timeout", outcome_detail;
  const FaultParams& F = s.faults;
  bool diverge_injected = false;
  Eigen::Vector3d v_prev = world.v_WB();

  const int n_steps = static_cast<int>(std::floor(s.duration_s / dt + 0.5));
  const std::array<int, 3> skid_geoms = {mj_name2id(m, mjOBJ_GEOM, "skid_left"),
                                         mj_name2id(m, mjOBJ_GEOM, "skid_right"), -1};
  const int platform_geom = mj_name2id(m, mjOBJ_GEOM, "platform");
  const int ground_geom = mj_name2id(m, mjOBJ_GEOM, "ground");
  const auto wall0 = Clock::now();

  for (int k = 0; k < n_steps; ++k) {
    const double t = k * dt;
    run_process_fault_hooks(F, t);  // abort / hang test hooks
    // ---- camera: renders at the exposure's sample times (state at time t) ----
    if (!exposing && t + 1e-9 >= next_frame_t) {
      exposing = true;
      camera.begin(t);
      sample_times = exposure_sample_times(s.camera, t, dt);
      next_sample = 0;
    }
    if (exposing) {
      while (next_sample < sample_times.size() && sample_times[next_sample] <= t + 1e-9) {
        const auto t0 = Clock::now();
        renderer.render_camera(m, d, world.camera_id(), cam.width_px, cam.height_px, render);
        camera.add(render);
        res.render_ms += ms_since(t0);
        ++next_sample;
      }
      if (next_sample >= sample_times.size() && t + 1e-9 >= camera_exposure_end(s.camera, next_frame_t)) {
        const CameraFrame frame = camera.finish(frame_index, world.X_WC());
        exposing = false;
        ++frame_index;
        next_frame_t += frame_period;
        ++frames;
        const auto t0 = Clock::now();
        RingDetection det = detector.detect(frame.bgr);
        const double proc_ms = ms_since(t0);
        res.estimator_ms += proc_ms;
        const double t_mid = frame.exposure.mid();
        if (s.faults.vision_outlier_t_s >= 0 && t_mid >= s.faults.vision_outlier_t_s &&
            vision_outliers_left == 0 && s.faults.vision_outlier_frames > 0 &&
            res.outliers_injected == 0) {
          vision_outliers_left = s.faults.vision_outlier_frames;
        }
        if (det.detected && vision_outliers_left > 0) {
          // Injected fault: the pose jumps along the optical axis.
          det.X_CP.translation().z() += s.faults.vision_outlier_m;
          --vision_outliers_left;
          ++res.outliers_injected;
        }
        if (det.detected) {
          ++detections;
          if (det.keyframe) ++keyframes;
          if (det.keyframe_status == KeyframeStatus::Rejected) ++keyframes_rejected;
        } else {
          ++not_detected_reasons[to_string(det.status)];
        }
        const double latency = s.estimator.measured_latency ? proc_ms * 1e-3 : s.estimator.vision_latency_s;
        const double deliver = frame.exposure.t_end_s + latency;
        VisionResult vr{to_platform_observation(det, t_mid)};
        if (det.detected && det.keyframe) vr.h_plane_m = height_above_target_m(det.X_CP, mount.X_BC());
        if (fault_active(t_mid, F.nan_vision_t_s, F.nan_vision_duration_s)) {
          corrupt_observation(vr.obs);  // test hook: a "detection" with a NaN pose
          vr.h_plane_m = height_above_target_m(vr.obs.X_CP, mount.X_BC());
        }
        vision_q.push(vr, deliver);
        if (det.detected && det.keyframe) {
          const double h_vision = height_above_target_m(det.X_CP, mount.X_BC());
          // Truth at mid-exposure (the state now is the exposure end).
          const double z_mid = world.X_WB().translation().z() -
                               world.v_WB().z() * (frame.exposure.t_end_s - t_mid);
          const double h_ray = world.ray_distance(world.X_WB().translation(), -Eigen::Vector3d::UnitZ());
          alt_metrics.add("vision", h_vision - (z_mid - world.X_WP().translation().z()),
                          h_ray > 0 ? h_ray : z_mid);
        }
        if (o.video) {
          cv::Mat small;
          cv::resize(frame.bgr, small, cv::Size(vw, vh), 0, 0, cv::INTER_AREA);
          if (s.video.overlays) {
            draw_detection(small, det, static_cast<double>(vw) / cam.width_px);
            const AltitudeEstimate a = fusion.estimate();
            put_text(small, fmt::format("t {:.2f} s   mode {}", t_mid, ctl::to_string(controller.mode())), 0);
            put_text(small, fmt::format("fused height above surface {:.2f} m   z {:.2f} m",
                                        a.h_surface_m, a.z_W_m),
                     1);
            put_text(small,
                     det.detected ? fmt::format("rings {}  reproj {:.2f} px  rho {:.4f}{}",
                                                det.centres.size(), det.reproj_err_px, det.rho,
                                                det.keyframe ? "" : "  (not a keyframe)")
                                  : std::string("no target: ") + to_string(det.status),
                     2);
          }
          cam_video->write(small);
          cv::Mat chase;
          renderer.render_free(m, d, chase_camera(world, s.video), s.video.chase_width_px,
                               s.video.chase_height_px, chase);
          if (s.video.overlays) {
            put_text(chase, fmt::format("t {:.2f} s  mode {}", t_mid, ctl::to_string(controller.mode())), 0);
          }
          chase_video->write(chase);
        }
        last_det = det;
        last_det_t = t_mid;
      }
    }

    // ---- vehicle forces: motors, per-rotor ground effect, wind drag ----
    const auto tp0 = Clock::now();
    motors.step(w_cmd, dt);
    const Eigen::Isometry3d X_WB = world.X_WB();
    RotorArray ge;
    for (int r = 0; r < kNumRotors; ++r) {
      const Eigen::Vector3d p_rotor(d->site_xpos + 3 * world.rotor_site(r));
      const double h = world.ray_distance(p_rotor, -Eigen::Vector3d::UnitZ());
      ge[r] = h > 0 ? ground_effect_factor(s.vehicle.model.ground_effect, h) : 1.0;
    }
    const BodyWrench wr = rotor_wrench(rp, motors.speeds_radps(), ge);
    const Eigen::Vector3d air = wind.step(dt);
    const Eigen::Vector3d drag_W = drag_force_W(s.wind, X_WB.linear(), world.v_WB(), air);
    const Eigen::Vector3d f_W = X_WB.linear() * wr.force_B_N + drag_W;
    const Eigen::Vector3d tau_W = X_WB.linear() * wr.torque_B_Nm;
    for (int i = 0; i < 3; ++i) {
      d->xfrc_applied[6 * vb + i] = f_W[i];
      d->xfrc_applied[6 * vb + 3 + i] = tau_W[i];
    }
    cart_drive.apply(world, cart_reference(s.cart, t));
    if (F.diverge_t_s >= 0 && t >= F.diverge_t_s && !diverge_injected) {
      d->qvel[world.vehicle_dof_adr() + 2] = std::numeric_limits<double>::quiet_NaN();  // test hook
      diverge_injected = true;
    }
    const double tn = (k + 1) * dt;
    // A NaN or runaway state makes MuJoCo warn ("... The simulation is unstable"); our warning
    // handler throws. The run ends there as `diverged`, with its outputs complete to that time.
    try {
      mj_step(m, d);
    } catch (const MujocoError& e) {
      if (!is_instability_warning(e.what())) throw;
      outcome = "diverged";
      outcome_detail = fmt::format("{} (at t = {:.3f} s)", e.what(), tn);
      res.sim_s = t;
      break;
    }
    res.physics_ms += ms_since(tp0);

    // ---- truth ----
    VehicleTruth truth;
    truth.t_s = tn;
    truth.X_WB = world.X_WB();
    truth.v_W_mps = world.v_WB();
    truth.omega_B_radps = world.omega_B();
    truth.a_W_mps2 = (truth.v_W_mps - v_prev) / dt;
    v_prev = truth.v_W_mps;
    truth.h_surface_m = world.ray_distance(truth.X_WB.translation(), -Eigen::Vector3d::UnitZ());
    if (truth.h_surface_m < 0) truth.h_surface_m = std::numeric_limits<double>::quiet_NaN();
    const double range = world.ray_distance(truth.X_WB.translation(), -truth.X_WB.linear().col(2));
    truth.range_m = range < 0 ? std::numeric_limits<double>::infinity() : range;
    double thrust = 0;
    for (double w : motors.speeds_radps()) thrust += rotor_thrust_N(rp, w);
    truth.thrust_fraction = thrust / (kNumRotors * rotor_thrust_N(rp, rp.w_max_radps));
    if (!world.state_finite() || !truth.X_WB.translation().allFinite() ||
        truth.X_WB.translation().norm() > kDivergedRange_m) {
      outcome = "diverged";
      outcome_detail = fmt::format(
          "the vehicle state is not finite or beyond {:.0f} km of the origin at t = {:.3f} s",
          kDivergedRange_m / 1000.0, tn);
      res.sim_s = tn;
      break;
    }

    // ---- sensors -> queues; each height sensor's error against truth at its sampling time ----
    const auto tc0 = Clock::now();
    const double true_z = truth.X_WB.translation().z();
    const double true_h = std::isfinite(truth.h_surface_m) ? truth.h_surface_m : true_z;
    // Corrupted-sample test hooks act after the metrics, on the way to the flight software.
    if (imu.due(tn)) {
      ImuSample si = imu.sample(truth);
      if (fault_active(tn, F.nan_imu_t_s, F.nan_imu_duration_s)) corrupt_sample(si);
      imu_q.push(si, tn + s.sensors.imu.latency_s);
    }
    if (mag.due(tn)) {
      MagSample sm = mag.sample(truth);
      if (fault_active(tn, F.nan_magnetometer_t_s, F.nan_magnetometer_duration_s)) corrupt_sample(sm);
      mag_q.push(sm, tn + s.sensors.magnetometer.latency_s);
    }
    if (baro.due(tn)) {
      BaroSample b = baro.sample(truth);
      const double h_baro = b.pressure_pa > 0 && std::isfinite(b.pressure_pa)
                                ? isa_altitude_m(b.pressure_pa)
                                : std::numeric_limits<double>::quiet_NaN();  // counted, unused
      alt_metrics.add("baro", h_baro - s.estimator.altitude.baro_origin_msl_m - true_z, true_h);
      if (fault_active(tn, F.nan_baro_t_s, F.nan_baro_duration_s)) corrupt_sample(b);
      baro_q.push(b, tn + s.sensors.baro.latency_s);
    }
    if (gps.due(tn)) {
      GpsSample g = gps.sample(truth);
      if (g.valid) alt_metrics.add("gps", g.p_W_m.z() - true_z, true_h);
      if (fault_active(tn, F.absurd_gps_t_s, F.absurd_gps_duration_s)) corrupt_sample(g);
      gps_q.push(g, tn + s.sensors.gps.latency_s);
    }
    if (sonar.due(tn)) {
      UltrasonicSample u = sonar.sample(truth);
      // Only while the true range is inside the sensor's range (eq. 12): outside it the
      // reading is garbage by design, and garbage that happens to look valid is not "in range".
      if (std::isfinite(truth.range_m) && truth.range_m >= s.sensors.ultrasonic.min_range_m &&
          truth.range_m <= s.sensors.ultrasonic.max_range_m) {
        alt_metrics.add("ultrasonic", u.range_m * truth.X_WB.linear()(2, 2) - true_h, true_h);
      }
      if (fault_active(tn, F.nan_ultrasonic_t_s, F.nan_ultrasonic_duration_s)) corrupt_sample(u);
      sonar_q.push(u, tn + s.sensors.ultrasonic.latency_s);
    }

    // ---- flight software: estimation ----
    for (const BaroSample& b : baro_q.pop_ready(tn)) {
      if (!screen.accept(b)) continue;
      if (!fusion_started) {
        // In the air at start: the first reading fixes height + baro bias, not their split.
        fusion.reset_from_baro(b);
        fusion_started = true;
      }
      fusion.update_baro(b);
    }
    for (const GpsSample& g : gps_q.pop_ready(tn)) {
      if (!screen.accept(g)) continue;
      nav.add_gps(g);
      if (fusion_started) fusion.update_gps(g);
    }
    for (const UltrasonicSample& u : sonar_q.pop_ready(tn)) {
      if (!screen.accept(u)) continue;
      if (fusion_started) fusion.update_ultrasonic(u);
    }
    for (const VisionResult& vr : vision_q.pop_ready(tn)) {
      if (!screen.accept(vr.obs)) continue;
      if (fusion_started && std::isfinite(vr.h_plane_m)) fusion.update_vision(vr.obs.t_s, vr.h_plane_m);
      controller.on_vision(vr.obs);
    }
    for (const MagSample& ms : mag_q.pop_ready(tn)) {
      if (screen.accept(ms)) nav.add_mag(ms);
    }
    for (const ImuSample& raw_imu : imu_q.pop_ready(tn)) {
      // A rejected sample is replaced by the last good one (zero-order hold).
      const std::optional<ImuSample> screened = screen.imu(raw_imu);
      if (!screened) continue;
      const ImuSample& s_imu = *screened;
      nav.add_imu(s_imu);
      const NavState ns = nav.state();
      if (fusion_started) {
        fusion.predict(s_imu, ns.q_WB, s.sensors.imu.gravity_mps2);
        controller.on_altitude(fusion.estimate());
      }
      // ---- controller inner loop, on every IMU sample ----
      if (ns.valid) {
        const ctl::RotorCommand cmd = controller.step(s_imu.t_s, ns, s_imu);
        for (int r = 0; r < kNumRotors; ++r) w_cmd[r] = cmd.w_radps[r];
      }
    }
    res.control_ms += ms_since(tc0);

    // ---- truth metrics: fusion error, contact ----
    const Eigen::Isometry3d X_WP = world.X_WP();
    if (fusion_started) {
      const AltitudeEstimate a = fusion.estimate();
      fused_z_err.add(a.z_W_m - truth.X_WB.translation().z());
      if (k % 10 == 0) {  // 100 Hz, the rate of the fastest height sensor
        alt_metrics.add("fused", a.z_W_m - truth.X_WB.translation().z(),
                        std::isfinite(truth.h_surface_m) ? truth.h_surface_m : truth.X_WB.translation().z());
      }
      if (std::isfinite(truth.h_surface_m)) fused_h_err.add(a.h_surface_m - truth.h_surface_m);
    }
    bool on_platform = false, on_ground = false;
    for (int c = 0; c < d->ncon; ++c) {
      const mjContact& con = d->contact[c];
      const bool ours = con.geom1 == skid_geoms[0] || con.geom1 == skid_geoms[1] ||
                        con.geom2 == skid_geoms[0] || con.geom2 == skid_geoms[1] ||
                        m->geom_bodyid[con.geom1] == vb || m->geom_bodyid[con.geom2] == vb;
      if (!ours) continue;
      const int other = m->geom_bodyid[con.geom1] == vb ? con.geom2 : con.geom1;
      if (other == platform_geom) on_platform = true;
      if (other == ground_geom) on_ground = true;
    }
    if ((on_platform || on_ground) && t_first_contact < 0) {
      t_first_contact = tn;
      const Eigen::Vector3d p_PB = X_WP.inverse() * truth.X_WB.translation();
      const Eigen::Vector3d qd = world.cart_qd();
      const Eigen::Vector3d r = truth.X_WB.translation() - X_WP.translation();
      const Eigen::Vector3d v_platform(qd.x() - qd.z() * r.y(), qd.y() + qd.z() * r.x(), 0.0);
      const double tilt = std::acos(std::clamp(truth.X_WB.linear().col(2).dot(X_WP.linear().col(2)), -1.0, 1.0));
      touchdown["surface"] = on_platform ? "platform" : "ground";
      touchdown["t_s"] = tn;
      touchdown["offset_m"] = p_PB.head<2>().norm();
      touchdown["offset_P_m"] = {p_PB.x(), p_PB.y()};
      touchdown["rel_speed_mps"] = (truth.v_W_mps - v_platform).norm();
      touchdown["rel_vertical_speed_mps"] = truth.v_W_mps.z() - v_platform.z();
      touchdown["tilt_deg"] = tilt * 180.0 / M_PI;
      touchdown["mode_at_contact"] = ctl::to_string(controller.mode());
    }
    if (on_ground) touched_ground = true;
    // Landed: resting on the platform, motors cut, upright, for 1 s.
    const double tilt_now = std::acos(std::clamp(truth.X_WB.linear().col(2).dot(X_WP.linear().col(2)), -1.0, 1.0));
    const bool resting = on_platform && !on_ground && controller.diagnostics().motors_cut &&
                         tilt_now < 20.0 * M_PI / 180.0;
    if (resting) {
      if (t_landed_confirm < 0) t_landed_confirm = tn;
    } else {
      t_landed_confirm = -1;
    }
    if (tilt_now > 80.0 * M_PI / 180.0 && (on_ground || on_platform)) {
      outcome = "tipped_over";
      outcome_detail = fmt::format("vehicle tipped over (tilt {:.0f} deg) at t = {:.2f} s",
                                   tilt_now * 180 / M_PI, tn);
      res.sim_s = tn;
      break;
    }
    if (touched_ground && !on_platform && truth.X_WB.translation().z() < 0.5) {
      outcome = "touched_ground";
      outcome_detail = fmt::format("the landing gear touched the ground at t = {:.2f} s", tn);
      res.sim_s = tn;
      break;
    }
    if (t_landed_confirm >= 0 && tn - t_landed_confirm >= 1.0) {
      outcome = "landed";
      outcome_detail = "resting on the platform with motors cut for 1 s";
      res.sim_s = tn;
      break;
    }

    // ---- trace ----
    if (k % trace_every == 0) {
      const NavState ns = nav.state();
      const AltitudeEstimate a = fusion.estimate();
      const auto& dg = controller.diagnostics();
      const Eigen::Vector3d rpy = rpy_of(truth.X_WB.linear()), nrpy = rpy_of(ns.q_WB.toRotationMatrix());
      const Eigen::Vector3d pw = truth.X_WB.translation(), pp = X_WP.translation();
      const Eigen::Vector3d cart_v = world.cart_qd();  // (x, y, yaw) rates
      trace.num(tn, 4).text(ctl::to_string(controller.mode()));
      for (double v : {pw.x(), pw.y(), pw.z(), rpy.x(), rpy.y(), rpy.z(), truth.v_W_mps.x(),
                       truth.v_W_mps.y(), truth.v_W_mps.z(), pp.x(), pp.y(), pp.z(),
                       rpy_of(X_WP.linear()).z(), cart_v.x(), cart_v.y(), ns.p_W_m.x(),
                       ns.p_W_m.y(), ns.p_W_m.z(), ns.v_W_mps.x(), ns.v_W_mps.y(), ns.v_W_mps.z(),
                       nrpy.x(), nrpy.y(), nrpy.z(), a.z_W_m, a.h_surface_m,
                       std::isfinite(truth.h_surface_m) ? truth.h_surface_m : -1.0,
                       dg.platform_W_m.x(), dg.platform_W_m.y(), dg.platform_W_m.z(),
                       dg.platform_v_W_mps.x(), dg.platform_v_W_mps.y(), dg.horizontal_error_m,
                       (pw - pp).head<2>().norm(), dg.setpoint.p_W_m.x(), dg.setpoint.p_W_m.y(),
                       dg.setpoint.p_W_m.z()}) {
        trace.num(v, 5);
      }
      trace.integer((last_det_t >= 0 && last_det.detected) ? 1 : 0);
      for (double w : motors.speeds_radps()) trace.num(w, 2);
      trace.end_row();
    }
    res.sim_s = tn;
    if (o.progress && k % 5000 == 0) {
      std::cerr << fmt::format("\rt = {:.1f} s  mode {}            ", tn,
                               ctl::to_string(controller.mode()))
                << std::flush;
    }
  }
  if (o.progress) std::cerr << "\n";
  res.wall_s = std::chrono::duration<double>(Clock::now() - wall0).count();
  res.frames = frames;
  if (cam_video) cam_video->close();
  if (chase_video) chase_video->close();
  trace.commit();
  if (outcome == "timeout") {
    outcome_detail = fmt::format("no landing within duration_s = {:.1f} s", s.duration_s);
  }

  // ---- summary ----
  const bool landed = outcome == "landed";
  summary["landed"] = landed;
  summary["outcome"] = outcome;
  summary["outcome_detail"] = outcome_detail;
  // Null (NaN) when there was no contact.
  auto touchdown_value = [&](const char* key) {
    return touchdown.contains(key) ? touchdown[key].get<double>() : std::nan("");
  };
  summary["touchdown_offset_m"] = touchdown_value("offset_m");
  summary["touchdown_rel_speed_mps"] = touchdown_value("rel_speed_mps");
  summary["touchdown_tilt_deg"] = touchdown_value("tilt_deg");
  summary["time_to_land_s"] = t_first_contact >= 0 ? t_first_contact : std::nan("");
  summary["touchdown"] = touchdown;
  Json transitions = Json::array();
  for (const auto& tr : controller.transitions()) {
    Json j;
    j["t_s"] = tr.t_s;
    j["from"] = ctl::to_string(tr.from);
    j["to"] = ctl::to_string(tr.to);
    j["reason"] = tr.reason;
    transitions.push_back(j);
  }
  summary["mode_transitions"] = transitions;
  summary["final_mode"] = ctl::to_string(controller.mode());
  Json vision = Json::object();
  vision["frames"] = frames;
  vision["detections"] = detections;
  vision["keyframes"] = keyframes;
  vision["keyframes_rejected"] = keyframes_rejected;
  Json reasons = Json::object();
  for (const auto& kv : not_detected_reasons) reasons[kv.first] = kv.second;
  vision["not_detected_by_reason"] = reasons;
  vision["outliers_injected"] = res.outliers_injected;
  summary["vision"] = vision;
  const RejectedSamples& rej = screen.rejected();
  summary["rejected_samples"] = {{"imu", rej.imu},
                                 {"baro", rej.baro},
                                 {"gps", rej.gps},
                                 {"ultrasonic", rej.ultrasonic},
                                 {"magnetometer", rej.magnetometer},
                                 {"vision", rej.vision},
                                 {"total", rej.total()}};
  Json alt = Json::object();
  alt["fused_z_rmse_m"] = fused_z_err.rmse_m();
  alt["fused_z_max_m"] = fused_z_err.max_abs_m;
  alt["fused_h_surface_rmse_m"] = fused_h_err.rmse_m();
  alt["fused_h_surface_max_m"] = fused_h_err.max_abs_m;
  alt["by_sensor"] = alt_metrics.json();
  summary["altitude_fusion"] = alt;
  return res;
}

}  // namespace lander::sim
