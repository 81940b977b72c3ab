// The vehicle's downward camera: exposure interval, motion blur from the real motion, read
// noise and lens distortion on top of MuJoCo's pinhole render.
//
// Motion blur: the frame is the mean of `blur_samples` renders taken at physics sub-steps
// spread over the exposure [t_start, t_start + exposure]; the simulator advances the real
// dynamics between them, so the blur is what the motion during the exposure produces.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "lander/estimator/params_io.h"
#include "lander/estimator/types.h"

namespace lander::sim {

// Largest image side (px) the simulator renders: the offscreen framebuffer MuJoCo allocates
// for the camera must fit the GL implementation's limits (GL_MAX_RENDERBUFFER_SIZE and
// GL_MAX_TEXTURE_SIZE are 16384 on Mesa llvmpipe, 16384-32768 on GPUs) and memory; checked
// by validate() so a bad scenario is refused before any work instead of failing in MuJoCo.
constexpr int kMaxRenderSidePx = 8192;
// Smallest camera image side (px) the simulator renders.
constexpr int kMinCameraSidePx = 16;

struct CameraParams {
  CameraModel intrinsics;        ///< K and distortion (OpenCV convention)
  double rate_hz{30.0};          ///< frame rate (Hz)
  double exposure_s{0.002};      ///< exposure time (s); YAML exposure_ms
  int blur_samples{1};           ///< renders averaged over the exposure (1 = no blur)
  double read_noise_dn{0.0};     ///< Gaussian read noise std (8-bit grey levels)
  void validate() const {
    validate_nested("intrinsics", intrinsics);
    const std::string sides = "must be in [" + std::to_string(kMinCameraSidePx) + ", " +
                              std::to_string(kMaxRenderSidePx) + "] (offscreen render limit)";
    require(intrinsics.width_px >= kMinCameraSidePx && intrinsics.width_px <= kMaxRenderSidePx,
            "intrinsics.width_px", sides);
    require(intrinsics.height_px >= kMinCameraSidePx && intrinsics.height_px <= kMaxRenderSidePx,
            "intrinsics.height_px", sides);
    require(rate_hz > 0 && rate_hz <= 240, "rate_hz", "must be in (0, 240]");
    require(exposure_s >= 0 && exposure_s < 1.0 / rate_hz, "exposure_ms",
            "must be >= 0 and shorter than the frame period");
    require(blur_samples >= 1 && blur_samples <= 64, "blur_samples", "must be in [1, 64]");
    require(read_noise_dn >= 0 && read_noise_dn <= 50, "read_noise_dn", "must be in [0, 50]");
  }
};

template <class V>
void visit_fields(V& v, CameraParams& p) {
  v.nested("intrinsics", p.intrinsics);
  v("rate_hz", p.rate_hz);
  v("exposure_ms", p.exposure_s, 1e-3);
  v("blur_samples", p.blur_samples);
  v("read_noise_dn", p.read_noise_dn);
}

// One frame as the vehicle delivers it, plus the truth the simulator keeps beside it.
struct CameraFrame {
  int index{0};
  cv::Mat bgr;                         ///< CV_8UC3, row 0 = image top
  ExposureInterval exposure;           ///< sim time (s)
  Eigen::Isometry3d X_WC_true{Eigen::Isometry3d::Identity()};  ///< at mid-exposure (truth)
};

// Sample times of the renders that make up one exposure: blur_samples instants spread evenly
// over [t_start, t_start + exposure] (midpoints of equal slices), each snapped to a multiple
// of the physics step so that it falls on a real physics state.
std::vector<double> exposure_sample_times(const CameraParams& p, double t_start_s,
                                          double physics_dt_s);

// Turns renders of the centred pinhole MuJoCo camera into the configured camera's image:
// averages the blur sub-renders, applies distortion / principal point by a precomputed
// remap, adds seeded read noise.
class CameraPipeline {
 public:
  CameraPipeline(const CameraParams& params, std::uint64_t seed);

  void begin(double t_start_s);        // start a new exposure
  void add(const cv::Mat& render_bgr); // one sub-render (pinhole, camera size)
  // Averages the sub-renders and finishes the frame. Throws if no render was added.
  CameraFrame finish(int index, const Eigen::Isometry3d& X_WC_mid);

  const CameraParams& params() const { return params_; }

 private:
  CameraParams params_;
  std::uint64_t seed_;
  bool needs_remap_ = false;
  cv::Mat map_x_, map_y_;
  cv::Mat first_, accum_;
  int count_ = 0;
  double t_start_ = 0.0;
};

}  // namespace lander::sim
