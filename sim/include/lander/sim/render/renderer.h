// Offscreen rendering of MuJoCo cameras into OpenCV images. The render path does MuJoCo's
// render, readPixels and one flip+RGB->BGR pass, nothing else.
#pragma once

#include <memory>

#include <mujoco/mujoco.h>
#include <opencv2/core.hpp>

#include "lander/core/params_io.h"
#include "lander/sim/render/gl_context.h"

namespace lander::sim {

struct RenderParams {
  std::string backend{"auto"};  ///< GL backend: auto (EGL, then OSMesa), egl, osmesa
  int msaa_samples{0};          ///< multisample anti-aliasing samples (0 = off; see README)
  bool shadows{false};          ///< the sun casts shadows (the vehicle's and the cart's on the
                                ///< rings): shadow mapping, costly on llvmpipe (README)
  void validate() const {
    check_fields(*this);
    require(backend == "auto" || backend == "egl" || backend == "osmesa", "backend",
            "must be auto, egl or osmesa (got '" + backend + "')");
  }
};

template <class V>
void visit_fields(V& v, RenderParams& p) {
  v("backend", p.backend, range::any, "", "GL backend: auto (EGL, then OSMesa)");
  v("msaa_samples", p.msaa_samples, range::closed(0, 16), "",
    "multisample anti-aliasing samples (0 = off; see README)");
  v("shadows", p.shadows, range::any, "",
    "the sun casts shadows (the vehicle's and the cart's on the rings)");
}

// Where a render's wall time goes (accumulated over every render of this renderer): MuJoCo's
// scene update (mjv_updateScene), drawing (mjr_render up to mjr_finish: the rasteriser's
// work), read-back (mjr_readPixels) and our one flip + RGB->BGR pass.
struct RenderTimes {
  int renders{0};
  double scene_ms{0}, draw_ms{0}, read_ms{0}, convert_ms{0};
};

class Renderer {
 public:
  // Creates the GL context and MuJoCo's rendering context (uploads the model's textures, so
  // fill them before). Throws GlError if no backend starts.
  Renderer(const mjModel* m, const RenderParams& params);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Renders model camera `cam_id` at the current mjData state into `bgr` (CV_8UC3,
  // width x height, row 0 = top of the image). `width`/`height` must not exceed the model's
  // offwidth/offheight.
  void render_camera(const mjModel* m, mjData* d, int cam_id, int width, int height,
                     cv::Mat& bgr);
  // Only rows [row0, row1) of that render (a rolling shutter's band): the camera's frustum cut
  // to those rows and drawn into a width x (row1 - row0) viewport, so that the drawing and the
  // read-back cost the band's area; the other rows of `bgr` (allocated height x width if it is
  // not) are left as they are.
  void render_camera_rows(const mjModel* m, mjData* d, int cam_id, int width, int height, int row0, int row1,
                          cv::Mat& bgr);
  // Same for a free (tracking) camera, e.g. the chase view.
  void render_free(const mjModel* m, mjData* d, const mjvCamera& cam, int width, int height,
                   cv::Mat& bgr);

  // Re-uploads model texture `tex_id` after its pixels changed (World::set_texture).
  void upload_texture(const mjModel* m, int tex_id);
  // Ids of the textures the current context holds as one grey channel (make_context).
  const std::vector<int>& luminance_textures() const { return luminance_textures_; }

  std::string backend_description() const { return gl_->description(); }
  std::vector<std::string> backend_devices() const { return gl_->devices(); }
  std::string backend_device_used() const { return gl_->device_used(); }
  const RenderTimes& times() const { return times_; }
  // Side of the context's shadow map (px): the model's shadowsize with render.shadows, else 0
  // (no map is made).
  int shadow_map_px() const { return context_.shadowFBO ? context_.shadowSize : 0; }
  // MuJoCo's scene render flags (mjRND_*), for `lander bench render`'s variants
  // (mjRND_SHADOW draws shadows only in a renderer made with render.shadows).
  mjtByte& scene_flag(int flag) { return scene_.flags[flag]; }
  void reset_times() { times_ = RenderTimes{}; }
  // MuJoCo's own render of the same camera with its default flags and no conversion
  // (mjv_updateScene + mjr_render + mjr_readPixels into `rgb`, rows bottom-up): what a bare
  // MuJoCo program pays, for `lander bench render` to compare with.
  void render_camera_bare(const mjModel* m, mjData* d, int cam_id, int width, int height,
                          std::vector<unsigned char>& rgb);

 private:
  // exclude_body: the body carrying the camera (its own geoms are not the surface it looks
  // at, for the shadow map's extent), -1 for a free camera.
  void render(const mjModel* m, mjData* d, mjvCamera& cam, int width, int height, cv::Mat& bgr,
              int exclude_body, int row0 = 0, int row1 = -1);
  // Creates MuJoCo's GL context (uploads every texture) with the configured MSAA. Large
  // textures whose every pixel is grey (the ring target) go to GL as one channel.
  void make_context(const mjModel* m);
  // Uploads 2D texture `id` of m (all grey) to its GL texture as 8-bit luminance, mipmapped.
  void upload_grey_texture(const mjModel* m, int id);

  std::unique_ptr<GlContext> gl_;
  std::vector<int> luminance_textures_;
  RenderParams params_;
  mjvScene scene_;
  mjrContext context_;
  mjvOption option_;
  std::vector<unsigned char> rgb_;
  RenderTimes times_;
  std::unique_ptr<mjvScene> bare_scene_;  // MuJoCo's default scene (render_camera_bare)
};

}  // namespace lander::sim
