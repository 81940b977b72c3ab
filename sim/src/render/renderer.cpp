#include "lander/sim/render/renderer.h"

#include <opencv2/imgproc.hpp>

namespace lander::sim {

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
  mjModel* mm = const_cast<mjModel*>(m);
  const int saved_samples = mm->vis.quality.offsamples;
  mm->vis.quality.offsamples = params_.msaa_samples;
  mjr_makeContext(m, &context_, mjFONTSCALE_100);
  mm->vis.quality.offsamples = saved_samples;
  mjr_setBuffer(mjFB_OFFSCREEN, &context_);
  if (context_.currentBuffer != mjFB_OFFSCREEN) {
    throw GlError("offscreen framebuffer not supported by " + gl_->description());
  }
}

void Renderer::render_camera(const mjModel* m, mjData* d, int cam_id, int width, int height,
                             cv::Mat& bgr) {
  mjvCamera cam;
  mjv_defaultCamera(&cam);
  cam.type = mjCAMERA_FIXED;
  cam.fixedcamid = cam_id;
  render(m, d, cam, width, height, bgr);
}

void Renderer::render_free(const mjModel* m, mjData* d, const mjvCamera& cam, int width,
                           int height, cv::Mat& bgr) {
  mjvCamera c = cam;
  render(m, d, c, width, height, bgr);
}

void Renderer::render(const mjModel* m, mjData* d, mjvCamera& cam, int width, int height,
                      cv::Mat& bgr) {
  if (width > context_.offWidth || height > context_.offHeight) {
    throw GlError("render size " + std::to_string(width) + "x" + std::to_string(height) +
                  " exceeds the offscreen buffer " + std::to_string(context_.offWidth) + "x" +
                  std::to_string(context_.offHeight));
  }
  const mjrRect viewport = {0, 0, width, height};
  mjv_updateScene(m, d, &option_, nullptr, &cam, mjCAT_ALL, &scene_);
  mjr_render(viewport, &scene_, &context_);
  rgb_.resize(static_cast<std::size_t>(width) * height * 3);
  mjr_readPixels(rgb_.data(), nullptr, viewport, &context_);
  // OpenGL rows run bottom-up: one pass flips rows and swaps RGB -> BGR.
  bgr.create(height, width, CV_8UC3);
  for (int r = 0; r < height; ++r) {
    const cv::Mat src(1, width, CV_8UC3, rgb_.data() + static_cast<std::size_t>(height - 1 - r) *
                                                          width * 3);
    cv::Mat dst = bgr.row(r);
    cv::cvtColor(src, dst, cv::COLOR_RGB2BGR);
  }
}

}  // namespace lander::sim
