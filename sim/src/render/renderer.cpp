#include "lander/sim/render/renderer.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>

#include <Eigen/Core>
#include <opencv2/imgproc.hpp>

namespace lander::sim {

namespace {

// Where a directional light's shadow map lies. MuJoCo draws it over +-shadowClip (a model
// constant, stat.extent * map.shadowclip: 10 m here) around the line through the light's
// position along its direction, and the position is fixed in the model: with it, shadows
// stopped about 10 m from the world origin, and a cart that had driven away carried none.
// Sunlight is the same everywhere, so each frame the line is moved through the point where
// the camera's optical axis meets the first surface (a ray: the platform in the last metre,
// else the ground), and the half-width set to hold the camera's footprint there (its
// half-diagonal is ~1.15 x the distance straight down; 1.5 x leaves room for tilted views). Light keeps a point's position across its rays, so a caster
// outside that box throws its shadow outside it too, i.e. outside the view. The shadow map's
// texels (2048 over 3 x the distance) then stay about as fine as the image's pixels on that
// surface (1/640 of the distance): with a fixed 2 m minimum, at 0.3 m the texels were 5
// pixels wide and the shadows' edges staircases of right angles, which the code map's
// corner search took for cells.
constexpr double kGroundZ = 0.0;           ///< the ground plane (world.xml)
constexpr double kMaxLookDistanceM = 60.0; ///< a near-horizontal axis: this far along it
constexpr double kShadowClipPerM = 1.5;    ///< half-width of the map per metre of distance
constexpr double kMinShadowClipM = 0.2;
constexpr double kLightBackOffM = 30.0;    ///< light placed this far above the look point
// Geom group drawn only in free (chase) views: the rotor discs (models/hexarotor.xml).
constexpr int kChaseOnlyGroup = 3;

void aim_shadow_maps(const mjModel* m, const mjData* d, int exclude_body, mjvScene& scn,
                     mjrContext& con) {
  const mjvGLCamera& c = scn.camera[0];
  const Eigen::Vector3d pos(c.pos[0], c.pos[1], c.pos[2]);
  Eigen::Vector3d fwd(c.forward[0], c.forward[1], c.forward[2]);
  if (fwd.norm() < 1e-9) return;
  fwd.normalize();
  // The first surface along the axis (the platform, 0.8 m above the ground, fills the view
  // in the last metre), else the ground plane.
  const mjtNum p0[3] = {pos.x(), pos.y(), pos.z()}, v0[3] = {fwd.x(), fwd.y(), fwd.z()};
  int geom = -1;
  double dist = mj_ray(m, d, p0, v0, nullptr, 1, exclude_body, &geom);
  if (!(dist > 0) || dist > kMaxLookDistanceM) {
    const double height = std::max(0.0, pos.z() - kGroundZ);
    dist = kMaxLookDistanceM;
    if (fwd.z() < -1e-6) dist = std::min(kMaxLookDistanceM, height / -fwd.z());
  }
  const Eigen::Vector3d look = pos + dist * fwd;
  con.shadowClip = static_cast<float>(std::max(kMinShadowClipM, kShadowClipPerM * dist));
  for (int i = 0; i < scn.nlight; ++i) {
    mjvLight& L = scn.lights[i];
    if (!L.castshadow || !L.directional) continue;
    Eigen::Vector3d dir(L.dir[0], L.dir[1], L.dir[2]);
    if (dir.norm() < 1e-9) continue;
    dir.normalize();
    const Eigen::Vector3d lp = look - (dist + kLightBackOffM) * dir;
    for (int k = 0; k < 3; ++k) L.pos[k] = static_cast<float>(lp[k]);
  }
}

}  // namespace

Renderer::Renderer(const mjModel* m, const RenderParams& params) : params_(params) {
  params.validate();
  gl_ = std::make_unique<GlContext>(parse_gl_backend(params.backend),
                                    m->vis.global.offwidth, m->vis.global.offheight);
  mjv_defaultScene(&scene_);
  mjv_defaultOption(&option_);
  mjv_makeScene(m, &scene_, 2000);
  mjr_defaultContext(&context_);
  make_context(m);
  scene_.flags[mjRND_SHADOW] = params.shadows ? 1 : 0;
  scene_.flags[mjRND_SKYBOX] = 1;
  // Sites and joint markers are not part of the camera's world.
  for (int g = 0; g < mjNGROUP; ++g) option_.sitegroup[g] = 0;
}

Renderer::~Renderer() {
  mjr_freeContext(&context_);
  mjv_freeScene(&scene_);
  if (bare_scene_) mjv_freeScene(bare_scene_.get());
}

void Renderer::upload_texture(const mjModel* m, int tex_id) {
  // MuJoCo 2.2.2's mjr_uploadTexture leaves the old mipmap levels in place (minified views
  // still sample the old texture), so rebuild the rendering context: every texture is
  // uploaded with fresh mipmaps. Costs about a second; textures change rarely.
  (void)tex_id;
  mjr_freeContext(&context_);
  mjr_defaultContext(&context_);
  make_context(m);
}

void Renderer::make_context(const mjModel* m) {
  // MSAA is a property of MuJoCo's offscreen buffer, read from the model at context creation.
  // So is the shadow map (shadowsize^2 floats, which llvmpipe allocates and clears: 16 MB at
  // 2048): without render.shadows no light draws into it, and with size 0 MuJoCo makes none
  // (mjr_render then lights every light as it does with the shadow flag off).
  mjModel* mm = const_cast<mjModel*>(m);
  const int saved_samples = mm->vis.quality.offsamples;
  const int saved_shadow = mm->vis.quality.shadowsize;
  mm->vis.quality.offsamples = params_.msaa_samples;
  if (!params_.shadows) mm->vis.quality.shadowsize = 0;
  mjr_makeContext(m, &context_, mjFONTSCALE_100);
  mm->vis.quality.offsamples = saved_samples;
  mm->vis.quality.shadowsize = saved_shadow;
  mjr_setBuffer(mjFB_OFFSCREEN, &context_);
  if (context_.currentBuffer != mjFB_OFFSCREEN) {
    throw GlError("offscreen framebuffer not supported by " + gl_->description());
  }
}

void Renderer::render_camera(const mjModel* m, mjData* d, int cam_id, int width, int height,
                             cv::Mat& bgr) {
  option_.geomgroup[kChaseOnlyGroup] = 0;
  mjvCamera cam;
  mjv_defaultCamera(&cam);
  cam.type = mjCAMERA_FIXED;
  cam.fixedcamid = cam_id;
  render(m, d, cam, width, height, bgr, m->cam_bodyid[cam_id]);
}

void Renderer::render_camera_rows(const mjModel* m, mjData* d, int cam_id, int width, int height, int row0,
                                  int row1, cv::Mat& bgr) {
  if (row0 < 0 || row1 > height || row1 <= row0) {
    throw std::invalid_argument("render_camera_rows: rows [" + std::to_string(row0) + ", " + std::to_string(row1) +
                                ") outside the image's " + std::to_string(height));
  }
  option_.geomgroup[kChaseOnlyGroup] = 0;
  mjvCamera cam;
  mjv_defaultCamera(&cam);
  cam.type = mjCAMERA_FIXED;
  cam.fixedcamid = cam_id;
  render(m, d, cam, width, height, bgr, m->cam_bodyid[cam_id], row0, row1);
}

void Renderer::render_free(const mjModel* m, mjData* d, const mjvCamera& cam, int width,
                           int height, cv::Mat& bgr) {
  option_.geomgroup[kChaseOnlyGroup] = 1;
  mjvCamera c = cam;
  render(m, d, c, width, height, bgr, -1);
}

void Renderer::render(const mjModel* m, mjData* d, mjvCamera& cam, int width, int height,
                      cv::Mat& bgr, int exclude_body, int row0, int row1) {
  const bool band = row1 >= 0;
  if (!band) row1 = height;
  if (width > context_.offWidth || height > context_.offHeight) {
    throw GlError("render size " + std::to_string(width) + "x" + std::to_string(height) +
                  " exceeds the offscreen buffer " + std::to_string(context_.offWidth) + "x" +
                  std::to_string(context_.offHeight));
  }
  using Clock = std::chrono::steady_clock;
  auto ms = [](Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
  };
  const int rows = row1 - row0;
  const mjrRect viewport = {0, 0, width, rows};
  const auto t0 = Clock::now();
  mjv_updateScene(m, d, &option_, nullptr, &cam, mjCAT_ALL, &scene_);
  if (scene_.flags[mjRND_SHADOW]) aim_shadow_maps(m, d, exclude_body, scene_, context_);
  if (band) {
    // The frustum's vertical extent cut to the band (image row 0 at the top); its horizontal
    // extent follows the viewport's aspect, width / rows, and so stays the full image's.
    for (mjvGLCamera& c : scene_.camera) {
      const float top = c.frustum_top, span = c.frustum_top - c.frustum_bottom;
      c.frustum_top = top - span * static_cast<float>(row0) / static_cast<float>(height);
      c.frustum_bottom = top - span * static_cast<float>(row1) / static_cast<float>(height);
    }
  }
  const auto t1 = Clock::now();
  mjr_render(viewport, &scene_, &context_);
  mjr_finish();  // the read-back waits for the drawing anyway; this only splits the timing
  const auto t2 = Clock::now();
  rgb_.resize(static_cast<std::size_t>(width) * rows * 3);
  mjr_readPixels(rgb_.data(), nullptr, viewport, &context_);
  const auto t3 = Clock::now();
  // OpenGL rows run bottom-up: one pass flips rows and swaps RGB -> BGR.
  if (bgr.rows != height || bgr.cols != width || bgr.type() != CV_8UC3) bgr.create(height, width, CV_8UC3);
  for (int r = 0; r < rows; ++r) {
    const cv::Mat src(1, width, CV_8UC3, rgb_.data() + static_cast<std::size_t>(rows - 1 - r) * width * 3);
    cv::Mat dst = bgr.row(row0 + r);
    cv::cvtColor(src, dst, cv::COLOR_RGB2BGR);
  }
  const auto t4 = Clock::now();
  ++times_.renders;
  times_.scene_ms += ms(t0, t1);
  times_.draw_ms += ms(t1, t2);
  times_.read_ms += ms(t2, t3);
  times_.convert_ms += ms(t3, t4);
}

void Renderer::render_camera_bare(const mjModel* m, mjData* d, int cam_id, int width, int height,
                                  std::vector<unsigned char>& rgb) {
  mjvCamera cam;
  mjv_defaultCamera(&cam);
  cam.type = mjCAMERA_FIXED;
  cam.fixedcamid = cam_id;
  mjvOption opt;
  mjv_defaultOption(&opt);
  if (!bare_scene_) {
    bare_scene_ = std::make_unique<mjvScene>();
    mjv_defaultScene(bare_scene_.get());
    mjv_makeScene(m, bare_scene_.get(), 2000);
  }
  mjvScene& scn = *bare_scene_;
  const mjrRect viewport = {0, 0, width, height};
  mjv_updateScene(m, d, &opt, nullptr, &cam, mjCAT_ALL, &scn);
  mjr_render(viewport, &scn, &context_);
  rgb.resize(static_cast<std::size_t>(width) * height * 3);
  mjr_readPixels(rgb.data(), nullptr, viewport, &context_);
}

}  // namespace lander::sim
