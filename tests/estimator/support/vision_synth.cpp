#include "estimator/support/vision_synth.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <utility>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "lander/estimator/camera_cv.h"
#include "lander/estimator/vision_conic.h"

namespace lander::test {

const TargetGeometry& default_target() {
  static const TargetGeometry g = TargetGeometry::load(LANDER_MODELS_DIR "/target.yaml");
  return g;
}

Eigen::Isometry3d look_at_pose(double altitude_m, double tilt_deg, double yaw_deg,
                               double azimuth_deg, const Eigen::Vector2d& aim_P_m) {
  const double th = tilt_deg * M_PI / 180, az = azimuth_deg * M_PI / 180;
  const Eigen::Vector3d d(std::sin(th) * std::cos(az), std::sin(th) * std::sin(az), std::cos(th));
  const Eigen::Vector3d aim(aim_P_m.x(), aim_P_m.y(), 0.0);
  const Eigen::Vector3d p_PC = aim + (altitude_m / std::cos(th)) * d;
  const Eigen::Vector3d z = -d;
  Eigen::Vector3d x0 = Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitX().dot(z) * z;
  if (x0.norm() < 1e-6) x0 = Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitY().dot(z) * z;
  x0.normalize();
  const Eigen::Vector3d y0 = z.cross(x0);
  const double yaw = yaw_deg * M_PI / 180;
  const Eigen::Vector3d x = std::cos(yaw) * x0 + std::sin(yaw) * y0;
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Isometry3d X_PC = Eigen::Isometry3d::Identity();
  X_PC.linear().col(0) = x;
  X_PC.linear().col(1) = y;
  X_PC.linear().col(2) = z;
  X_PC.translation() = p_PC;
  return X_PC.inverse();
}

namespace {

std::mutex& texture_mutex() {
  static std::mutex mu;
  return mu;
}
std::map<const TargetGeometry*, std::vector<cv::Mat>>& texture_cache() {
  static std::map<const TargetGeometry*, std::vector<cv::Mat>> cache;
  return cache;
}
std::map<const TargetGeometry*, cv::Mat>& texture_overrides() {
  static std::map<const TargetGeometry*, cv::Mat> o;
  return o;
}

// Grey float texture pyramid (level k: 2^k texels per level texel), cached per target.
const std::vector<cv::Mat>& texture_levels(const TargetGeometry& g) {
  std::lock_guard<std::mutex> lock(texture_mutex());
  auto& levels = texture_cache()[&g];
  if (levels.empty()) {
    auto it = texture_overrides().find(&g);
    cv::Mat bgr = it != texture_overrides().end() ? it->second : render_target_texture(g);
    cv::Mat grey, f;
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
    grey.convertTo(f, CV_32F);
    levels.push_back(f);
    while (levels.back().cols > 64) {
      cv::Mat half;
      cv::resize(levels.back(), half, cv::Size(levels.back().cols / 2, levels.back().rows / 2), 0,
                 0, cv::INTER_AREA);
      levels.push_back(half);
    }
  }
  return levels;
}

// Supersampled ideal (undistorted) view on a canvas of `size` px whose pinhole is K.
cv::Mat render_ideal_ss(const TargetGeometry& g, const Eigen::Matrix3d& K, cv::Size size,
                        const Eigen::Isometry3d& X_CP, const SynthOptions& opt) {
  const int S = opt.supersample;
  const auto& levels = texture_levels(g);
  // Texture level: texel no larger than the footprint of one sample on the nearest point.
  double depth_min = 1e9;
  for (double sx : {-1.0, 0.0, 1.0}) {
    for (double sy : {-1.0, 0.0, 1.0}) {
      const Eigen::Vector3d q =
          X_CP * Eigen::Vector3d(0.5 * sx * g.platform_size_m.x(), 0.5 * sy * g.platform_size_m.y(), 0);
      depth_min = std::min(depth_min, std::max(q.z(), 1e-3));
    }
  }
  const double footprint_m = depth_min / (K(0, 0) * S);
  const double texel_m = 1.0 / g.px_per_m();
  int k = static_cast<int>(std::floor(std::log2(std::max(1.0, footprint_m / texel_m))));
  k = std::clamp(k, 0, static_cast<int>(levels.size()) - 1);
  const double f = std::ldexp(1.0, k), s = g.px_per_m();
  Eigen::Matrix3d A;  // level-k texel -> platform (m)
  A << f / s, 0, 0.5 * f / s - 0.5 * g.platform_size_m.x(), 0, -f / s,
      0.5 * g.platform_size_m.y() - 0.5 * f / s, 0, 0, 1;
  Eigen::Matrix3d T;  // image px -> supersample px
  T << S, 0, 0.5 * S - 0.5, 0, S, 0.5 * S - 0.5, 0, 0, 1;
  const Eigen::Matrix3d M = T * plane_homography(K, X_CP) * A;
  cv::Mat Mcv(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) Mcv.at<double>(r, c) = M(r, c);
  }
  const float ground = static_cast<float>(opt.ground_grey * 255.0);
  cv::Mat ss;
  cv::warpPerspective(levels[k], ss, Mcv, cv::Size(size.width * S, size.height * S),
                      cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(ground));
  // Samples whose ray misses the plane in front of the camera (beyond the horizon) are ground.
  const Eigen::Matrix3d Mi = M.inverse();
  const Eigen::Vector3d ref = M * Eigen::Vector3d(0.5 * levels[k].cols, 0.5 * levels[k].rows, 1);
  const double sref = (Mi.row(2) * ref) > 0 ? 1.0 : -1.0;
  for (int y = 0; y < ss.rows; ++y) {
    float* row = ss.ptr<float>(y);
    for (int x = 0; x < ss.cols; ++x) {
      if (sref * (Mi(2, 0) * x + Mi(2, 1) * y + Mi(2, 2)) <= 0) row[x] = ground;
    }
  }
  // Shadow bands: each sample in front of the camera whose plane point (P, m) lies in a band
  // is multiplied by the band's light (supersampling makes the band's edges anti-aliased).
  // The light ramp multiplies each such sample by its light at that point.
  const LightRamp& ramp = opt.light_ramp;
  const bool ramped = ramp.min_light != 1.0 && ramp.half_width_m > 0;
  const double rc = std::cos(ramp.angle_deg * M_PI / 180.0);
  const double rs = std::sin(ramp.angle_deg * M_PI / 180.0);
  if (!opt.shadows.empty() || ramped) {
    const Eigen::Matrix3d G = (T * plane_homography(K, X_CP)).inverse();  // sample px -> P
    std::vector<std::pair<double, double>> dirs;  // each band's (cos, sin), once per view
    for (const auto& b : opt.shadows) {
      const double a = b.angle_deg * M_PI / 180.0;
      dirs.emplace_back(std::cos(a), std::sin(a));
    }
    for (int y = 0; y < ss.rows; ++y) {
      float* row = ss.ptr<float>(y);
      for (int x = 0; x < ss.cols; ++x) {
        const double w = G(2, 0) * x + G(2, 1) * y + G(2, 2);
        if (sref * (Mi(2, 0) * x + Mi(2, 1) * y + Mi(2, 2)) <= 0 || w == 0) continue;
        const double px = (G(0, 0) * x + G(0, 1) * y + G(0, 2)) / w;
        const double py = (G(1, 0) * x + G(1, 1) * y + G(1, 2)) / w;
        for (std::size_t i = 0; i < opt.shadows.size(); ++i) {
          const auto& b = opt.shadows[i];
          const double s = px * dirs[i].first + py * dirs[i].second - b.offset_m;
          if (std::abs(s) < 0.5 * b.width_m) row[x] *= static_cast<float>(b.light);
        }
        if (ramped) {
          const double u = std::clamp(
              (px * rc + py * rs + ramp.half_width_m) / (2 * ramp.half_width_m), 0.0, 1.0);
          row[x] *= static_cast<float>(1.0 + u * (ramp.min_light - 1.0));
        }
      }
    }
  }
  return ss;
}

}  // namespace

void set_texture_override(const TargetGeometry& g, const cv::Mat& texture_bgr) {
  std::lock_guard<std::mutex> lock(texture_mutex());
  texture_overrides()[&g] = texture_bgr.clone();
  texture_cache().erase(&g);
}

namespace {
// Texture pixel rectangle of the code square plus one texel, symmetric about the centre.
cv::Rect code_rect(const TargetGeometry& g) {
  const double c = platform_to_texture(g, Eigen::Vector2d::Zero()).x();  // 2047.5 for 4096
  const int half = static_cast<int>(std::ceil(0.5 * g.code.side_m() * g.px_per_m())) + 1;
  const int x0 = static_cast<int>(std::lround(c + 0.5)) - half;
  return cv::Rect(x0, x0, 2 * half, 2 * half);
}
}  // namespace

cv::Mat texture_with_rotated_code(const TargetGeometry& g) {
  cv::Mat tex = render_target_texture(g);
  const cv::Rect r = code_rect(g);
  cv::Mat rotated;
  cv::rotate(tex(r), rotated, cv::ROTATE_90_CLOCKWISE);
  rotated.copyTo(tex(r));
  return tex;
}

cv::Mat texture_with_inverted_cells(const TargetGeometry& g, int col0, int row0, int w) {
  cv::Mat tex = render_target_texture(g);
  const double half = 0.5 * g.code.side_m();
  const Eigen::Vector2d tl = platform_to_texture(
      g, Eigen::Vector2d(-half + col0 * g.code.cell_m, half - row0 * g.code.cell_m));
  const Eigen::Vector2d br = platform_to_texture(
      g, Eigen::Vector2d(-half + (col0 + w) * g.code.cell_m, half - (row0 + w) * g.code.cell_m));
  const cv::Rect r(cv::Point(static_cast<int>(std::lround(tl.x() + 0.5)),
                             static_cast<int>(std::lround(tl.y() + 0.5))),
                   cv::Point(static_cast<int>(std::lround(br.x() + 0.5)),
                             static_cast<int>(std::lround(br.y() + 0.5))));
  cv::Mat roi = tex(r);
  cv::bitwise_not(roi, roi);
  return tex;
}

cv::Mat render_view(const TargetGeometry& g, const CameraModel& cam, const Eigen::Isometry3d& X_CP,
                    const SynthOptions& opt) {
  const int S = opt.supersample;
  const cv::Size size(cam.width_px, cam.height_px);
  cv::Mat ss;
  if (!cam.has_distortion()) {
    ss = render_ideal_ss(g, cam.K(), size, X_CP, opt);
  } else {
    // Ideal view on a padded canvas, then each supersample of the distorted frame looks up
    // its undistorted position (cv::undistortPoints) in it.
    const int pad = std::max(cam.width_px, cam.height_px) / 4;
    Eigen::Matrix3d Kp = cam.K();
    Kp(0, 2) += pad;
    Kp(1, 2) += pad;
    const cv::Mat ideal =
        render_ideal_ss(g, Kp, cv::Size(size.width + 2 * pad, size.height + 2 * pad), X_CP, opt);
    // The maps depend on the camera alone: the last camera's are kept (a test renders many
    // views through one distorted camera; undistortPoints on every supersample costs ~2.5 s).
    const cv::Mat Kcv = camera_matrix_cv(cam);
    const cv::Mat Dcv = dist_coeffs_cv(cam);
    std::vector<double> key(Kcv.begin<double>(), Kcv.end<double>());
    key.insert(key.end(), Dcv.begin<double>(), Dcv.end<double>());
    key.insert(key.end(), {double(size.width), double(size.height), double(S)});  // pad: of size
    static std::mutex cache_mutex;
    static std::vector<double> cached_key;
    static cv::Mat cached_mapx, cached_mapy;
    cv::Mat mapx, mapy;
    {
      std::lock_guard<std::mutex> lock(cache_mutex);
      if (key == cached_key) {
        mapx = cached_mapx;
        mapy = cached_mapy;
      }
    }
    if (mapx.empty()) {
      std::vector<cv::Point2f> src;
      src.reserve(static_cast<std::size_t>(size.area()) * S * S);
      for (int y = 0; y < size.height * S; ++y) {
        for (int x = 0; x < size.width * S; ++x) {
          src.emplace_back((x + 0.5f) / S - 0.5f, (y + 0.5f) / S - 0.5f);
        }
      }
      std::vector<cv::Point2f> und;
      cv::undistortPoints(src, und, Kcv, Dcv, cv::noArray(), Kcv,
                          cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-9));
      mapx.create(size.height * S, size.width * S, CV_32F);
      mapy.create(mapx.size(), CV_32F);
      for (int y = 0, i = 0; y < mapx.rows; ++y) {
        for (int x = 0; x < mapx.cols; ++x, ++i) {
          mapx.at<float>(y, x) = S * (und[i].x + pad + 0.5f) - 0.5f;
          mapy.at<float>(y, x) = S * (und[i].y + pad + 0.5f) - 0.5f;
        }
      }
      std::lock_guard<std::mutex> lock(cache_mutex);
      cached_key = key;
      cached_mapx = mapx;
      cached_mapy = mapy;
    }
    cv::remap(ideal, ss, mapx, mapy, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
              cv::Scalar(opt.ground_grey * 255.0));
  }
  cv::Mat img;
  cv::resize(ss, img, size, 0, 0, cv::INTER_AREA);
  if (opt.blur_px > 0) motion_blur(img, opt.blur_px, opt.blur_angle_deg);
  if (opt.noise_sigma > 0) {
    cv::RNG rng(opt.seed);
    cv::Mat noise(img.size(), CV_32F);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, opt.noise_sigma);
    img += noise;
  }
  cv::Mat out;
  img.convertTo(out, CV_8U);
  if (opt.bgr) cv::cvtColor(out, out, cv::COLOR_GRAY2BGR);
  return out;
}

cv::Mat render_exposure(const TargetGeometry& g, const CameraModel& cam,
                        const std::vector<Eigen::Isometry3d>& poses, const SynthOptions& opt) {
  cv::Mat acc;
  for (const auto& X : poses) {
    cv::Mat f;
    render_view(g, cam, X, opt).convertTo(f, opt.bgr ? CV_32FC3 : CV_32FC1);
    if (acc.empty()) {
      acc = f / static_cast<double>(poses.size());
    } else {
      acc += f / static_cast<double>(poses.size());
    }
  }
  cv::Mat out;
  acc.convertTo(out, CV_8U);
  return out;
}

std::vector<Eigen::Vector2d> true_centres(const TargetGeometry& g, const CameraModel& cam,
                                          const Eigen::Isometry3d& X_CP) {
  std::vector<Eigen::Vector2d> out;
  for (const auto& r : g.rings) {
    const Eigen::Vector3d p = cam.K() * (X_CP * Eigen::Vector3d(r.centre_P_m.x(), r.centre_P_m.y(), 0));
    out.push_back(p.head<2>() / p.z());
  }
  return out;
}

void motion_blur(cv::Mat& img, double length_px, double angle_deg) {
  if (length_px <= 0) return;
  const int n = 2 * static_cast<int>(std::ceil(0.5 * length_px)) + 3;
  cv::Mat k = cv::Mat::zeros(n, n, CV_32F);
  const double c = 0.5 * (n - 1), a = angle_deg * M_PI / 180;
  const int steps = std::max(50, static_cast<int>(length_px * 20));
  for (int i = 0; i <= steps; ++i) {
    const double t = (static_cast<double>(i) / steps - 0.5) * length_px;
    const double x = c + t * std::cos(a), y = c + t * std::sin(a);
    const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
    const double fx = x - x0, fy = y - y0;
    k.at<float>(y0, x0) += static_cast<float>((1 - fx) * (1 - fy));
    k.at<float>(y0, x0 + 1) += static_cast<float>(fx * (1 - fy));
    k.at<float>(y0 + 1, x0) += static_cast<float>((1 - fx) * fy);
    k.at<float>(y0 + 1, x0 + 1) += static_cast<float>(fx * fy);
  }
  k /= cv::sum(k)[0];
  cv::Mat src = img.clone();
  cv::filter2D(src, img, -1, k, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
}

cv::Mat distractor_frame(const CameraModel& cam, std::uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat img(cam.height_px, cam.width_px, CV_8UC3, cv::Scalar(115, 115, 115));
  constexpr int kShift = 4;  // sub-pixel drawing, 1/16 px
  auto P = [&](double x, double y) {
    return cv::Point(static_cast<int>(x * (1 << kShift)), static_cast<int>(y * (1 << kShift)));
  };
  auto R = [&](double r) { return static_cast<int>(r * (1 << kShift)); };
  // Radius ratios far (> 0.04) from every model ring ratio (0.2, 0.3, ..., 0.75) and > 0.8.
  const double bad_ratios[] = {0.25, 0.45, 0.86, 0.93};
  for (int i = 0; i < 14; ++i) {
    const double x = rng.uniform(60.0, cam.width_px - 60.0), y = rng.uniform(60.0, cam.height_px - 60.0);
    const double Rr = rng.uniform(12.0, 50.0);
    const cv::Scalar dark(20, 20, 20), light(235, 235, 235);
    switch (i % 4) {
      case 0:  // concentric annulus with a ratio of no ring set
        cv::circle(img, P(x, y), R(Rr), dark, cv::FILLED, cv::LINE_AA, kShift);
        cv::circle(img, P(x, y), R(Rr * bad_ratios[(i / 4) % 4]), light, cv::FILLED, cv::LINE_AA,
                   kShift);
        break;
      case 1:  // disc
        cv::circle(img, P(x, y), R(Rr), dark, cv::FILLED, cv::LINE_AA, kShift);
        break;
      case 2:  // light disc on a dark disc, off-centre (not concentric)
        cv::circle(img, P(x, y), R(Rr), dark, cv::FILLED, cv::LINE_AA, kShift);
        cv::circle(img, P(x + 0.45 * Rr, y), R(0.4 * Rr), light, cv::FILLED, cv::LINE_AA, kShift);
        break;
      default:  // thin circle outline
        cv::circle(img, P(x, y), R(Rr), dark, 3, cv::LINE_AA, kShift);
        break;
    }
  }
  return img;
}

void apply_image_band(cv::Mat& img, const Eigen::Vector2d& point_px, double angle_deg,
                      double width_px, double light) {
  CV_Assert(img.depth() == CV_8U);
  const double a = angle_deg * M_PI / 180.0, c = std::cos(a), s = std::sin(a);
  const int ch = img.channels();
  for (int y = 0; y < img.rows; ++y) {
    std::uint8_t* row = img.ptr<std::uint8_t>(y);
    for (int x = 0; x < img.cols; ++x) {
      // Signed distance of the pixel centre to the centre line; the covered fraction of the
      // pixel's box, exact for an edge along an image axis and close to it otherwise.
      const double d = std::abs((x - point_px.x()) * c + (y - point_px.y()) * s);
      const double cover = std::clamp(0.5 * width_px - d + 0.5, 0.0, 1.0);
      if (cover <= 0) continue;
      const double f = 1.0 - cover * (1.0 - light);
      for (int k = 0; k < ch; ++k) row[x * ch + k] = cv::saturate_cast<std::uint8_t>(row[x * ch + k] * f);
    }
  }
}

std::vector<int> ring_sets_crossed(const TargetGeometry& g, const ShadowBand& band) {
  std::vector<int> ids;
  const double a = band.angle_deg * M_PI / 180.0;
  const Eigen::Vector2d n(std::cos(a), std::sin(a));
  for (const auto& r : g.rings) {
    const double s = r.centre_P_m.dot(n) - band.offset_m;
    // An edge line at signed distance e from the ring's centre cuts its outer circle if |e| < R.
    const double e1 = s - 0.5 * band.width_m, e2 = s + 0.5 * band.width_m;
    if (std::abs(e1) < r.outer_radius_m || std::abs(e2) < r.outer_radius_m) ids.push_back(r.id);
  }
  return ids;
}

}  // namespace lander::test
