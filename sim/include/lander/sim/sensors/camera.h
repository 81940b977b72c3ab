// The vehicle's downward camera: exposure interval, motion blur from the real motion, read
// noise and lens distortion on top of MuJoCo's pinhole render.
//
// Motion blur: the frame is the mean of `blur_samples` renders taken at physics sub-steps
// spread over the exposure [t_start, t_start + exposure]; the simulator advances the real
// dynamics between them, so the blur is what the motion during the exposure produces.
#pragma once

#include <cstdint>
#include <string>
#include <optional>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "lander/core/params_io.h"
#include "lander/core/types.h"

namespace lander::sim {

class World;
class Renderer;

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
  int blur_samples{1};           ///< renders averaged over the exposure (1 = no blur); with
                                 ///< blur_px_per_render > 0 the most renders a frame may take
  double blur_px_per_render{1.0};///< adaptive blur: one render per this many pixels of the
                                 ///< largest image motion during the exposure (capped by
                                 ///< blur_samples); 0 = always blur_samples renders
  double read_noise_dn{0.0};     ///< Gaussian read noise std (8-bit grey levels)
  double gain{1.0};              ///< exposure x gain relative to nominal: scales the image
                                 ///< (clipped at white); < 1 darker, > 1 brighter
  Eigen::Vector3d mount_error_rad{Eigen::Vector3d::Zero()};  ///< true mount rotation off the
                                 ///< nominal (MJCF) one: roll, pitch, yaw about B's x, y, z
                                 ///< (rad); YAML mount_error_deg
  Eigen::Vector3d mount_offset_m{Eigen::Vector3d::Zero()};   ///< true mount position off the
                                 ///< nominal one, in B (m)
  int jpeg_quality{0};           ///< frames delivered as JPEG at this quality (1-100; libjpeg
                                 ///< through OpenCV, 4:2:0 chroma as a UVC camera sends), each
                                 ///< encoded and decoded before the flight software sees it;
                                 ///< 0 = lossless frames (seed 000's camera sent JPG: Table 2)
  // Rolling shutter (issue 54): row v of H starts its exposure readout v / H after row 0. The
  // frame is assembled from bands of rows, each rendered at its own time; the band count
  // follows the image motion over the readout (one band per rolling_shutter_px_per_band
  // pixels, at most rolling_shutter_max_bands). 0 = global shutter (the frames of before).
  double rolling_shutter_readout_s{0.0};  ///< YAML rolling_shutter_readout_ms
  double rolling_shutter_px_per_band{1.0};///< a row's position is off by at most half this (px)
  int rolling_shutter_max_bands{16};      ///< most bands (renders per blur sample) a frame takes
  // Frame timing of a USB camera on a busy computer (issue 54): drops, stamp jitter and a
  // delivery latency that varies; all 0 = every frame delivered, stamped at its exposure end.
  double frame_drop_prob{0.0};   ///< probability that a frame never reaches the flight
                                 ///< software (bus or computer busy), drawn per frame (-)
  double timestamp_jitter_s{0.0};///< std of the driver stamp's Gaussian error (s); the stamp
                                 ///< and the exposure interval the driver reports move by it;
                                 ///< YAML timestamp_jitter_ms
  double delivery_latency_s{0.0};///< mean extra time from the exposure end to the frame's
                                 ///< arrival (transfer, decode) (s), before the computer's
                                 ///< vision latency; YAML delivery_latency_ms
  double delivery_latency_std_s{0.0};///< its std per frame (s), a Gaussian cut at 0; frames
                                 ///< keep their order; YAML delivery_latency_std_ms
  bool stamp_at_arrival{false};  ///< the driver stamps each frame when it arrives (its
                                 ///< exposure end + the delivery latency, + the jitter) and
                                 ///< reports an exposure ending at that stamp, as drivers
                                 ///< that stamp on buffer completion do; false: stamped at the
                                 ///< exposure end. The flight software's belief of that delay
                                 ///< is flight.camera.stamp_delay_ms
  // Blur whose render count follows the image motion (blur_renders()).
  bool adaptive_blur() const { return blur_samples > 1 && blur_px_per_render > 0; }
  void validate() const {
    check_fields(*this);
    require(mount_error_rad.cwiseAbs().maxCoeff() <= M_PI / 6, "mount_error_deg",
            "each angle must be within +-30 deg");
    require(mount_offset_m.cwiseAbs().maxCoeff() <= 0.2, "mount_offset_m",
            "each component must be within +-0.2 m");
    validate_nested("intrinsics", intrinsics);
    const std::string sides = "must be in [" + std::to_string(kMinCameraSidePx) + ", " +
                              std::to_string(kMaxRenderSidePx) + "] (offscreen render limit)";
    require(intrinsics.width_px >= kMinCameraSidePx && intrinsics.width_px <= kMaxRenderSidePx,
            "intrinsics.width_px", sides);
    require(intrinsics.height_px >= kMinCameraSidePx && intrinsics.height_px <= kMaxRenderSidePx,
            "intrinsics.height_px", sides);
    require(exposure_s >= 0 && exposure_s < 1.0 / rate_hz, "exposure_ms",
            "must be >= 0 and shorter than the frame period");
    require(exposure_s + rolling_shutter_readout_s < 1.0 / rate_hz, "rolling_shutter_readout_ms",
            "the readout plus the exposure must be shorter than the frame period");
    require(blur_px_per_render == 0 || (blur_px_per_render >= 0.1 && blur_px_per_render <= 100),
            "blur_px_per_render", "must be 0 (fixed count) or in [0.1, 100] px");
  }
};

template <class V>
void visit_fields(V& v, CameraParams& p) {
  v.nested("intrinsics", p.intrinsics);
  v("rate_hz", p.rate_hz, range::open_closed(0, 240), "Hz", "frame rate");
  v("exposure_ms", p.exposure_s, range::any, "ms", "exposure time", 1e-3);
  v("blur_samples", p.blur_samples, range::closed(1, 64), "",
    "renders averaged over the exposure (1 = no blur)");
  v("blur_px_per_render", p.blur_px_per_render, range::any, "",
    "adaptive blur: one render per this many pixels of the largest image");
  v("read_noise_dn", p.read_noise_dn, range::closed(0, 50), "grey levels (8 bit)",
    "Gaussian read noise std (8-bit grey levels)");
  v("gain", p.gain, range::open_closed(0, 16), "", "exposure x gain relative to nominal");
  v("mount_error_deg", p.mount_error_rad, range::any, "deg",
    "true mount rotation off the nominal one", M_PI / 180.0);
  v("mount_offset_m", p.mount_offset_m, range::any, "m", "true mount position off the nominal one");
  v("jpeg_quality", p.jpeg_quality, range::closed(0, 100), "",
    "frames delivered as JPEG at this quality (1-100, 4:2:0 chroma); 0 = lossless");
  v("rolling_shutter_readout_ms", p.rolling_shutter_readout_s, range::closed(0, 100), "ms",
    "rolling shutter: first row's start to the last row's start; 0 = global shutter", 1e-3);
  v("rolling_shutter_px_per_band", p.rolling_shutter_px_per_band, range::closed(0.05, 100), "px",
    "one band of rows per this much image motion over the readout");
  v("rolling_shutter_max_bands", p.rolling_shutter_max_bands, range::closed(1, 720), "",
    "most bands of rows a frame is assembled from");
  v("frame_drop_prob", p.frame_drop_prob, range::closed(0, 0.9), "probability",
    "probability that a frame never reaches the flight software");
  v("timestamp_jitter_ms", p.timestamp_jitter_s, range::closed(0, 100), "ms",
    "std of the driver stamp's Gaussian error", 1e-3);
  v("delivery_latency_ms", p.delivery_latency_s, range::closed(0, 1000), "ms",
    "mean extra time from the exposure end to the frame's arrival", 1e-3);
  v("delivery_latency_std_ms", p.delivery_latency_std_s, range::closed(0, 1000), "ms",
    "its std per frame (a Gaussian cut at 0)", 1e-3);
  v("stamp_at_arrival", p.stamp_at_arrival, range::any, "",
    "the driver stamps each frame when it arrives (exposure end + delivery latency)");
}

// One frame's delivery (FrameTimingModel): dropped or not, the driver stamp's error and the
// extra delivery latency, in seconds.
struct FrameTiming {
  bool dropped{false};
  double stamp_error_s{0.0};
  double delivery_latency_s{0.0};
};

// Draws each frame's timing from the camera's frame_drop_prob, timestamp_jitter_ms and
// delivery_latency_ms / _std_ms, from a generator seeded by (seed, frame index): the same frame
// always gets the same timing, whatever else the run draws. With every key 0 nothing is drawn
// and every frame is delivered on time with an exact stamp.
class FrameTimingModel {
 public:
  FrameTimingModel(const CameraParams& p, std::uint64_t seed);
  FrameTiming at(int frame_index) const;

 private:
  double drop_prob_, jitter_s_, latency_s_, latency_std_s_;
  std::uint64_t seed_;
};

// What the flight software received of the camera's frames over a run (summary.json's
// camera_delivery): counts, the stamps' errors and the delivery latencies.
class FrameDeliveryStats {
 public:
  void add(const FrameTiming& t);
  long captured() const { return captured_; }
  long dropped() const { return dropped_; }
  long delivered() const { return captured_ - dropped_; }
  double stamp_error_rms_s() const;
  double stamp_error_max_abs_s() const { return stamp_max_abs_s_; }
  double delivery_latency_mean_s() const;
  double delivery_latency_max_s() const { return latency_max_s_; }

 private:
  long captured_{0}, dropped_{0};
  double stamp_sq_sum_{0.0}, stamp_max_abs_s_{0.0}, latency_sum_s_{0.0}, latency_max_s_{0.0};
};

// One frame as the vehicle delivers it, plus the truth the simulator keeps beside it.
struct CameraFrame {
  int index{0};
  cv::Mat bgr;                         ///< CV_8UC3, row 0 = image top
  ExposureInterval exposure;           ///< sim time (s)
  int renders{1};                      ///< renders averaged into it (motion blur)
  /// Truth at the exposure's middle (ExposureInterval::mid(), the first physics state at or
  /// after it): the camera's and the platform's poses.
  Eigen::Isometry3d X_WC_true{Eigen::Isometry3d::Identity()};
  Eigen::Isometry3d X_WP_true{Eigen::Isometry3d::Identity()};
};

// Writes `frame` as `dir`/frame_NNNNN.png (lossless, atomically). Throws OutputError.
void save_frame_png(const std::string& dir, const CameraFrame& frame);

// Sample times of the renders that make up one exposure: n instants spread evenly over
// [t_start, t_start + exposure] (midpoints of equal slices), each snapped to a multiple of the
// physics step so that it falls on a real physics state. n = p.blur_samples when n_renders is
// 0.
std::vector<double> exposure_sample_times(const CameraParams& p, double t_start_s,
                                          double physics_dt_s, int n_renders = 0);

// The motion the camera sees during an exposure, for the adaptive blur: the camera's pose and
// velocity (linear v_W of its centre, angular w_W, both in W) and scene points with their
// velocities (W), all held constant over the exposure.
struct ExposureMotion {
  Eigen::Isometry3d X_WC{Eigen::Isometry3d::Identity()};  ///< OpenCV convention (z forward)
  Eigen::Vector3d v_W{Eigen::Vector3d::Zero()}, w_W{Eigen::Vector3d::Zero()};
  std::vector<Eigen::Vector3d> points_W, point_velocities_W;
};
// One render of a frame's exposure: its (physics) time and the band of pinhole-render rows
// [row0, row1) it contributes to.
struct ExposureRender {
  double t_s{0.0};
  int row0{0}, row1{0};
};
// The renders of one exposure starting at t_start_s with a rolling shutter of n_bands bands
// of the render's rows (render_rows, the image's image_rows centred in it) and n_blur renders
// per band: band b's rows start readout x (its centre row) / image_rows after t_start, its
// renders spread over the exposure from there (exposure_sample_times), snapped to the physics
// step; in time order (bands in row order at equal times). One band: exposure_sample_times'
// renders over every row.
std::vector<ExposureRender> exposure_renders(const CameraParams& p, double t_start_s, double physics_dt_s,
                                             int render_rows, int image_rows, int n_bands, int n_blur);
// Bands for a rolling shutter whose readout sees `motion_px` of image motion: one per
// rolling_shutter_px_per_band pixels, at least 1, at most rolling_shutter_max_bands; 1 without
// a rolling shutter.
int rolling_shutter_bands(const CameraParams& p, double motion_px);

// Largest displacement (px) over `exposure_s` of the points that are in front of the camera
// and inside the image (with a margin of a tenth of its size) at the exposure's start or end,
// with the camera's pinhole projection (fx, fy, cx, cy). 0 when none is.
double image_motion_px(const CameraModel& cam, const ExposureMotion& m, double exposure_s);
// The scene points of the world whose image motion sets the blur: the landing platform's
// centre and corners (moving with the cart) and the ground where the image's centre and
// corners look (still), with the camera's motion now.
ExposureMotion exposure_motion(const World& world, const CameraModel& cam);
// Renders for one exposure: blur_samples without adaptive blur, else one per
// blur_px_per_render pixels of image motion, at least 1, at most blur_samples.
int blur_renders(const CameraParams& p, double motion_px);

// Size of the centred pinhole render (focal length fy) that the camera's image is remapped
// from: the camera's own size without distortion, larger when barrel distortion or an
// off-centre principal point look beyond it (at most kMaxRenderSidePx).
cv::Size pinhole_render_size(const CameraModel& c);

// Turns renders of the centred pinhole MuJoCo camera into the configured camera's image:
// averages the blur sub-renders, applies distortion / principal point by a precomputed
// remap, adds seeded read noise.
class CameraPipeline {
 public:
  CameraPipeline(const CameraParams& params, std::uint64_t seed);

  // Start a new exposure; with bands, each row is to get renders_per_row renders (add_rows).
  void begin(double t_start_s, int renders_per_row = 0);
  void add(const cv::Mat& render_bgr); // one sub-render (pinhole, render_size())
  // One render's rows [row0, row1) (rolling shutter): every row must get renders_per_row.
  void add_rows(const cv::Mat& render_bgr, int row0, int row1);
  // This exposure is assembled from bands (begun with renders_per_row > 0).
  bool banded() const { return renders_per_row_ > 0; }
  // Averages the sub-renders and finishes the frame. Throws if no render was added.
  CameraFrame finish(int index, const Eigen::Isometry3d& X_WC_mid);
  // Bytes of the last frame's JPEG (0 without jpeg_quality).
  std::size_t last_jpeg_bytes() const { return last_jpeg_bytes_; }

  const CameraParams& params() const { return params_; }
  cv::Size render_size() const { return render_size_; }

 private:
  CameraParams params_;
  std::uint64_t seed_;
  cv::Size render_size_;
  cv::Mat noise_bank_;  // read noise, CV_32FC3, larger than the image (see finish())
  bool needs_remap_ = false;
  cv::Mat map_x_, map_y_;
  cv::Mat first_, accum_;
  int count_ = 0;
  int renders_per_row_ = 0;  // bands (add_rows): the renders each row gets; 0 = whole frames
  double t_start_ = 0.0;
  std::size_t last_jpeg_bytes_ = 0;
  // The frame's pixels as delivered: through JPEG when jpeg_quality is set.
  void deliver(CameraFrame* f);
  // The image itself (no gain, noise or JPEG); the remap or the mean of the renders else.
  CameraFrame averaged(int index, const Eigen::Isometry3d& X_WC_mid);
};

// One planned render of an exposure (exposure_renders) of the world's camera in its state now,
// into `buf` and added to `pipe`: only the band's rows when the pipeline assembles bands
// (Renderer::render_camera_rows), the whole view else.
void add_exposure_render(Renderer& renderer, World& world, CameraPipeline& pipe, const ExposureRender& r,
                         cv::Mat& buf);

// The camera on the vehicle in the loop: exposes at its rate, renders the world at the
// exposure's sample times (one physics state each) and finishes the frame when the exposure
// ends. Call advance() once per physics step, before the step, with the state at t_s.
class CameraRig {
 public:
  CameraRig(const CameraParams& params, std::uint64_t seed, double physics_dt_s);
  // Renders what falls at t_s; returns the frame when its exposure ended at t_s. Adds the
  // render wall time to *render_ms when given.
  std::optional<CameraFrame> advance(double t_s, World& world, Renderer& renderer,
                                     double* render_ms = nullptr);
  int frames() const { return frame_index_; }

 private:
  void begin_exposure(double t_s, const World& world);
  CameraPipeline pipeline_;
  double dt_, period_;
  int frame_index_ = 0;
  double next_frame_t_ = 0.0;
  bool exposing_ = false;
  std::vector<ExposureRender> planned_;  // this exposure's renders (exposure_renders)
  // Truth at the exposure's middle, taken at the first physics state at or after it.
  bool mid_taken_ = false;
  double t_mid_ = 0.0;
  Eigen::Isometry3d X_WC_mid_{Eigen::Isometry3d::Identity()}, X_WP_mid_{Eigen::Isometry3d::Identity()};
  int frame_renders_ = 0;    // renders of the frame being exposed
  std::size_t next_sample_ = 0;
  long renders_ = 0;

 public:
  long renders() const { return renders_; }  ///< renders so far (blur sub-renders included)

 private:
  cv::Mat render_;
};

}  // namespace lander::sim
