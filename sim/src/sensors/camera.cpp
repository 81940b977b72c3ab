#include "lander/sim/sensors/camera.h"
#include "lander/sim/sensors/jpeg.h"

#include <chrono>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "lander/sim/render/renderer.h"
#include "lander/sim/plant/world.h"
#include "lander/sim/util/output_files.h"

namespace lander::sim {

std::vector<double> exposure_sample_times(const CameraParams& p, double t_start_s,
                                          double physics_dt_s, int n_renders) {
  std::vector<double> t;
  const int n = n_renders > 0 ? n_renders : p.blur_samples;
  for (int i = 0; i < n; ++i) {
    const double ti = t_start_s + (i + 0.5) * p.exposure_s / n;
    t.push_back(std::round(ti / physics_dt_s) * physics_dt_s);
  }
  return t;
}

std::vector<ExposureRender> exposure_renders(const CameraParams& p, double t_start_s, double physics_dt_s,
                                             int render_rows, int image_rows, int n_bands, int n_blur) {
  std::vector<ExposureRender> out;
  if (n_bands <= 1) {
    for (double t : exposure_sample_times(p, t_start_s, physics_dt_s, n_blur)) out.push_back({t, 0, render_rows});
    return out;
  }
  // The image's rows sit centred in the render's (a distorted camera's larger pinhole view);
  // render rows above or below them take the first or last image row's time.
  const double offset = 0.5 * (render_rows - image_rows);
  for (int b = 0; b < n_bands; ++b) {
    const int row0 = static_cast<int>(static_cast<long>(render_rows) * b / n_bands);
    const int row1 = static_cast<int>(static_cast<long>(render_rows) * (b + 1) / n_bands);
    if (row1 <= row0) continue;
    const double centre_row = std::clamp(0.5 * (row0 + row1 - 1) - offset, 0.0, image_rows - 1.0);
    const double t_band = t_start_s + p.rolling_shutter_readout_s * centre_row / image_rows;
    for (double t : exposure_sample_times(p, t_band, physics_dt_s, n_blur)) out.push_back({t, row0, row1});
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const ExposureRender& a, const ExposureRender& b) { return a.t_s < b.t_s; });
  return out;
}

int rolling_shutter_bands(const CameraParams& p, double motion_px) {
  if (p.rolling_shutter_readout_s <= 0) return 1;
  const double n = std::ceil(motion_px / p.rolling_shutter_px_per_band);
  if (!(n >= 1)) return 1;  // also NaN
  return static_cast<int>(std::min<double>(n, p.rolling_shutter_max_bands));
}

double image_motion_px(const CameraModel& cam, const ExposureMotion& m, double exposure_s) {
  // The camera's pose at the exposure's end: rotated by w T about its centre, moved by v T.
  const double T = exposure_s;
  Eigen::Isometry3d X_end = Eigen::Isometry3d::Identity();
  const double angle = m.w_W.norm() * T;
  const Eigen::Matrix3d dR = angle > 0 ? Eigen::AngleAxisd(angle, m.w_W.normalized()).toRotationMatrix()
                                       : Eigen::Matrix3d::Identity();
  X_end.linear() = dR * m.X_WC.linear();
  X_end.translation() = m.X_WC.translation() + m.v_W * T;
  const double mu = 0.1 * cam.width_px, mv = 0.1 * cam.height_px;
  auto project = [&](const Eigen::Isometry3d& X_WC, const Eigen::Vector3d& p_W, Eigen::Vector2d& uv) {
    const Eigen::Vector3d p_C = X_WC.inverse() * p_W;
    if (p_C.z() <= 1e-3) return false;
    uv = {cam.fx_px * p_C.x() / p_C.z() + cam.cx_px, cam.fy_px * p_C.y() / p_C.z() + cam.cy_px};
    return uv.x() >= -mu && uv.x() <= cam.width_px + mu && uv.y() >= -mv && uv.y() <= cam.height_px + mv;
  };
  double worst = 0.0;
  for (std::size_t i = 0; i < m.points_W.size(); ++i) {
    const Eigen::Vector3d p1 = m.points_W[i] + m.point_velocities_W[i] * T;
    Eigen::Vector2d a, b;
    const bool in0 = project(m.X_WC, m.points_W[i], a), in1 = project(X_end, p1, b);
    // Both ends in front of the camera, at least one of them in the image.
    const Eigen::Vector3d z0 = m.X_WC.inverse() * m.points_W[i], z1 = X_end.inverse() * p1;
    if ((in0 || in1) && z0.z() > 1e-3 && z1.z() > 1e-3) worst = std::max(worst, (b - a).norm());
  }
  return worst;
}

ExposureMotion exposure_motion(const World& world, const CameraModel& cam) {
  ExposureMotion m;
  m.X_WC = world.X_WC();
  const Eigen::Isometry3d X_WB = world.X_WB();
  m.w_W = X_WB.linear() * world.omega_B();
  m.v_W = world.v_WB() + m.w_W.cross(m.X_WC.translation() - X_WB.translation());
  // The platform (half-size 0.9 m, models/cart.xml) moving with the cart: x, y and yaw rate.
  const Eigen::Isometry3d X_WP = world.X_WP();
  for (const Eigen::Vector2d& c : {Eigen::Vector2d(0, 0), Eigen::Vector2d(0.9, 0.9), Eigen::Vector2d(0.9, -0.9),
                                  Eigen::Vector2d(-0.9, 0.9), Eigen::Vector2d(-0.9, -0.9)}) {
    const Eigen::Vector3d p = X_WP * Eigen::Vector3d(c.x(), c.y(), 0.0);
    m.points_W.push_back(p);
    m.point_velocities_W.push_back(world.cart_point_velocity_W(p));
  }
  // The ground (z = 0) where the image's centre and corners look, if they look down at it.
  for (const Eigen::Vector2d& uv : {Eigen::Vector2d(cam.cx_px, cam.cy_px), Eigen::Vector2d(0, 0),
                                   Eigen::Vector2d(cam.width_px, 0), Eigen::Vector2d(0, cam.height_px),
                                   Eigen::Vector2d(cam.width_px, cam.height_px)}) {
    const Eigen::Vector3d ray_W =
        m.X_WC.linear() * Eigen::Vector3d((uv.x() - cam.cx_px) / cam.fx_px, (uv.y() - cam.cy_px) / cam.fy_px, 1.0);
    if (ray_W.z() >= -1e-6) continue;
    const double s = -m.X_WC.translation().z() / ray_W.z();
    if (s <= 0 || s > 1000) continue;
    m.points_W.push_back(m.X_WC.translation() + s * ray_W);
    m.point_velocities_W.push_back(Eigen::Vector3d::Zero());
  }
  return m;
}

int blur_renders(const CameraParams& p, double motion_px) {
  if (!p.adaptive_blur()) return p.blur_samples;
  const double n = std::ceil(motion_px / p.blur_px_per_render);
  if (!(n >= 1)) return 1;  // also NaN
  return static_cast<int>(std::min<double>(n, p.blur_samples));
}

namespace {

// Undistorted normalised coordinates of pixels (u, v) of camera c (OpenCV's iterative inverse
// of the Brown-Conrady model).
std::vector<cv::Point2f> undistorted_normalised(const CameraModel& c, const std::vector<cv::Point2f>& px) {
  const cv::Matx33d K(c.fx_px, 0, c.cx_px, 0, c.fy_px, c.cy_px, 0, 0, 1);
  const cv::Vec<double, 5> D(c.k1, c.k2, c.p1, c.p2, c.k3);
  std::vector<cv::Point2f> norm;
  cv::undistortPoints(px, norm, K, D, cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 1e-6));
  return norm;
}

bool needs_remap(const CameraModel& c) {
  const double cx0 = 0.5 * (c.width_px - 1), cy0 = 0.5 * (c.height_px - 1);
  return c.has_distortion() || std::abs(c.cx_px - cx0) > 1e-9 || std::abs(c.cy_px - cy0) > 1e-9 ||
         std::abs(c.fx_px - c.fy_px) > 1e-9;
}

}  // namespace

cv::Size pinhole_render_size(const CameraModel& c) {
  if (!needs_remap(c)) return {c.width_px, c.height_px};
  // The rays of the image's border pixels: the pinhole render (focal length fy, centred) must
  // reach the farthest of them (barrel distortion and an off-centre principal point look
  // outside the camera-sized pinhole view).
  std::vector<cv::Point2f> border;
  for (int u = 0; u < c.width_px; ++u) {
    border.emplace_back(u, 0);
    border.emplace_back(u, c.height_px - 1);
  }
  for (int v = 0; v < c.height_px; ++v) {
    border.emplace_back(0, v);
    border.emplace_back(c.width_px - 1, v);
  }
  double ex = 0, ey = 0;
  for (const cv::Point2f& n : undistorted_normalised(c, border)) {
    ex = std::max(ex, std::abs(c.fy_px * n.x));
    ey = std::max(ey, std::abs(c.fy_px * n.y));
  }
  // Half-sizes (w - 1) / 2 >= extent + 1 px of margin for the bilinear lookup; same parity.
  auto side = [](int n, double extent) {
    const double need = 2.0 * (extent + 1.0) + 1.0;
    int out = n;
    while (out < need) out += 2;
    return std::min(out, kMaxRenderSidePx);
  };
  return {side(c.width_px, ex), side(c.height_px, ey)};
}

CameraPipeline::CameraPipeline(const CameraParams& params, std::uint64_t seed)
    : params_(params), seed_(seed) {
  params.validate();
  const CameraModel& c = params.intrinsics;
  render_size_ = pinhole_render_size(c);
  if (params.read_noise_dn > 0) {
    // Read noise bank: white Gaussian noise of the configured std, a quarter larger than the
    // image on each axis; each frame takes a window at a seeded offset (~1 ms a frame
    // against ~20 ms for drawing a fresh 1280x720x3 Gaussian field).
    noise_bank_.create(c.height_px + c.height_px / 4 + 1, c.width_px + c.width_px / 4 + 1, CV_32FC3);
    cv::RNG rng(seed_ ^ 0xD1B54A32D192ED03ull);
    rng.fill(noise_bank_, cv::RNG::NORMAL, 0.0, params.read_noise_dn);
  }
  needs_remap_ = needs_remap(c);
  if (needs_remap_) {
    // For every output (distorted) pixel, find where its ray lands in the pinhole render:
    // undistort to normalised coordinates, then project with the render's K (fy, centred:
    // MuJoCo renders square pixels with the principal point at the image centre, (w - 1) / 2
    // and (h - 1) / 2 in OpenCV's pixel-centre convention).
    const double cx0 = 0.5 * (render_size_.width - 1), cy0 = 0.5 * (render_size_.height - 1);
    std::vector<cv::Point2f> pts;
    pts.reserve(static_cast<std::size_t>(c.width_px) * c.height_px);
    for (int v = 0; v < c.height_px; ++v) {
      for (int u = 0; u < c.width_px; ++u) pts.emplace_back(u, v);
    }
    const std::vector<cv::Point2f> norm = undistorted_normalised(c, pts);
    map_x_.create(c.height_px, c.width_px, CV_32F);
    map_y_.create(c.height_px, c.width_px, CV_32F);
    for (int v = 0, i = 0; v < c.height_px; ++v) {
      for (int u = 0; u < c.width_px; ++u, ++i) {
        map_x_.at<float>(v, u) = static_cast<float>(c.fy_px * norm[i].x + cx0);
        map_y_.at<float>(v, u) = static_cast<float>(c.fy_px * norm[i].y + cy0);
      }
    }
    // Fixed-point maps (1/32 px interpolation steps): remap runs ~3x faster than with the
    // float maps, and 1/32 px is far below the render's own aliasing.
    cv::Mat fx, fy;
    cv::convertMaps(map_x_, map_y_, fx, fy, CV_16SC2);
    map_x_ = fx;
    map_y_ = fy;
  }
}

void CameraPipeline::begin(double t_start_s, int renders_per_row) {
  t_start_ = t_start_s;
  count_ = 0;
  renders_per_row_ = renders_per_row;
  accum_.release();
  if (renders_per_row_ == 1) {
    first_.create(render_size_, CV_8UC3);
  } else if (renders_per_row_ > 1) {
    accum_ = cv::Mat::zeros(render_size_, CV_32FC3);
  }
}

void CameraPipeline::add_rows(const cv::Mat& render_bgr, int row0, int row1) {
  if (renders_per_row_ <= 0) throw std::logic_error("CameraPipeline::add_rows without begin(t, renders_per_row)");
  const cv::Range rows(row0, row1);
  if (renders_per_row_ == 1) {
    render_bgr.rowRange(rows).copyTo(first_.rowRange(rows));  // one render a row: stays 8-bit
  } else {
    cv::Mat band = accum_.rowRange(rows);
    cv::accumulate(render_bgr.rowRange(rows), band);
  }
  count_ = renders_per_row_;  // what each row gets once the bands are complete
}

void CameraPipeline::add(const cv::Mat& render_bgr) {
  if (count_ == 0) {
    render_bgr.copyTo(first_);  // stays 8-bit unless more renders or post-processing follow
  } else {
    if (count_ == 1) first_.convertTo(accum_, CV_32FC3);
    cv::accumulate(render_bgr, accum_);
  }
  ++count_;
}

CameraFrame CameraPipeline::finish(int index, const Eigen::Isometry3d& X_WC_mid) {
  CameraFrame f = averaged(index, X_WC_mid);
  deliver(&f);
  return f;
}

// JPEG delivery (jpeg_quality): encoded with libjpeg through OpenCV (its default 4:2:0 chroma
// subsampling, a UVC camera's) and decoded again, so the flight software, the video and the
// saved frames get what a JPEG camera sends.
void CameraPipeline::deliver(CameraFrame* f) {
  last_jpeg_bytes_ = 0;
  if (params_.jpeg_quality <= 0) return;
  try {
    f->bgr = jpeg_round_trip(f->bgr, params_.jpeg_quality, &last_jpeg_bytes_);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(fmt::format("camera frame {}: {}", f->index, e.what()));
  }
}

cv::Mat jpeg_round_trip(const cv::Mat& bgr, int quality, std::size_t* bytes) {
  std::vector<uchar> jpeg;
  if (!cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, quality})) {
    throw std::runtime_error("JPEG encoding failed");
  }
  if (bytes) *bytes = jpeg.size();
  cv::Mat out = cv::imdecode(jpeg, cv::IMREAD_COLOR);
  if (out.empty()) throw std::runtime_error("JPEG decoding failed");
  return out;
}

CameraFrame CameraPipeline::averaged(int index, const Eigen::Isometry3d& X_WC_mid) {
  if (count_ == 0) throw std::logic_error("CameraPipeline::finish without a render");
  CameraFrame f;
  f.index = index;
  f.exposure.t_start_s = t_start_;
  f.exposure.t_end_s = t_start_ + params_.exposure_s + params_.rolling_shutter_readout_s;
  f.exposure.readout_s = params_.rolling_shutter_readout_s;
  f.X_WC_true = X_WC_mid;
  if (count_ == 1 && !needs_remap_ && params_.read_noise_dn <= 0 && params_.gain == 1.0) {
    f.bgr = first_.clone();  // plain frame: the render itself
    return f;
  }
  cv::Mat mean;
  if (count_ == 1 && needs_remap_) {
    // One render: remap the 8-bit image itself (cheaper than in float).
    cv::Mat remapped;
    cv::remap(first_, remapped, map_x_, map_y_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    if (params_.read_noise_dn <= 0 && params_.gain == 1.0) {
      f.bgr = remapped;
      return f;
    }
    remapped.convertTo(mean, CV_32FC3);
  } else {
    if (count_ == 1) {
      first_.convertTo(mean, CV_32FC3);
    } else {
      mean = accum_ * (1.0 / count_);
    }
    if (needs_remap_) {
      cv::Mat remapped;
      cv::remap(mean, remapped, map_x_, map_y_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
      mean = remapped;
    }
  }
  if (params_.gain != 1.0) mean *= params_.gain;  // exposure x gain; saturates below
  if (params_.read_noise_dn > 0) {
    // A window of the run's noise bank at an offset drawn from the frame's seed: the same
    // frame always gets the same noise, and no Gaussian is drawn per frame.
    cv::RNG rng(seed_ ^ (0x9E3779B97F4A7C15ull * static_cast<std::uint64_t>(index + 1)));
    const int dx = rng.uniform(0, noise_bank_.cols - mean.cols + 1);
    const int dy = rng.uniform(0, noise_bank_.rows - mean.rows + 1);
    mean += noise_bank_(cv::Rect(dx, dy, mean.cols, mean.rows));
  }
  mean.convertTo(f.bgr, CV_8UC3);  // rounds and saturates
  return f;
}

FrameTimingModel::FrameTimingModel(const CameraParams& p, std::uint64_t seed)
    : drop_prob_(p.frame_drop_prob),
      jitter_s_(p.timestamp_jitter_s),
      latency_s_(p.delivery_latency_s),
      latency_std_s_(p.delivery_latency_std_s),
      seed_(seed) {}

FrameTiming FrameTimingModel::at(int frame_index) const {
  FrameTiming t;
  t.delivery_latency_s = latency_s_;
  if (drop_prob_ <= 0 && jitter_s_ <= 0 && latency_std_s_ <= 0) return t;
  // One generator per frame, the three draws always made in the same order.
  std::mt19937_64 rng(seed_ ^ (0xBF58476D1CE4E5B9ull * static_cast<std::uint64_t>(frame_index + 1)));
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::normal_distribution<double> n01(0.0, 1.0);
  const double u = u01(rng), n_stamp = n01(rng), n_latency = n01(rng);
  t.dropped = u < drop_prob_;
  t.stamp_error_s = jitter_s_ * n_stamp;
  t.delivery_latency_s = std::max(0.0, latency_s_ + latency_std_s_ * n_latency);
  return t;
}

void FrameDeliveryStats::add(const FrameTiming& t) {
  ++captured_;
  if (t.dropped) {
    ++dropped_;
    return;
  }
  stamp_sq_sum_ += t.stamp_error_s * t.stamp_error_s;
  stamp_max_abs_s_ = std::max(stamp_max_abs_s_, std::abs(t.stamp_error_s));
  latency_sum_s_ += t.delivery_latency_s;
  latency_max_s_ = std::max(latency_max_s_, t.delivery_latency_s);
}

double FrameDeliveryStats::stamp_error_rms_s() const {
  return delivered() > 0 ? std::sqrt(stamp_sq_sum_ / static_cast<double>(delivered())) : 0.0;
}

double FrameDeliveryStats::delivery_latency_mean_s() const {
  return delivered() > 0 ? latency_sum_s_ / static_cast<double>(delivered()) : 0.0;
}

void save_frame_png(const std::string& dir, const CameraFrame& frame) {
  write_png_file(fmt::format("{}/frame_{:05d}.png", dir, frame.index), frame.bgr);
}

void add_exposure_render(Renderer& renderer, World& world, CameraPipeline& pipe, const ExposureRender& r,
                         cv::Mat& buf) {
  const cv::Size rs = pipe.render_size();
  if (pipe.banded()) {
    renderer.render_camera_rows(world.model(), world.data(), world.camera_id(), rs.width, rs.height, r.row0, r.row1,
                                buf);
    pipe.add_rows(buf, r.row0, r.row1);
  } else {
    renderer.render_camera(world.model(), world.data(), world.camera_id(), rs.width, rs.height, buf);
    pipe.add(buf);
  }
}

CameraRig::CameraRig(const CameraParams& params, std::uint64_t seed, double physics_dt_s)
    : pipeline_(params, seed), dt_(physics_dt_s), period_(1.0 / params.rate_hz) {}

std::optional<CameraFrame> CameraRig::advance(double t_s, World& world, Renderer& renderer,
                                              double* render_ms) {
  const CameraParams& p = pipeline_.params();
  if (!exposing_ && t_s + 1e-9 >= next_frame_t_) begin_exposure(t_s, world);
  if (!exposing_) return std::nullopt;
  if (!mid_taken_ && t_s + 1e-9 >= t_mid_) {
    X_WC_mid_ = world.X_WC();
    X_WP_mid_ = world.X_WP();
    mid_taken_ = true;
  }
  // The renders that fall now: the whole frame, or (rolling shutter) only its band's rows.
  while (next_sample_ < planned_.size() && planned_[next_sample_].t_s <= t_s + 1e-9) {
    const auto t0 = std::chrono::steady_clock::now();
    add_exposure_render(renderer, world, pipeline_, planned_[next_sample_], render_);
    ++renders_;
    ++frame_renders_;
    if (render_ms) {
      *render_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    }
    ++next_sample_;
  }
  if (next_sample_ < planned_.size() ||
      t_s + 1e-9 < next_frame_t_ + p.exposure_s + p.rolling_shutter_readout_s) {
    return std::nullopt;
  }
  CameraFrame frame = pipeline_.finish(frame_index_, X_WC_mid_);
  frame.X_WP_true = X_WP_mid_;
  frame.renders = frame_renders_;
  exposing_ = false;
  ++frame_index_;
  next_frame_t_ += period_;
  return frame;
}

// A new exposure at t_s: the blur's renders from the image motion over the exposure, the
// rolling shutter's bands from the motion over the readout (the camera's motion now).
void CameraRig::begin_exposure(double t_s, const World& world) {
  const CameraParams& p = pipeline_.params();
  exposing_ = true;
  mid_taken_ = false;
  t_mid_ = t_s + 0.5 * (p.exposure_s + p.rolling_shutter_readout_s);
  const bool rolling = p.rolling_shutter_readout_s > 0;
  const ExposureMotion motion = p.adaptive_blur() || rolling ? exposure_motion(world, p.intrinsics) : ExposureMotion{};
  const int n_blur = p.adaptive_blur() ? blur_renders(p, image_motion_px(p.intrinsics, motion, p.exposure_s))
                                       : p.blur_samples;
  const int n_bands =
      rolling ? rolling_shutter_bands(p, image_motion_px(p.intrinsics, motion, p.rolling_shutter_readout_s)) : 1;
  frame_renders_ = 0;
  pipeline_.begin(t_s, n_bands > 1 ? n_blur : 0);
  planned_ = exposure_renders(p, t_s, dt_, pipeline_.render_size().height, p.intrinsics.height_px, n_bands,
                                   n_blur);
  next_sample_ = 0;
}

}  // namespace lander::sim
