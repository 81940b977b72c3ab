#include "lander/sim/render/renderer.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>
#include <vector>

#include <GL/gl.h>

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

namespace {

// Textures of at least this many texels whose pixels are all grey go to GL as one channel:
// MuJoCo uploads RGB, which llvmpipe keeps as 4 bytes a texel, so the 4096 px ring target with
// its mipmaps holds 89 MB as RGB and 22 MB as luminance (issue 53: a run's peak memory).
// Luminance samples as (L, L, L, 1): the same texels, filtered and mipmapped channel by
// channel alike, so the frames are the same.
constexpr long kGreyUploadMinTexels = 1L << 20;

bool large_grey_texture(const mjModel* m, int id) {
  if (m->tex_type[id] != mjTEXTURE_2D) return false;
  const long n = static_cast<long>(m->tex_width[id]) * m->tex_height[id];
  if (n < kGreyUploadMinTexels) return false;
  const unsigned char* p = m->tex_rgb + m->tex_adr[id];
  for (long i = 0; i < n; ++i, p += 3) {
    if (p[0] != p[1] || p[1] != p[2]) return false;
  }
  return true;
}

}  // namespace

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
  // The large grey textures: MuJoCo uploads a 1x1 texel of each (its RGB copy is never made),
  // then ours replaces it.
  struct Shrunk {
    int id, width, height;
  };
  std::vector<Shrunk> grey;
  for (int i = 0; i < m->ntex; ++i) {
    if (!large_grey_texture(m, i)) continue;
    grey.push_back({i, m->tex_width[i], m->tex_height[i]});
    mm->tex_width[i] = mm->tex_height[i] = 1;
  }
  auto restore = [&] {
    mm->vis.quality.offsamples = saved_samples;
    mm->vis.quality.shadowsize = saved_shadow;
    for (const Shrunk& t : grey) {
      mm->tex_width[t.id] = t.width;
      mm->tex_height[t.id] = t.height;
    }
  };
  try {
    mjr_makeContext(m, &context_, mjFONTSCALE_100);
  } catch (...) {
    restore();
    throw;
  }
  restore();
  luminance_textures_.clear();
  for (const Shrunk& t : grey) {
    upload_grey_texture(m, t.id);
    luminance_textures_.push_back(t.id);
  }
  mjr_setBuffer(mjFB_OFFSCREEN, &context_);
  if (context_.currentBuffer != mjFB_OFFSCREEN) {
    throw GlError("offscreen framebuffer not supported by " + gl_->description());
  }
}

void Renderer::upload_grey_texture(const mjModel* m, int id) {
  using BindTexture = void (*)(GLenum, GLuint);
  using TexImage2D = void (*)(GLenum, GLint, GLint, GLsizei, GLsizei, GLint, GLenum, GLenum, const void*);
  using GenerateMipmap = void (*)(GLenum);
  using PixelStorei = void (*)(GLenum, GLint);
  using GetIntegerv = void (*)(GLenum, GLint*);
  using ActiveTexture = void (*)(GLenum);
  using GetError = GLenum (*)();
  const auto bind = reinterpret_cast<BindTexture>(gl_->proc("glBindTexture"));
  const auto image = reinterpret_cast<TexImage2D>(gl_->proc("glTexImage2D"));
  const auto mipmap = reinterpret_cast<GenerateMipmap>(gl_->proc("glGenerateMipmap"));
  const auto store = reinterpret_cast<PixelStorei>(gl_->proc("glPixelStorei"));
  const auto get = reinterpret_cast<GetIntegerv>(gl_->proc("glGetIntegerv"));
  const auto active = reinterpret_cast<ActiveTexture>(gl_->proc("glActiveTexture"));
  const auto error = reinterpret_cast<GetError>(gl_->proc("glGetError"));
  if (!bind || !image || !mipmap || !store || !get || !active || !error) {
    throw GlError("texture upload: " + gl_->description() + " lacks a GL 3.0 texture entry point");
  }
  const int w = m->tex_width[id], h = m->tex_height[id];
  std::vector<unsigned char> luminance(static_cast<std::size_t>(w) * h);
  const unsigned char* rgb = m->tex_rgb + m->tex_adr[id];
  for (std::size_t k = 0; k < luminance.size(); ++k) luminance[k] = rgb[3 * k];
  GLint alignment = 4;
  get(GL_UNPACK_ALIGNMENT, &alignment);
  active(GL_TEXTURE0);
  bind(GL_TEXTURE_2D, context_.texture[id]);
  store(GL_UNPACK_ALIGNMENT, 1);
  image(GL_TEXTURE_2D, 0, GL_LUMINANCE8, w, h, 0, GL_LUMINANCE, GL_UNSIGNED_BYTE, luminance.data());
  mipmap(GL_TEXTURE_2D);
  store(GL_UNPACK_ALIGNMENT, alignment);
  bind(GL_TEXTURE_2D, 0);
  if (const GLenum e = error(); e != GL_NO_ERROR) {
    throw GlError("texture upload: GL error " + std::to_string(e) + " uploading texture " + std::to_string(id) +
                  " (" + std::to_string(w) + "x" + std::to_string(h) + ") as luminance on " + gl_->description());
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
