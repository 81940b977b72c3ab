// `lander bench render --json FILE [--frames N] [--blur-frames N] [--backend B] [--msaa N] [--shadows]`
// Renders N frames (default 300) of the default scene from the vehicle camera at 1280x720,
// first plain (MuJoCo render + readPixels + one flip/convert, profiled by stage), then the
// same views through a bare MuJoCo render, then with motion blur of 8 sub-renders per frame;
// the adaptive blur at hover and at speed against a 64-render reference (--blur-frames views
// per condition, default 8); the remap of a distorting lens and read noise. Writes the
// milliseconds per frame.
#include <chrono>
#include <functional>
#include <iostream>

#include <opencv2/imgproc.hpp>

#include "command.h"
#include "lander/sim/plant/plant.h"
#include "lander/sim/sensors/camera.h"
#include "lander/sim/util/output_files.h"
#include "lander/sim/render/renderer.h"
#include "lander/sim/scenario.h"
#include "lander/sim/util/stats.h"
#include "lander/sim/plant/world.h"

namespace lander::cli {
namespace {

int bench_render(const Args& args) {
  ArgParser a(args, {"json", "frames", "backend", "msaa", "scenario", "blur-frames"}, {"shadows"});
  if (!a.has("json")) throw UsageError("usage: lander bench render --json FILE [--frames N]");
  const int n = static_cast<int>(a.integer("frames", 300, 1));
  if (n < 1) throw UsageError("--frames must be >= 1");
  sim::Scenario s = sim::Scenario::load(a.value("scenario", std::string(LANDER_SCENARIOS_DIR) + "/default.yaml"));
  s.render.backend = a.value("backend", s.render.backend);
  s.render.msaa_samples = static_cast<int>(a.integer("msaa", s.render.msaa_samples, 0));
  s.render.shadows = s.render.shadows || a.flag("shadows");
  s.validate();
  sim::World world(s.world, s.camera.intrinsics);
  sim::apply_plant_truth(s, world);  // the sun casts shadows with --shadows
  sim::Renderer renderer(world.model(), s.render);
  // The pinhole view the camera's image is remapped from (larger than the image with barrel
  // distortion).
  const cv::Size rs = sim::pinhole_render_size(s.camera.intrinsics);
  const int W = rs.width, H = rs.height;
  // The vehicle descends from 10 m to 2 m above the platform while drifting and yawing, the
  // cart moves at 0.5 m/s: the platform stays in view as in an approach.
  auto place = [&](int i, double sub) {
    const double u = (i + sub) / n;
    const Eigen::Vector3d cart(0.5 * u * 10.0, 0.0, 0.0);
    world.set_cart_state(cart, Eigen::Vector3d(0.5, 0, 0));
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.linear() = Eigen::AngleAxisd(0.6 * u, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                 Eigen::AngleAxisd(0.08, Eigen::Vector3d::UnitY()).toRotationMatrix();
    X.translation() = Eigen::Vector3d(cart.x() - 1.0 + 0.8 * u, 0.3, 0.8 + 10.0 - 8.0 * u);
    world.set_vehicle_state(X, Eigen::Vector3d(0.5, 0, -0.8), Eigen::Vector3d::Zero());
    world.forward();
  };
  cv::Mat img;
  place(0, 0);
  renderer.render_camera(world.model(), world.data(), world.camera_id(), W, H, img);  // warm-up
  // Milliseconds of `render(i)` at each of the n views.
  auto time_views = [&](const std::function<void(int)>& render) {
    std::vector<double> ms;
    for (int i = 0; i < n; ++i) {
      place(i, 0);
      const auto t0 = std::chrono::steady_clock::now();
      render(i);
      ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    return ms;
  };
  auto ours = [&](int) { renderer.render_camera(world.model(), world.data(), world.camera_id(), W, H, img); };
  renderer.reset_times();
  const std::vector<double> plain = time_views(ours);
  const sim::RenderTimes prof = renderer.times();
  // What parts of the scene cost: the same views with one of MuJoCo's render flags changed.
  nlohmann::ordered_json variants = nlohmann::ordered_json::object();
  for (const auto& [name, flag] : {std::pair<const char*, int>{"no_skybox", mjRND_SKYBOX},
                                   {"no_haze", mjRND_HAZE}, {"no_cull_face", mjRND_CULL_FACE}}) {
    const mjtByte saved = renderer.scene_flag(flag);
    renderer.scene_flag(flag) = !saved;
    variants[name] = sim::summarize(time_views(ours)).median;
    renderer.scene_flag(flag) = saved;
  }
  // The same views through a bare MuJoCo render (default scene flags and options, readPixels
  // into RGB, no conversion): what the camera path costs above MuJoCo itself.
  std::vector<unsigned char> rgb;
  const std::vector<double> bare = time_views([&](int) {
    renderer.render_camera_bare(world.model(), world.data(), world.camera_id(), W, H, rgb);
  });
  std::vector<double> blur;
  sim::CameraParams cp = s.camera;
  cp.blur_samples = 8;
  cp.exposure_s = 0.02;
  sim::CameraPipeline pipeline(cp, 1);
  for (int i = 0; i < n; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    pipeline.begin(0.0);
    for (int k = 0; k < 8; ++k) {
      place(i, 0.02 * (k + 0.5) / 8);
      renderer.render_camera(world.model(), world.data(), world.camera_id(), W, H, img);
      pipeline.add(img);
    }
    pipeline.finish(i, world.X_WC());
    blur.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  // Lens distortion: the camera image is remapped from a larger pinhole render with maps
  // computed once. The remap alone, for the scenario's camera with k1 = -0.08 added when it
  // has no distortion (mismatch_camera.yaml's lens).
  sim::CameraParams dp = s.camera;
  if (!dp.intrinsics.has_distortion()) dp.intrinsics.k1 = -0.08;
  dp.blur_samples = 1;
  const auto tm0 = std::chrono::steady_clock::now();
  sim::CameraPipeline distorting(dp, 1);
  const double map_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - tm0).count();
  const cv::Size drs = distorting.render_size();
  cv::Mat big;
  cv::resize(img, big, drs);  // stands in for the larger render: the remap's cost does not
                              // depend on the content
  std::vector<double> remap;
  for (int i = 0; i < n; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    distorting.begin(0.0);
    distorting.add(big);
    distorting.finish(i, world.X_WC());
    remap.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  // Read noise (camera.read_noise_dn, 2 DN as in motion_blur.yaml) on one render.
  sim::CameraParams np = s.camera;
  np.blur_samples = 1;
  np.read_noise_dn = 2.0;
  sim::CameraPipeline noisy(np, 1);
  std::vector<double> noise_ms;
  for (int i = 0; i < n; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    noisy.begin(0.0);
    noisy.add(img);
    noisy.finish(i, world.X_WC());
    noise_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  // Adaptive motion blur (camera.blur_px_per_render) against a 64-render reference, at hover
  // and at speed, with motion_blur.yaml's 20 ms exposure: renders per frame, cost, and how far
  // the frame is from the reference (grey levels).
  nlohmann::ordered_json adaptive = nlohmann::ordered_json::array();
  {
    struct Condition {
      const char* name;
      double height_m;
      Eigen::Vector3d v_W, omega_B;
      double cart_mps;
    };
    const std::vector<Condition> conds = {
        {"hover_5m", 5.0, {0.05, 0.0, 0.0}, {0.0, 0.0, 0.02}, 0.0},
        {"follow_5m", 5.0, {0.5, 0.0, -0.3}, {0.05, 0.05, 0.1}, 0.5},
        {"full_speed_5m", 5.0, {3.0, 0.5, -0.5}, {0.3, 0.3, 0.5}, 1.5},
        {"full_speed_2m", 2.0, {1.5, 0.0, -0.5}, {0.3, 0.3, 0.5}, 1.5}};
    sim::CameraParams ap = s.camera;
    ap.exposure_s = 0.02;
    ap.blur_samples = 64;
    ap.blur_px_per_render = 1.0;
    const int nf = static_cast<int>(a.integer("blur-frames", 8, 1));
    sim::CameraPipeline pipe(ap, 1);  // averages whatever renders a frame adds
    for (const Condition& c : conds) {
      // The state at time tau into the exposure: constant velocities from the start pose.
      auto at = [&](int i, double tau) {
        const double yaw0 = 0.7 * i;
        Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
        const Eigen::Matrix3d R0 = Eigen::AngleAxisd(yaw0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
        const Eigen::Vector3d w_W = R0 * c.omega_B;
        const double ang = w_W.norm() * tau;
        X.linear() = (ang > 0 ? Eigen::AngleAxisd(ang, w_W.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity()) * R0;
        const Eigen::Vector3d cart(2.0 * i + c.cart_mps * tau, 0.0, 0.0);
        world.set_cart_state(cart, Eigen::Vector3d(c.cart_mps, 0, 0));
        X.translation() = Eigen::Vector3d(2.0 * i + 0.2, 0.1, 0.8 + c.height_m) + c.v_W * tau;
        world.set_vehicle_state(X, c.v_W, c.omega_B);
        world.forward();
      };
      std::vector<double> n_used, ms, mean_diff, p999_diff, max_diff, ms_fixed8, mean_diff8, p999_diff8;
      // Mean, 99.9th percentile and max of |a - ref| over pixels and channels (grey levels).
      auto compare = [](const cv::Mat& x, const cv::Mat& ref, double* mean, double* p999, double* mx) {
        cv::Mat diff;
        cv::absdiff(x, ref, diff);
        const cv::Mat flat = diff.reshape(1, 1);
        *mean = cv::mean(flat)[0];
        cv::minMaxLoc(flat, nullptr, mx);
        int hist[256] = {0};
        for (int q = 0; q < flat.cols; ++q) ++hist[flat.at<unsigned char>(0, q)];
        const double need = 0.999 * flat.cols;
        double acc = 0;
        int level = 0;
        while (level < 255 && (acc += hist[level]) < need) ++level;
        *p999 = level;
      };
      for (int i = 0; i < nf; ++i) {
        at(i, 0.0);
        const double motion = sim::image_motion_px(s.camera.intrinsics, sim::exposure_motion(world, s.camera.intrinsics), ap.exposure_s);
        auto blurred = [&](int n, double* cost_ms) {
          const auto t0 = std::chrono::steady_clock::now();
          pipe.begin(0.0);
          for (int k = 0; k < n; ++k) {
            at(i, (k + 0.5) * ap.exposure_s / n);
            renderer.render_camera(world.model(), world.data(), world.camera_id(), W, H, img);
            pipe.add(img);
          }
          cv::Mat out = pipe.finish(i, world.X_WC()).bgr;
          if (cost_ms) *cost_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
          return out;
        };
        const int n = sim::blur_renders(ap, motion);
        double cost = 0, cost8 = 0;
        const cv::Mat adapt = blurred(n, &cost);
        const cv::Mat fixed8 = blurred(8, &cost8);
        const cv::Mat ref = blurred(64, nullptr);
        double m1, p1, x1, m8, p8, x8;
        compare(adapt, ref, &m1, &p1, &x1);
        compare(fixed8, ref, &m8, &p8, &x8);
        n_used.push_back(n);
        ms.push_back(cost);
        ms_fixed8.push_back(cost8);
        mean_diff.push_back(m1);
        p999_diff.push_back(p1);
        max_diff.push_back(x1);
        mean_diff8.push_back(m8);
        p999_diff8.push_back(p8);
      }
      adaptive.push_back({{"condition", c.name},
                          {"renders_mean", sim::summarize(n_used).mean},
                          {"renders_max", sim::summarize(n_used).max},
                          {"ms_per_frame_mean", sim::summarize(ms).mean},
                          {"ms_per_frame_fixed8_mean", sim::summarize(ms_fixed8).mean},
                          {"diff_to_64_mean_dn", sim::summarize(mean_diff).mean},
                          {"diff_to_64_p999_dn_max", sim::summarize(p999_diff).max},
                          {"diff_to_64_max_dn", sim::summarize(max_diff).max},
                          {"fixed8_diff_to_64_mean_dn", sim::summarize(mean_diff8).mean},
                          {"fixed8_diff_to_64_p999_dn_max", sim::summarize(p999_diff8).max}});
    }
  }
  nlohmann::ordered_json j;
  j["adaptive_blur_20ms"] = adaptive;
  j["read_noise_ms_per_frame_median"] = sim::summarize(noise_ms).median;
  j["read_noise_ms_per_frame_max"] = sim::summarize(noise_ms).max;
  j["ms_per_frame_median"] = sim::summarize(plain).median;
  j["ms_per_frame_mean"] = sim::summarize(plain).mean;
  j["ms_per_frame_max"] = sim::summarize(plain).max;
  const double nr = std::max(1, prof.renders);
  j["profile_ms_per_frame_mean"] = {{"scene_update", prof.scene_ms / nr},
                                    {"draw", prof.draw_ms / nr},
                                    {"read_pixels", prof.read_ms / nr},
                                    {"flip_convert", prof.convert_ms / nr}};
  j["variants_ms_per_frame_median"] = variants;
  j["bare_mujoco_ms_per_frame_median"] = sim::summarize(bare).median;
  j["bare_mujoco_ms_per_frame_mean"] = sim::summarize(bare).mean;
  j["ours_over_bare_median"] = sim::summarize(plain).median / sim::summarize(bare).median;
  j["distortion"] = {{"k1", dp.intrinsics.k1},
                     {"render_width_px", drs.width},
                     {"render_height_px", drs.height},
                     {"maps_ms", map_ms},
                     {"remap_ms_per_frame_median", sim::summarize(remap).median},
                     {"remap_ms_per_frame_max", sim::summarize(remap).max}};
  j["ms_per_frame_blur8_median"] = sim::summarize(blur).median;
  j["backend"] = renderer.backend_description();
  j["frames"] = n;
  j["width_px"] = W;
  j["height_px"] = H;
  j["msaa_samples"] = s.render.msaa_samples;
  j["shadows"] = s.render.shadows;
  sim::write_json_file(a.value("json"), j);
  std::cout << sim::json_text(j);
  return kExitOk;
}

const LanderCommand reg("render", "render --json FILE [--frames N] [--blur-frames N] [--backend auto|egl|osmesa] [--msaa N] [--shadows]",
                        Kind::Bench, bench_render);

}  // namespace
}  // namespace lander::cli
