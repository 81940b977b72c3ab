#include "lander/sim/run.h"

#include <sys/resource.h>
#include <sys/stat.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>

#include <opencv2/imgproc.hpp>

#include "lander/sim/loop.h"
#include "lander/sim/loop/flight_factory.h"
#include "lander/sim/loop/vision_log.h"
#include "lander/sim/util/output_files.h"
#include "lander/sim/plant/plant.h"
#include "lander/sim/render/renderer.h"
#include "lander/sim/render/video.h"
#include "lander/sim/plant/world.h"
#include "loop/fault_hooks.h"
#include "loop/overlay.h"

namespace lander::sim {

using Json = nlohmann::ordered_json;

namespace {

// The process's peak resident memory so far (MB of 2^20 bytes; Linux reports KiB): in a
// campaign every run is its own process, so this is the run's (issue 53).
double peak_rss_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;
}

bool is_dir(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

void make_dirs(const std::string& path) {
  std::string cur;
  for (std::size_t i = 0; i <= path.size(); ++i) {
    if (i == path.size() || path[i] == '/') {
      if (!cur.empty() && !is_dir(cur) && mkdir(cur.c_str(), 0755) != 0 && !is_dir(cur)) {
        throw ConfigError("cannot create output directory " + cur);
      }
    }
    if (i < path.size()) cur += path[i];
  }
}

std::string parent_dir(const std::string& p) {
  const auto pos = p.find_last_of('/');
  if (pos == std::string::npos) return ".";
  return pos == 0 ? "/" : p.substr(0, pos);
}

// Scripted flight: the vehicle follows the waypoints, the cart its path; every camera frame
// is rendered (with blur from the scripted motion when blur_samples > 1).
void run_kinematic(const Scenario& s, const RunOptions& o, World& world, Renderer& renderer,
                   Json& summary) {
  CameraPipeline camera(s.camera, derive_seed(s.seed, "camera"));
  const double dt = s.world.physics_dt_s;
  std::unique_ptr<VideoWriter> cam_video, chase_video;
  const int cw = s.camera.intrinsics.width_px / s.video.camera_scale_div / 2 * 2;
  const int ch = s.camera.intrinsics.height_px / s.video.camera_scale_div / 2 * 2;
  if (o.video) {
    cam_video = std::make_unique<VideoWriter>(o.out_dir + "/camera.mp4", cw, ch, s.camera.rate_hz);
    chase_video = std::make_unique<VideoWriter>(o.out_dir + "/chase.mp4", s.video.chase_width_px,
                                                s.video.chase_height_px, s.camera.rate_hz);
  }
  CsvWriter trace(o.out_dir + "/trace.csv",
                    {"t_s", "frame", "x_WB_m", "y_WB_m", "z_WB_m", "roll_rad", "pitch_rad",
                     "yaw_rad", "x_WP_m", "y_WP_m", "z_WP_m", "yaw_WP_rad", "h_above_P_m",
                     "platform_in_view"});
  auto set_state = [&](double t) {
    const CartReference c = cart_reference(s.cart, t, &world.route());
    world.set_cart_state(c.q, c.qd);
    Eigen::Isometry3d X_WB;
    Eigen::Vector3d v_W, w_B;
    scripted_vehicle_state(s.vehicle, t, X_WB, v_W, w_B);
    world.set_vehicle_state(X_WB, v_W, w_B);
    world.forward();
  };
  const double period = 1.0 / s.camera.rate_hz;
  const int n_frames = static_cast<int>(std::floor((s.duration_s - s.camera.exposure_s) / period)) + 1;
  cv::Mat render, chase, small;
  int in_view = 0;
  double render_ms = 0;
  std::string outcome = "scripted_flight_complete";
  std::string outcome_detail = "kinematic vehicle: no controller, no landing attempted";
  for (int i = 0; i < n_frames; ++i) {
    const double t0 = std::round(i * period / dt) * dt;
    run_process_fault_hooks(s.faults, t0);  // abort / hang test hooks
    camera.begin(t0);
    const auto clock0 = std::chrono::steady_clock::now();
    for (double ts : exposure_sample_times(s.camera, t0, dt)) {
      set_state(ts);
      renderer.render_camera(world.model(), world.data(), world.camera_id(),
                             camera.render_size().width, camera.render_size().height, render);
      camera.add(render);
    }
    render_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - clock0).count();
    const double t_mid = t0 + 0.5 * s.camera.exposure_s;
    set_state(t_mid);
    if (s.faults.diverge_t_s >= 0 && t_mid >= s.faults.diverge_t_s) {  // test hook
      world.data()->qpos[world.vehicle_qpos_adr()] = std::numeric_limits<double>::quiet_NaN();
    }
    if (!world.state_finite()) {
      outcome = "diverged";
      outcome_detail = fmt::format("the scripted vehicle state is not finite at t = {:.3f} s", t_mid);
      break;
    }
    CameraFrame frame = camera.finish(i, world.X_WC());
    if (!o.save_frames_dir.empty()) save_frame_png(o.save_frames_dir, frame);
    // Truth for the trace: is the platform centre in the image?
    const Eigen::Vector3d p_C = world.X_WC().inverse() * world.X_WP().translation();
    const Eigen::Vector3d uv = s.camera.intrinsics.K() * p_C;
    const bool visible = p_C.z() > 0 && uv.x() / uv.z() >= 0 &&
                         uv.x() / uv.z() <= s.camera.intrinsics.width_px - 1 &&
                         uv.y() / uv.z() >= 0 && uv.y() / uv.z() <= s.camera.intrinsics.height_px - 1;
    in_view += visible;
    const Eigen::Isometry3d X_WB = world.X_WB(), X_WP = world.X_WP();
    const Eigen::Vector3d rpy = rpy_of(X_WB.linear());
    for (double v : {t_mid, static_cast<double>(i), X_WB.translation().x(), X_WB.translation().y(),
                     X_WB.translation().z(), rpy.x(), rpy.y(), rpy.z(), X_WP.translation().x(),
                     X_WP.translation().y(), X_WP.translation().z(), rpy_of(X_WP.linear()).z(),
                     X_WB.translation().z() - X_WP.translation().z(), visible ? 1.0 : 0.0}) {
      trace.num(v, 6);
    }
    trace.end_row();
    if (o.video) {
      cv::resize(frame.bgr, small, cv::Size(cw, ch), 0, 0, cv::INTER_AREA);
      if (s.video.overlays) {
        put_text(small, fmt::format("t {:.2f} s  frame {}  (scripted, no estimator)", t_mid, i), 0);
        put_text(small, fmt::format("true height above platform {:.2f} m",
                                    X_WB.translation().z() - X_WP.translation().z()),
                 1);
      }
      cam_video->write(small);
      renderer.render_free(world.model(), world.data(), chase_camera(world, s.video),
                           s.video.chase_width_px, s.video.chase_height_px, chase);
      if (s.video.overlays) put_text(chase, fmt::format("t {:.2f} s  chase view", t_mid), 0);
      chase_video->write(chase);
    }
    if (o.progress && i % 30 == 0) {
      std::cerr << "\rframe " << i + 1 << "/" << n_frames << std::flush;
    }
  }
  if (o.progress) std::cerr << "\n";
  if (cam_video) cam_video->close();
  if (chase_video) chase_video->close();
  trace.commit();
  summary["landed"] = false;
  summary["outcome"] = outcome;
  summary["outcome_detail"] = outcome_detail;
  summary["vision"] = {{"frames", n_frames}, {"frames_platform_in_view", in_view}};
  Json perf;
  perf["render_ms_per_frame_mean"] = render_ms / std::max(1, n_frames);
  write_json_file(o.out_dir + "/performance.json", perf);
}

// flight_software.json: who flies (the seam's info) and from where (builtin, or a plugin's
// file with its sha256).
Json flight_software_json(const flight::FlightSoftware& fs, const Scenario& s) {
  const flight::FlightSoftwareInfo who = fs.info();
  const flight::FlightSoftwareSource src = flight_software_source(s);
  Json j;
  j["name"] = who.name;
  j["version"] = who.version;
  j["source"] = src.kind;
  j["plugin"] = src.plugin_path.empty() ? Json(nullptr) : Json(src.plugin_path);
  j["plugin_sha256"] = src.plugin_sha256.empty() ? Json(nullptr) : Json(src.plugin_sha256);
  j["api_version"] = flight::kFlightSoftwareApiVersion;
  return j;
}

}  // namespace

void preflight(const Scenario& s, const RunOptions& o) {
  s.validate();
  if (!o.replay_vision.empty() || !o.record_vision.empty()) {
    if (s.vehicle.control != "closed_loop") {
      throw ConfigError("--record-vision and --replay-vision need a closed-loop scenario");
    }
  }
  if (!o.replay_vision.empty()) read_vision_log(o.replay_vision);  // throws naming file:line
  if (!std::ifstream(s.world.model_path)) {
    throw ConfigError(s.world.model_path + ": cannot open model file (world.model)");
  }
  TargetGeometry::load(s.world.target_path);  // throws naming the file and key
  TargetGeometry::load(s.flight.target_path);  // the flight software's copy
  if (o.out_dir.empty()) throw ConfigError("no output directory given (--out DIR)");
  const std::string parent = parent_dir(o.out_dir);
  if (!is_dir(parent) && parent != ".") {
    // Nested new directories are fine; only refuse paths under a regular file.
    struct stat st;
    if (stat(parent.c_str(), &st) == 0 && !S_ISDIR(st.st_mode)) {
      throw ConfigError("output path " + o.out_dir + " is inside a file");
    }
  }
  if (o.video && !on_path("ffmpeg")) {
    throw ConfigError("--video needs ffmpeg on PATH (apt-get install ffmpeg)");
  }
}

Json run_scenario(const Scenario& s, const RunOptions& o) {
  preflight(s, o);
  // Load the world (may throw ConfigError for an unreadable model) before writing anything.
  World world(s.world, s.camera.intrinsics, s.cart.deck_motion.present());
  apply_plant_truth(s, world);
  if (o.video) world.reserve_offscreen(s.video.chase_width_px, s.video.chase_height_px);
  // No GL at all for a closed loop driven by recorded vision (change indication).
  const bool needs_renderer = s.vehicle.control == "kinematic" || o.replay_vision.empty() || o.video;
  std::unique_ptr<Renderer> renderer;
  if (needs_renderer) {
    renderer = std::make_unique<Renderer>(world.model(), s.render);
    // The GL context holds the textures now (with mipmaps); the model's copy goes back.
    world.release_texture_pixels();
  }
  // The flight software before any output: a plugin that cannot be loaded or created is a bad
  // input (PluginError, a ConfigError), with nothing written.
  std::unique_ptr<flight::FlightSoftware> flight;
  if (s.vehicle.control == "closed_loop") flight = o.flight_factory ? o.flight_factory(s) : make_flight_software(s);
  make_dirs(o.out_dir);
  if (!o.save_frames_dir.empty()) make_dirs(o.save_frames_dir);
  write_file_atomic(o.out_dir + "/scenario.resolved.yaml", yaml_to_string(params_to_yaml(s)));
  if (flight) {
    // What the flight software was built from, beside the resolved scenario (the plant's
    // truth), and where it came from.
    write_file_atomic(o.out_dir + "/flight.resolved.yaml", yaml_to_string(params_to_yaml(s.flight)));
    write_json_file(o.out_dir + "/flight_software.json", flight_software_json(*flight, s));
  }
  Json summary = Json::object();
  summary["schema_version"] = kSummarySchemaVersion;
  summary["scenario"] = s.name;
  summary["seed"] = s.seed;
  summary["vehicle_control"] = s.vehicle.control;
  summary["render_backend"] = renderer ? renderer->backend_description() : "none (recorded vision)";
  try {
    if (s.vehicle.control == "kinematic") {
      run_kinematic(s, o, world, *renderer, summary);
    } else {
      const LoopResult r = ClosedLoop(s, o, world, renderer.get(), std::move(flight)).run(summary);
      Json perf;
      perf["sim_seconds"] = r.sim_s;
      perf["wall_seconds"] = r.wall_s;
      perf["realtime_factor"] = r.wall_s > 0 ? r.sim_s / r.wall_s : 0.0;
      const double n = std::max(1, r.frames);
      perf["vision_schedule"] = r.overlapped ? "overlapped" : "serial";
      perf["camera_frames"] = r.frames;
      perf["renders_per_frame"] = static_cast<double>(r.renders) / std::max(1, r.frames);
      perf["ms_per_camera_frame"] = {{"render", r.render_ms / n},
                                     {"estimator", r.estimator_ms / n},
                                     {"estimator_ring_detector", r.detector_ms / n},
                                     {"estimator_ring_detector_thread_cpu", r.detector_cpu_ms / n},
                                     {"estimator_path_stage", r.path_stage_ms / n},
                                     {"control", r.control_ms / n},
                                     {"physics", r.physics_ms / n},
                                     {"vision_wait", r.vision_wait_ms / n}};
      perf["peak_rss_mb"] = peak_rss_mb();
      // Timings differ run to run: they go beside summary.json, which stays deterministic.
      write_json_file(o.out_dir + "/performance.json", perf);
    }
  } catch (const std::exception& e) {
    summary["landed"] = false;
    summary["outcome"] = "error";
    summary["outcome_detail"] = e.what();
    write_json_file(o.out_dir + "/summary.json", summary);
    throw;
  }
  write_json_file(o.out_dir + "/summary.json", summary);
  return summary;
}

}  // namespace lander::sim
