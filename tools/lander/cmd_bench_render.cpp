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

using json = nlohmann::ordered_json;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// The scene every step renders: the world, its renderer, the pinhole render size and the
// number of views.
struct Bench {
  const sim::Scenario& s;
  sim::World& world;
  sim::Renderer& renderer;
  int W, H;  ///< the pinhole view the camera's image is remapped from (px)
  int n;     ///< views

  void render(cv::Mat& img) {
    renderer.render_camera(world.model(), world.data(), world.camera_id(), W, H, img);
  }
  // View i (+ sub of a view into the next): the vehicle descends from 10 m to 2 m above the
  // platform while drifting and yawing, the cart moves at 0.5 m/s: the platform stays in view
  // as in an approach.
  void place(int i, double sub) {
    const double u = (i + sub) / n;
    const Eigen::Vector3d cart(0.5 * u * 10.0, 0.0, 0.0);
    world.set_cart_state(cart, Eigen::Vector3d(0.5, 0, 0));
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.linear() = Eigen::AngleAxisd(0.6 * u, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                 Eigen::AngleAxisd(0.08, Eigen::Vector3d::UnitY()).toRotationMatrix();
    X.translation() = Eigen::Vector3d(cart.x() - 1.0 + 0.8 * u, 0.3, 0.8 + 10.0 - 8.0 * u);
    world.set_vehicle_state(X, Eigen::Vector3d(0.5, 0, -0.8), Eigen::Vector3d::Zero());
    world.forward();
  }
  // Milliseconds of `render(i)` at each of the n views.
  std::vector<double> time_views(const std::function<void(int)>& render_view) {
    std::vector<double> ms;
    for (int i = 0; i < n; ++i) {
      place(i, 0);
      const auto t0 = Clock::now();
      render_view(i);
      ms.push_back(ms_since(t0));
    }
    return ms;
  }
};

// The scenario of the bench: --scenario (default.yaml) with --backend, --msaa, --shadows.
sim::Scenario bench_scenario(const ArgParser& a) {
  sim::Scenario s = sim::Scenario::load(a.value("scenario", std::string(LANDER_SCENARIOS_DIR) + "/default.yaml"));
  s.render.backend = a.value("backend", s.render.backend);
  s.render.msaa_samples = static_cast<int>(a.integer("msaa", s.render.msaa_samples, 0));
  s.render.shadows = s.render.shadows || a.flag("shadows");
  s.validate();
  return s;
}

// What parts of the scene cost: the same views with one of MuJoCo's render flags changed.
json flag_variants(Bench& b, cv::Mat& img) {
  json variants = json::object();
  for (const auto& [name, flag] : {std::pair<const char*, int>{"no_skybox", mjRND_SKYBOX},
                                   {"no_haze", mjRND_HAZE}, {"no_cull_face", mjRND_CULL_FACE}}) {
    const mjtByte saved = b.renderer.scene_flag(flag);
    b.renderer.scene_flag(flag) = !saved;
    variants[name] = sim::summarize(b.time_views([&](int) { b.render(img); })).median;
    b.renderer.scene_flag(flag) = saved;
  }
  return variants;
}

// Motion blur of 8 sub-renders per frame over a 20 ms exposure (ms per frame).
std::vector<double> time_blur8(Bench& b, cv::Mat& img) {
  std::vector<double> blur;
  sim::CameraParams cp = b.s.camera;
  cp.blur_samples = 8;
  cp.exposure_s = 0.02;
  sim::CameraPipeline pipeline(cp, 1);
  for (int i = 0; i < b.n; ++i) {
    const auto t0 = Clock::now();
    pipeline.begin(0.0);
    for (int k = 0; k < 8; ++k) {
      b.place(i, 0.02 * (k + 0.5) / 8);
      b.render(img);
      pipeline.add(img);
    }
    pipeline.finish(i, b.world.X_WC());
    blur.push_back(ms_since(t0));
  }
  return blur;
}

// Lens distortion: the camera image is remapped from a larger pinhole render with maps
// computed once. The remap alone, for the scenario's camera with k1 = -0.08 added when it
// has no distortion (mismatch_camera.yaml's lens).
json time_distortion(Bench& b, const cv::Mat& img) {
  sim::CameraParams dp = b.s.camera;
  if (!dp.intrinsics.has_distortion()) dp.intrinsics.k1 = -0.08;
  dp.blur_samples = 1;
  const auto tm0 = Clock::now();
  sim::CameraPipeline distorting(dp, 1);
  const double map_ms = ms_since(tm0);
  const cv::Size drs = distorting.render_size();
  cv::Mat big;
  cv::resize(img, big, drs);  // stands in for the larger render: the remap's cost does not
                              // depend on the content
  std::vector<double> remap;
  for (int i = 0; i < b.n; ++i) {
    const auto t0 = Clock::now();
    distorting.begin(0.0);
    distorting.add(big);
    distorting.finish(i, b.world.X_WC());
    remap.push_back(ms_since(t0));
  }
  return {{"k1", dp.intrinsics.k1},
          {"render_width_px", drs.width},
          {"render_height_px", drs.height},
          {"maps_ms", map_ms},
          {"remap_ms_per_frame_median", sim::summarize(remap).median},
          {"remap_ms_per_frame_max", sim::summarize(remap).max}};
}

// One stage of the camera pipeline on one render (ms per frame): `pipe` the camera with it on.
std::vector<double> time_pipeline(Bench& b, const cv::Mat& img, sim::CameraPipeline& pipe) {
  std::vector<double> ms;
  for (int i = 0; i < b.n; ++i) {
    const auto t0 = Clock::now();
    pipe.begin(0.0);
    pipe.add(img);
    pipe.finish(i, b.world.X_WC());
    ms.push_back(ms_since(t0));
  }
  return ms;
}

// Read noise (camera.read_noise_dn, 2 DN as in motion_blur.yaml) on one render (ms per frame).
std::vector<double> time_read_noise(Bench& b, const cv::Mat& img) {
  sim::CameraParams np = b.s.camera;
  np.read_noise_dn = 2.0;
  sim::CameraPipeline noisy(np, 1);
  return time_pipeline(b, img, noisy);
}

// JPEG delivery (camera.jpeg_quality 80, the seed's camera as issue 54 gives it): encode and
// decode per frame (ms), and the last frame's size.
json time_jpeg(Bench& b, const cv::Mat& img) {
  sim::CameraParams jp = b.s.camera;
  jp.jpeg_quality = 80;
  sim::CameraPipeline jpeg(jp, 1);
  const std::vector<double> ms = time_pipeline(b, img, jpeg);
  return {{"quality", jp.jpeg_quality},
          {"ms_per_frame_median", sim::summarize(ms).median},
          {"ms_per_frame_max", sim::summarize(ms).max},
          {"bytes_per_frame", jpeg.last_jpeg_bytes()}};
}

// A flight condition of the adaptive-blur comparison: height, constant velocities, cart speed.
struct BlurCondition {
  const char* name;
  double height_m;
  Eigen::Vector3d v_W, omega_B;
  double cart_mps;
};

// The flight conditions of the adaptive blur's and the rolling shutter's figures: hover, an
// observe's follow, full speed at 5 m and at 2 m.
std::vector<BlurCondition> motion_conditions() {
  return {{"hover_5m", 5.0, {0.05, 0.0, 0.0}, {0.0, 0.0, 0.02}, 0.0},
          {"follow_5m", 5.0, {0.5, 0.0, -0.3}, {0.05, 0.05, 0.1}, 0.5},
          {"full_speed_5m", 5.0, {3.0, 0.5, -0.5}, {0.3, 0.3, 0.5}, 1.5},
          {"full_speed_2m", 2.0, {1.5, 0.0, -0.5}, {0.3, 0.3, 0.5}, 1.5}};
}

// The state of view i at time tau into the exposure: constant velocities from the start pose.
void place_in_condition(Bench& b, const BlurCondition& c, int i, double tau) {
  const double yaw0 = 0.7 * i;
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  const Eigen::Matrix3d R0 = Eigen::AngleAxisd(yaw0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d w_W = R0 * c.omega_B;
  const double ang = w_W.norm() * tau;
  X.linear() = (ang > 0 ? Eigen::AngleAxisd(ang, w_W.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity()) * R0;
  const Eigen::Vector3d cart(2.0 * i + c.cart_mps * tau, 0.0, 0.0);
  b.world.set_cart_state(cart, Eigen::Vector3d(c.cart_mps, 0, 0));
  X.translation() = Eigen::Vector3d(2.0 * i + 0.2, 0.1, 0.8 + c.height_m) + c.v_W * tau;
  b.world.set_vehicle_state(X, c.v_W, c.omega_B);
  b.world.forward();
}

// Mean, 99.9th percentile and max of |x - ref| over pixels and channels (grey levels).
struct FrameDiff {
  double mean{0}, p999{0}, max{0};
};
FrameDiff compare(const cv::Mat& x, const cv::Mat& ref) {
  FrameDiff d;
  cv::Mat diff;
  cv::absdiff(x, ref, diff);
  const cv::Mat flat = diff.reshape(1, 1);
  d.mean = cv::mean(flat)[0];
  cv::minMaxLoc(flat, nullptr, &d.max);
  int hist[256] = {0};
  for (int q = 0; q < flat.cols; ++q) ++hist[flat.at<unsigned char>(0, q)];
  const double need = 0.999 * flat.cols;
  double acc = 0;
  int level = 0;
  while (level < 255 && (acc += hist[level]) < need) ++level;
  d.p999 = level;
  return d;
}

// View i of condition c blurred from `renders` renders over the exposure; its cost in ms.
cv::Mat blurred(Bench& b, sim::CameraPipeline& pipe, const sim::CameraParams& ap,
                const BlurCondition& c, int i, int renders, double* cost_ms) {
  cv::Mat img;
  const auto t0 = Clock::now();
  pipe.begin(0.0);
  for (int k = 0; k < renders; ++k) {
    place_in_condition(b, c, i, (k + 0.5) * ap.exposure_s / renders);
    b.render(img);
    pipe.add(img);
  }
  cv::Mat out = pipe.finish(i, b.world.X_WC()).bgr;
  if (cost_ms) *cost_ms = ms_since(t0);
  return out;
}

// One condition over `frames` views: the adaptive renders per frame, their cost, and how far
// the adaptive and a fixed 8-render frame are from the 64-render reference.
json adaptive_condition(Bench& b, sim::CameraPipeline& pipe, const sim::CameraParams& ap,
                        const BlurCondition& c, int frames) {
  std::vector<double> n_used, ms, mean_diff, p999_diff, max_diff, ms_fixed8, mean_diff8, p999_diff8;
  for (int i = 0; i < frames; ++i) {
    place_in_condition(b, c, i, 0.0);
    const double motion = sim::image_motion_px(b.s.camera.intrinsics, sim::exposure_motion(b.world, b.s.camera.intrinsics), ap.exposure_s);
    const int renders = sim::blur_renders(ap, motion);
    double cost = 0, cost8 = 0;
    const cv::Mat adapt = blurred(b, pipe, ap, c, i, renders, &cost);
    const cv::Mat fixed8 = blurred(b, pipe, ap, c, i, 8, &cost8);
    const cv::Mat ref = blurred(b, pipe, ap, c, i, 64, nullptr);
    const FrameDiff d1 = compare(adapt, ref), d8 = compare(fixed8, ref);
    n_used.push_back(renders);
    ms.push_back(cost);
    ms_fixed8.push_back(cost8);
    mean_diff.push_back(d1.mean);
    p999_diff.push_back(d1.p999);
    max_diff.push_back(d1.max);
    mean_diff8.push_back(d8.mean);
    p999_diff8.push_back(d8.p999);
  }
  return {{"condition", c.name},
          {"renders_mean", sim::summarize(n_used).mean},
          {"renders_max", sim::summarize(n_used).max},
          {"ms_per_frame_mean", sim::summarize(ms).mean},
          {"ms_per_frame_fixed8_mean", sim::summarize(ms_fixed8).mean},
          {"diff_to_64_mean_dn", sim::summarize(mean_diff).mean},
          {"diff_to_64_p999_dn_max", sim::summarize(p999_diff).max},
          {"diff_to_64_max_dn", sim::summarize(max_diff).max},
          {"fixed8_diff_to_64_mean_dn", sim::summarize(mean_diff8).mean},
          {"fixed8_diff_to_64_p999_dn_max", sim::summarize(p999_diff8).max}};
}

// Adaptive motion blur (camera.blur_px_per_render) against a 64-render reference, at hover
// and at speed, with motion_blur.yaml's 20 ms exposure: renders per frame, cost, and how far
// the frame is from the reference (grey levels).
json adaptive_blur(Bench& b, int frames) {
  const std::vector<BlurCondition> conds = motion_conditions();
  sim::CameraParams ap = b.s.camera;
  ap.exposure_s = 0.02;
  ap.blur_samples = 64;
  ap.blur_px_per_render = 1.0;
  sim::CameraPipeline pipe(ap, 1);  // averages whatever renders a frame adds
  json adaptive = json::array();
  for (const BlurCondition& c : conds) adaptive.push_back(adaptive_condition(b, pipe, ap, c, frames));
  return adaptive;
}

// View i of condition c with a rolling shutter (rp), assembled from `bands` bands as the
// camera rig does (sim::add_exposure_render); its cost in ms.
cv::Mat rolling(Bench& b, sim::CameraPipeline& pipe, const sim::CameraParams& rp, const BlurCondition& c, int i,
                int bands, double* cost_ms) {
  cv::Mat img;
  const auto t0 = Clock::now();
  const std::vector<sim::ExposureRender> renders =
      sim::exposure_renders(rp, 0.0, 1e-4, pipe.render_size().height, rp.intrinsics.height_px, bands, 1);
  pipe.begin(0.0, bands > 1 ? 1 : 0);
  for (const sim::ExposureRender& r : renders) {
    place_in_condition(b, c, i, r.t_s);
    sim::add_exposure_render(b.renderer, b.world, pipe, r, img);
  }
  cv::Mat out = pipe.finish(i, b.world.X_WC()).bgr;
  if (cost_ms) *cost_ms = ms_since(t0);
  return out;
}

// Rolling shutter (camera.rolling_shutter_readout_ms 30, the seed's CMOS camera as issue 54
// gives it) in the adaptive blur's conditions: bands per frame from the image motion over the
// readout, the cost per frame, and how far the frame is from one assembled from 180 bands
// (4 rows each: the reference) and from the global-shutter frame (what the shutter changes).
json rolling_shutter(Bench& b, int frames) {
  const std::vector<BlurCondition> conds = motion_conditions();
  sim::CameraParams rp = b.s.camera;
  rp.rolling_shutter_readout_s = 0.030;
  rp.exposure_s = 0.002;  // the scenario's may be a blurred one; readout + exposure < period
  rp.blur_samples = 1;
  constexpr int kReferenceBands = 180;
  sim::CameraPipeline pipe(rp, 1);
  json out = json::array();
  for (const BlurCondition& c : conds) {
    std::vector<double> bands_used, ms, diff_ref_p999, diff_ref_max, diff_global_p999;
    for (int i = 0; i < frames; ++i) {
      place_in_condition(b, c, i, 0.0);
      const double motion = sim::image_motion_px(rp.intrinsics, sim::exposure_motion(b.world, rp.intrinsics),
                                                 rp.rolling_shutter_readout_s);
      const int bands = sim::rolling_shutter_bands(rp, motion);
      double cost = 0;
      const cv::Mat frame = rolling(b, pipe, rp, c, i, bands, &cost);
      const cv::Mat ref = rolling(b, pipe, rp, c, i, kReferenceBands, nullptr);
      const cv::Mat global = rolling(b, pipe, rp, c, i, 1, nullptr);
      bands_used.push_back(bands);
      ms.push_back(cost);
      const FrameDiff dr = compare(frame, ref), dg = compare(global, ref);
      diff_ref_p999.push_back(dr.p999);
      diff_ref_max.push_back(dr.max);
      diff_global_p999.push_back(dg.p999);
    }
    out.push_back({{"condition", c.name},
                   {"bands_mean", sim::summarize(bands_used).mean},
                   {"bands_max", sim::summarize(bands_used).max},
                   {"ms_per_frame_mean", sim::summarize(ms).mean},
                   {"ms_per_frame_max", sim::summarize(ms).max},
                   {"diff_to_180_bands_p999_dn_max", sim::summarize(diff_ref_p999).max},
                   {"diff_to_180_bands_max_dn", sim::summarize(diff_ref_max).max},
                   {"global_shutter_diff_to_180_bands_p999_dn_max", sim::summarize(diff_global_p999).max}});
  }
  return {{"readout_ms", 1e3 * rp.rolling_shutter_readout_s},
          {"px_per_band", rp.rolling_shutter_px_per_band},
          {"max_bands", rp.rolling_shutter_max_bands},
          {"conditions", out}};
}

// The timings of the plain, variant and bare renders (ms per frame) with the plain renders'
// profile by stage.
struct PlainTimes {
  std::vector<double> plain, bare;
  sim::RenderTimes profile;
  json variants;
};

// The bench's JSON, in the order it has always been written.
json report(const Bench& b, const PlainTimes& t, const std::vector<double>& blur,
            const json& distortion, const std::vector<double>& noise_ms, const json& adaptive) {
  json j;
  j["adaptive_blur_20ms"] = adaptive;
  j["read_noise_ms_per_frame_median"] = sim::summarize(noise_ms).median;
  j["read_noise_ms_per_frame_max"] = sim::summarize(noise_ms).max;
  j["ms_per_frame_median"] = sim::summarize(t.plain).median;
  j["ms_per_frame_mean"] = sim::summarize(t.plain).mean;
  j["ms_per_frame_max"] = sim::summarize(t.plain).max;
  const double nr = std::max(1, t.profile.renders);
  j["profile_ms_per_frame_mean"] = {{"scene_update", t.profile.scene_ms / nr},
                                    {"draw", t.profile.draw_ms / nr},
                                    {"read_pixels", t.profile.read_ms / nr},
                                    {"flip_convert", t.profile.convert_ms / nr}};
  j["variants_ms_per_frame_median"] = t.variants;
  j["bare_mujoco_ms_per_frame_median"] = sim::summarize(t.bare).median;
  j["bare_mujoco_ms_per_frame_mean"] = sim::summarize(t.bare).mean;
  j["ours_over_bare_median"] = sim::summarize(t.plain).median / sim::summarize(t.bare).median;
  j["distortion"] = distortion;
  j["ms_per_frame_blur8_median"] = sim::summarize(blur).median;
  j["backend"] = b.renderer.backend_description();
  j["egl_devices"] = b.renderer.backend_devices();
  j["device_used"] = b.renderer.backend_device_used();
  j["frames"] = b.n;
  j["width_px"] = b.W;
  j["height_px"] = b.H;
  j["msaa_samples"] = b.s.render.msaa_samples;
  j["shadows"] = b.s.render.shadows;
  return j;
}

int bench_render(const Args& args) {
  ArgParser a(args, {"json", "frames", "backend", "msaa", "scenario", "blur-frames"}, {"shadows"});
  if (!a.has("json")) throw UsageError("usage: lander bench render --json FILE [--frames N]");
  const int n = static_cast<int>(a.integer("frames", 300, 1));
  if (n < 1) throw UsageError("--frames must be >= 1");
  const sim::Scenario s = bench_scenario(a);
  sim::World world(s.world, s.camera.intrinsics, s.cart.deck_motion.present());
  sim::apply_plant_truth(s, world);  // the sun casts shadows with --shadows
  sim::Renderer renderer(world.model(), s.render);
  // The pinhole view the camera's image is remapped from (larger than the image with barrel
  // distortion).
  const cv::Size rs = sim::pinhole_render_size(s.camera.intrinsics);
  Bench b{s, world, renderer, rs.width, rs.height, n};
  cv::Mat img;
  b.place(0, 0);
  b.render(img);  // warm-up
  // Our camera render, profiled by stage; the scene's parts; a bare MuJoCo render (default
  // scene flags and options, readPixels into RGB, no conversion): what the camera path costs
  // above MuJoCo itself.
  PlainTimes t;
  renderer.reset_times();
  t.plain = b.time_views([&](int) { b.render(img); });
  t.profile = renderer.times();
  t.variants = flag_variants(b, img);
  std::vector<unsigned char> rgb;
  t.bare = b.time_views([&](int) {
    renderer.render_camera_bare(world.model(), world.data(), world.camera_id(), b.W, b.H, rgb);
  });
  // The camera pipeline's stages: motion blur, lens distortion, read noise, adaptive blur.
  const std::vector<double> blur = time_blur8(b, img);
  const json distortion = time_distortion(b, img);
  const std::vector<double> noise_ms = time_read_noise(b, img);
  const json adaptive = adaptive_blur(b, static_cast<int>(a.integer("blur-frames", 8, 1)));
  json j = report(b, t, blur, distortion, noise_ms, adaptive);
  j["jpeg"] = time_jpeg(b, img);
  j["rolling_shutter"] = rolling_shutter(b, static_cast<int>(a.integer("blur-frames", 8, 1)));
  sim::write_json_file(a.value("json"), j);
  std::cout << sim::json_text(j);
  // Which GL device rendered these figures (a hardware EGL device, when one is present, is
  // preferred to Mesa's llvmpipe).
  std::cerr << "bench render: device: " << b.renderer.backend_device_used() << "; "
            << b.renderer.backend_description() << "; EGL devices seen: "
            << (b.renderer.backend_devices().empty() ? "none" : "") << "\n";
  for (const std::string& d : b.renderer.backend_devices()) std::cerr << "  " << d << "\n";
  return kExitOk;
}

const LanderCommand reg("render", "render --json FILE [--frames N] [--blur-frames N] [--backend auto|egl|osmesa] [--msaa N] [--shadows]",
                        Kind::Bench, bench_render);

}  // namespace
}  // namespace lander::cli
