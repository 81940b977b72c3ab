#include "lander/sim/camera.h"

#include <cmath>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace lander::sim {

std::vector<double> exposure_sample_times(const CameraParams& p, double t_start_s,
                                          double physics_dt_s) {
  std::vector<double> t;
  const int n = p.blur_samples;
  for (int i = 0; i < n; ++i) {
    const double ti = t_start_s + (i + 0.5) * p.exposure_s / n;
    t.push_back(std::round(ti / physics_dt_s) * physics_dt_s);
  }
  return t;
}

CameraPipeline::CameraPipeline(const CameraParams& params, std::uint64_t seed)
    : params_(params), seed_(seed) {
  params.validate();
  const CameraModel& c = params.intrinsics;
  // MuJoCo renders a pinhole with square pixels (fx = fy) and the principal point at the
  // image centre, (w - 1) / 2 and (h - 1) / 2 in OpenCV's pixel-centre convention.
  const double cx0 = 0.5 * (c.width_px - 1), cy0 = 0.5 * (c.height_px - 1);
  needs_remap_ = c.has_distortion() || std::abs(c.cx_px - cx0) > 1e-9 ||
                 std::abs(c.cy_px - cy0) > 1e-9 || std::abs(c.fx_px - c.fy_px) > 1e-9;
  if (needs_remap_) {
    // For every output (distorted) pixel, find where its ray lands in the pinhole render:
    // undistort to normalised coordinates, then project with the render's K.
    std::vector<cv::Point2f> pts;
    pts.reserve(static_cast<std::size_t>(c.width_px) * c.height_px);
    for (int v = 0; v < c.height_px; ++v) {
      for (int u = 0; u < c.width_px; ++u) pts.emplace_back(u, v);
    }
    const cv::Matx33d K(c.fx_px, 0, c.cx_px, 0, c.fy_px, c.cy_px, 0, 0, 1);
    const cv::Vec<double, 5> D(c.k1, c.k2, c.p1, c.p2, c.k3);
    std::vector<cv::Point2f> norm;
    cv::undistortPoints(pts, norm, K, D, cv::noArray(), cv::noArray(),
                        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20,
                                         1e-6));
    map_x_.create(c.height_px, c.width_px, CV_32F);
    map_y_.create(c.height_px, c.width_px, CV_32F);
    for (int v = 0, i = 0; v < c.height_px; ++v) {
      for (int u = 0; u < c.width_px; ++u, ++i) {
        map_x_.at<float>(v, u) = static_cast<float>(c.fy_px * norm[i].x + cx0);
        map_y_.at<float>(v, u) = static_cast<float>(c.fy_px * norm[i].y + cy0);
      }
    }
  }
}

void CameraPipeline::begin(double t_start_s) {
  t_start_ = t_start_s;
  count_ = 0;
  accum_.release();
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
  if (count_ == 0) throw std::logic_error("CameraPipeline::finish without a render");
  CameraFrame f;
  f.index = index;
  f.exposure.t_start_s = t_start_;
  f.exposure.t_end_s = t_start_ + params_.exposure_s;
  f.X_WC_true = X_WC_mid;
  if (count_ == 1 && !needs_remap_ && params_.read_noise_dn <= 0) {
    f.bgr = first_.clone();  // plain frame: the render itself
    return f;
  }
  cv::Mat mean;
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
  if (params_.read_noise_dn > 0) {
    cv::Mat noise(mean.size(), CV_32FC3);
    cv::RNG rng(seed_ ^ (0x9E3779B97F4A7C15ull * static_cast<std::uint64_t>(index + 1)));
    rng.fill(noise, cv::RNG::NORMAL, 0.0, params_.read_noise_dn);
    mean += noise;
  }
  mean.convertTo(f.bgr, CV_8UC3);  // rounds and saturates
  return f;
}

}  // namespace lander::sim
