// The estimator benchmark of issue 3: ours vs AprilTag vs ArUco on frames with known truth.
#include "lander/bench/estimator_bench.h"

#include "bench_metrics.h"
#include "camera_condition.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <ostream>
#include <random>
#include <sstream>
#include <ctime>
#include <cstdint>
#include <limits>

#include <opencv2/calib3d.hpp>

#include "lander/estimator/camera_cv.h"
#include "lander/estimator/vision_detector.h"
#include "lander/sim/util/output_files.h"
#include "lander/sim/util/stats.h"

namespace lander::bench {

using namespace lander::sim;  // output files, statistics

void EstimatorBenchParams::validate() const {
  check_fields(*this);
  require(!altitudes_m.empty(), "altitudes_m", "must not be empty");
  for (double a : altitudes_m) require(a > 0, "altitudes_m", "must be > 0");
  require(!tilts_deg.empty(), "tilts_deg", "must not be empty");
  for (double t : tilts_deg) require(t >= 0 && t < 85, "tilts_deg", "must be in [0, 85)");
  require(!blur_px.empty(), "blur_px", "must not be empty");
  for (double b : blur_px) require(b >= 0, "blur_px", "must be >= 0");
  for (int i : only_views) require(i >= 0, "only_views", "must be >= 0");
  require(!shadow_altitudes_m.empty(), "shadow_altitudes_m", "must not be empty");
  for (double a : shadow_altitudes_m) require(a > 0, "shadow_altitudes_m", "must be > 0");
  require(!shadow_tilts_deg.empty(), "shadow_tilts_deg", "must not be empty");
  for (double t : shadow_tilts_deg) {
    require(t >= 0 && t < 85, "shadow_tilts_deg", "must be in [0, 85)");
  }
  require(!shadow_widths_m.empty(), "shadow_widths_m", "must not be empty");
  for (double w : shadow_widths_m) require(w > 0, "shadow_widths_m", "must be > 0");
  require(!shadow_lights.empty(), "shadow_lights", "must not be empty");
  for (double l : shadow_lights) require(l >= 0 && l < 1, "shadow_lights", "must be in [0, 1)");
  require(!camera_altitudes_m.empty(), "camera_altitudes_m", "must not be empty");
  for (double a : camera_altitudes_m) require(a > 0, "camera_altitudes_m", "must be > 0");
  require(!camera_tilts_deg.empty(), "camera_tilts_deg", "must not be empty");
  for (double t : camera_tilts_deg) require(t >= 0 && t < 85, "camera_tilts_deg", "must be in [0, 85)");
}

// The band's signed coordinate s(q) = q . n - offset on the plane; a pixel's ray meets the
// plane at q = o + lambda r (o: camera centre in P, r: the pixel's ray in P, lambda > 0).
// Coverage of the pixel by |s| < w/2 is taken as the fraction of a pixel-wide ramp of s
// (slope |grad s| m/px from the neighbouring pixels' s) inside the band: exact for a straight
// edge across a pixel, and a pixel on the band's edge gets a blend of both lights.
void apply_shadow_band(cv::Mat& img, const CameraModel& cam, const Eigen::Isometry3d& X_CP,
                       const ShadowBand& band) {
  CV_Assert(img.depth() == CV_8U);
  const Eigen::Isometry3d X_PC = X_CP.inverse();
  const Eigen::Vector3d o = X_PC.translation();
  const Eigen::Matrix3d M = X_PC.linear() * cam.K().inverse();  // undistorted px -> ray in P
  const Eigen::Vector2d n(std::cos(band.angle_rad), std::sin(band.angle_rad));
  // Undistorted positions of the pixel centres (the frame carries the lens distortion).
  const int W = img.cols, H = img.rows;
  std::vector<cv::Point2f> und;
  if (cam.has_distortion()) {
    std::vector<cv::Point2f> src;
    src.reserve(static_cast<std::size_t>(W) * H);
    for (int y = 0; y < H; ++y) {
      for (int x = 0; x < W; ++x) src.emplace_back(static_cast<float>(x), static_cast<float>(y));
    }
    cv::undistortPoints(src, und, camera_matrix_cv(cam), dist_coeffs_cv(cam), cv::noArray(),
                        camera_matrix_cv(cam));
  }
  // s at (u, v) in undistorted px; NaN where the ray misses the plane in front.
  auto s_at = [&](double u, double v) {
    const Eigen::Vector3d r = M * Eigen::Vector3d(u, v, 1.0);
    if (!(r.z() * o.z() < 0)) return std::numeric_limits<double>::quiet_NaN();  // misses
    const double lambda = -o.z() / r.z();
    const Eigen::Vector3d q = o + lambda * r;
    return q.x() * n.x() + q.y() * n.y() - band.offset_m;
  };
  const int ch = img.channels();
  const double half = 0.5 * band.width_m;
  for (int y = 0; y < H; ++y) {
    std::uint8_t* row = img.ptr<std::uint8_t>(y);
    for (int x = 0; x < W; ++x) {
      double u = x, v = y;
      if (!und.empty()) {
        u = und[static_cast<std::size_t>(y) * W + x].x;
        v = und[static_cast<std::size_t>(y) * W + x].y;
      }
      const double s = s_at(u, v);
      if (!std::isfinite(s)) continue;
      const double su = s_at(u + 0.5, v) - s_at(u - 0.5, v);
      const double sv = s_at(u, v + 0.5) - s_at(u, v - 0.5);
      const double g = std::hypot(std::isfinite(su) ? su : 0.0, std::isfinite(sv) ? sv : 0.0);
      double cover = std::abs(s) < half ? 1.0 : 0.0;
      if (g > 0) cover = std::clamp(0.5 + (half - std::abs(s)) / g, 0.0, 1.0);
      if (cover <= 0) continue;
      const double f = 1.0 - cover * (1.0 - band.light);
      for (int c = 0; c < ch; ++c) {
        row[x * ch + c] = cv::saturate_cast<std::uint8_t>(row[x * ch + c] * f);
      }
    }
  }
}

std::vector<int> ring_sets_crossed(const TargetGeometry& g, const ShadowBand& band) {
  std::vector<int> ids;
  const Eigen::Vector2d n(std::cos(band.angle_rad), std::sin(band.angle_rad));
  for (const auto& r : g.rings) {
    const double s = r.centre_P_m.dot(n) - band.offset_m;
    // A band edge at signed distance e from the set's centre cuts its outer circle if |e| < R.
    if (std::abs(s - 0.5 * band.width_m) < r.outer_radius_m ||
        std::abs(s + 0.5 * band.width_m) < r.outer_radius_m) {
      ids.push_back(r.id);
    }
  }
  return ids;
}

Eigen::Isometry3d bench_camera_pose_P(double altitude_m, double tilt_deg, double yaw_deg,
                                      double azimuth_deg, const Eigen::Vector2d& aim_P_m) {
  const double th = tilt_deg * M_PI / 180, az = azimuth_deg * M_PI / 180;
  const Eigen::Vector3d d(std::sin(th) * std::cos(az), std::sin(th) * std::sin(az), std::cos(th));
  const Eigen::Vector3d z = -d;
  Eigen::Vector3d x0 = Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitX().dot(z) * z;
  if (x0.norm() < 1e-6) x0 = Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitY().dot(z) * z;
  x0.normalize();
  const Eigen::Vector3d y0 = z.cross(x0);
  const double yaw = yaw_deg * M_PI / 180;
  const Eigen::Vector3d x = std::cos(yaw) * x0 + std::sin(yaw) * y0;
  Eigen::Isometry3d X_PC = Eigen::Isometry3d::Identity();
  X_PC.linear() << x, z.cross(x), z;
  X_PC.translation() = Eigen::Vector3d(aim_P_m.x(), aim_P_m.y(), 0) + (altitude_m / std::cos(th)) * d;
  return X_PC;
}

using namespace detail;  // metrics and view geometry (bench_metrics.h)


std::string run_estimator_bench(const BenchRenderFn& render, const Eigen::Isometry3d& X_WP,
                                const TargetGeometry& g, const CameraModel& cam,
                                const VisionParams& vision, const EstimatorBenchParams& p,
                                std::ostream* progress) {
  p.validate();
  cam.validate();
  g.validate();
  VisionParams single = vision;
  single.tracking = false;
  RingTargetDetector ours(cam, g, single);
  AprilTagDetector apriltag;
  MethodStats s_ours, s_tag, s_aruco, s_aruco_sub;
  Json views = Json::array();
  std::mt19937_64 rng(p.seed);
  std::uniform_real_distribution<double> U(0.0, 1.0);

  std::vector<Eigen::Vector2d> ring_centres_P;
  for (const auto& r : g.rings) ring_centres_P.push_back(r.centre_P_m);
  const auto corners = marker_corners_P(g);
  const std::vector<Eigen::Vector2d> corners_P(corners.begin(), corners.end());

  // The blur ours is told for a frame rendered with `length_px` of blur.
  const double blur_dir = p.blur_direction_deg * M_PI / 180.0;
  auto blur_vector = [&](double length_px) {
    return Eigen::Vector2d(length_px * std::cos(blur_dir), length_px * std::sin(blur_dir));
  };
  // One frame of ours / of a square marker into a group: detection, centre or corner error
  // against the true projections `truth`, reprojection, pose error.
  auto add_ours = [&](Stats& s, const RingDetection& d, double cpu_ms, const Eigen::Isometry3d& X_CP,
                      const std::vector<Eigen::Vector2d>& truth) {
    ++s.frames;
    s.ms.push_back(cpu_ms);
    if (!d.detected) return;
    ++s.detected;
    for (const auto& c : d.centres) {
      for (std::size_t i = 0; i < g.rings.size(); ++i) {
        if (g.rings[i].id == c.ring_id) s.centre_err.push_back((c.centre_image_px - truth[i]).norm());
      }
    }
    add_pose(s, d.reproj_err_px, d.X_CP, X_CP);
  };
  auto add_square = [&](Stats& s, const PeerDetection& d, double cpu_ms,
                        const Eigen::Isometry3d& X_CP, const std::vector<Eigen::Vector2d>& truth) {
    ++s.frames;
    s.ms.push_back(cpu_ms);
    if (!d.detected) return;
    ++s.detected;
    for (int i = 0; i < 4; ++i) s.centre_err.push_back((d.corners_px[i] - truth[i]).norm());
    add_pose(s, d.reproj_err_px, d.X_CP, X_CP);
  };
  // Square-marker frame of the view sweep.
  auto score_square = [&](MethodStats& ms, const PeerDetection& d, double cpu_ms,
                          const Eigen::Isometry3d& X_CP, double alt, double blur, double tilt,
                          bool resolved) {
    const auto truth = project_P(cam, X_CP, corners_P);
    ms.add(alt, blur, tilt, resolved, [&](Stats& s) { add_square(s, d, cpu_ms, X_CP, truth); });
  };

  int view_index = -1;  // the view's index in the whole sweep (with these lists)
  for (double alt : p.view_sweep ? p.altitudes_m : std::vector<double>{}) {
    for (double tilt : p.tilts_deg) {
      for (double blur : p.blur_px) {
        for (int k = 0; k < p.yaws_per_view; ++k) {
          const double yaw = 360.0 * U(rng), az = 360.0 * U(rng);
          const double jr = p.aim_jitter_m * std::sqrt(U(rng)), ja = 2 * M_PI * U(rng);
          ++view_index;
          if (!p.only_views.empty() && std::find(p.only_views.begin(), p.only_views.end(),
                                                 view_index) == p.only_views.end()) {
            continue;
          }
          const Eigen::Vector2d aim(jr * std::cos(ja), jr * std::sin(ja));
          const Eigen::Isometry3d X_WC = X_WP * bench_camera_pose_P(alt, tilt, yaw, az, aim);
          const Eigen::Isometry3d X_CP = X_WC.inverse() * X_WP;

          // Ours: a single-frame (full-frame) search, then the same frame again with a
          // tracking detector primed on it, for the ROI timing.
          const cv::Mat rings = render(X_WC, MarkerKind::Rings, blur);
          const Eigen::Vector2d blur_vec = blur_vector(blur);
          double ms_ours = 0.0;
          const RingDetection d = timed([&] { return ours.detect(rings, blur_vec); }, ms_ours);
          double ms_track = kNaN;
          if (d.detected) {
            VisionParams tp = vision;
            tp.tracking = true;
            RingTargetDetector tracker(cam, g, tp);
            tracker.detect(rings, blur_vec);
            double ms2 = 0.0;
            const RingDetection d2 = timed([&] { return tracker.detect(rings, blur_vec); }, ms2);
            if (d2.used_roi) ms_track = ms2;
          }
          const auto truth = project_P(cam, X_CP, ring_centres_P);
          const double ring_px = min_ring_extent_px(cam, X_CP, g);
          const bool resolved = ring_px >= kResolvablePx;
          s_ours.add(alt, blur, tilt, resolved, [&](Stats& s) {
            add_ours(s, d, ms_ours, X_CP, truth);
            if (d.detected && std::isfinite(ms_track)) s.ms_tracking.push_back(ms_track);
          });

          const cv::Mat tag = render(X_WC, MarkerKind::AprilTag, blur);
          double ms = 0.0;
          const PeerDetection dt = timed([&] { return apriltag.detect(tag, cam, g); }, ms);
          score_square(s_tag, dt, ms, X_CP, alt, blur, tilt, resolved);
          const cv::Mat aruco = render(X_WC, MarkerKind::Aruco, blur);
          const PeerDetection da = timed([&] { return detect_aruco(aruco, cam, g, false); }, ms);
          score_square(s_aruco, da, ms, X_CP, alt, blur, tilt, resolved);
          const PeerDetection ds = timed([&] { return detect_aruco(aruco, cam, g, true); }, ms);
          score_square(s_aruco_sub, ds, ms, X_CP, alt, blur, tilt, resolved);
          // One record a view, to find out why a view was missed.
          Json v = Json::object();
          v["index"] = view_index;
          v["altitude_m"] = alt;
          v["tilt_deg"] = tilt;
          v["blur_px"] = blur;
          v["yaw_deg"] = yaw;
          v["azimuth_deg"] = az;
          v["min_ring_px"] = ring_px;
          v["ours"] = d.detected;
          v["ours_status"] = to_string(d.status);
          v["ours_reason"] = d.reason;
          v["ours_pos_err_m"] =
              d.detected ? (d.X_CP.translation() - X_CP.translation()).norm() : kNaN;
          v["ours_rot_err_deg"] = d.detected ? rot_err_deg(d.X_CP, X_CP) : kNaN;
          v["apriltag"] = dt.detected;
          v["aruco"] = da.detected;
          // The true image centre of each ring set, by id (what a miss's ellipses are checked
          // against).
          Json tc = Json::object();
          for (std::size_t i = 0; i < g.rings.size(); ++i) {
            tc[std::to_string(g.rings[i].id)] = Json::array({truth[i].x(), truth[i].y()});
          }
          v["true_centres_px"] = std::move(tc);
          if (!d.detected && !p.save_misses_dir.empty()) {
            write_png_file(p.save_misses_dir + "/view_" + std::to_string(view_index) + ".png",
                           rings);
          }
          views.push_back(std::move(v));
        }
      }
    }
    if (progress) {
      *progress << "bench estimator: altitude " << alt << " m done, ours "
                << s_ours.by_alt[alt].detected << "/" << s_ours.by_alt[alt].frames << "\n";
    }
  }

  // Frames with no target: the camera over the ground away from the platform, looking down
  // (tilt up to 45 deg); poses where any of the platform could be in view are redrawn.
  auto empty_pose = [&](double alt, std::mt19937_64& gen) {
    Eigen::Isometry3d X_WC;
    for (int tries = 0;; ++tries) {
      const double r = alt * 2.0 + 4.0 + 30.0 * U(gen), a = 2 * M_PI * U(gen);
      const Eigen::Vector2d aim(r * std::cos(a), r * std::sin(a));
      // Drawn last argument first: the order GCC evaluated the former single call's
      // arguments in (unspecified in C++; clang differs), so the empty frames are the same
      // with either compiler and the same as the sweeps reported so far.
      const double azimuth = 360.0 * U(gen);
      const double yaw = 360.0 * U(gen);
      const double tilt = 45.0 * U(gen);
      X_WC = X_WP * bench_camera_pose_P(alt, tilt, yaw, azimuth, aim);
      if (!platform_in_view(cam, X_WC.inverse() * X_WP, g) || tries > 100) break;
    }
    return X_WC;
  };
  std::vector<double> deblur_blurs;  // the sweep's blurs long enough for the blur-aware pass
  for (double b : p.blur_px) {
    if (vision.deblur_min_px > 0 && b >= vision.deblur_min_px) deblur_blurs.push_back(b);
  }
  for (int i = 0; i < p.empty_frames; ++i) {
    const double alt = p.altitudes_m[i % p.altitudes_m.size()];
    const Eigen::Isometry3d X_WC = empty_pose(alt, rng);
    const cv::Mat frame = render(X_WC, MarkerKind::Rings, 0.0);
    double ms_empty = 0.0;
    const RingDetection d = timed([&] { return ours.detect(frame); }, ms_empty);
    // The blur-aware pass must not invent a target either: the same frame searched again as
    // if the vehicle predicted a blur (the sweep's blurs that reach the pass, in turn; the
    // frame itself is sharp, so the deconvolution's ringing is at its worst). Not timed.
    bool fp_deblur = false;
    if (!deblur_blurs.empty()) {
      const double b = deblur_blurs[static_cast<std::size_t>(i) % deblur_blurs.size()];
      fp_deblur = ours.detect(frame, blur_vector(b)).detected;
    }
    s_ours.add_empty(alt, [&](Stats& s) {
      ++s.empty;
      s.false_pos += d.detected || fp_deblur;
      s.ms_empty.push_back(ms_empty);
    });
    const bool tag = apriltag.detect(render(X_WC, MarkerKind::AprilTag, 0.0), cam, g).detected;
    s_tag.add_empty(alt, [&](Stats& s) {
      ++s.empty;
      s.false_pos += tag;
    });
    const cv::Mat aruco = render(X_WC, MarkerKind::Aruco, 0.0);
    const bool ar = detect_aruco(aruco, cam, g, false).detected;
    const bool ars = detect_aruco(aruco, cam, g, true).detected;
    s_aruco.add_empty(alt, [&](Stats& s) {
      ++s.empty;
      s.false_pos += ar;
    });
    s_aruco_sub.add_empty(alt, [&](Stats& s) {
      ++s.empty;
      s.false_pos += ars;
    });
  }
  if (progress) *progress << "bench estimator: " << p.empty_frames << " empty frames done\n";

  // ---- Shadow condition (issue 12): one render per view and method, then every band. ----
  // Per method (ours, AprilTag, ArUco, ArUco + subpix) and light level.
  struct ShadowGroups {
    Stats in_view, all, empty;
    std::map<double, Stats> by_width, by_alt;
    std::map<int, Stats> by_sets;
  };
  constexpr int kMethods = 4;
  const char* const method_keys[kMethods] = {"ours", "apriltag", "aruco", "aruco.subpix"};
  std::vector<std::vector<ShadowGroups>> sh(kMethods, std::vector<ShadowGroups>(p.shadow_lights.size()));
  // Own random stream: the view sweep and empty frames above draw the same poses with or
  // without the shadow condition.
  std::mt19937_64 srng(p.seed + 12);
  auto target_in_view = [&](const Eigen::Isometry3d& X_CP) {
    return detail::target_in_view(cam, X_CP, g, corners_P);
  };
  int shadow_views = 0;
  for (double alt : p.shadow_sweep ? p.shadow_altitudes_m : std::vector<double>{}) {
    for (double tilt : p.shadow_tilts_deg) {
      for (int k = 0; k < p.shadow_views_per_pose; ++k) {
        const double yaw = 360.0 * U(srng), az = 360.0 * U(srng);
        const double jr = p.aim_jitter_m * std::sqrt(U(srng)), ja = 2 * M_PI * U(srng);
        const Eigen::Vector2d aim(jr * std::cos(ja), jr * std::sin(ja));
        const Eigen::Isometry3d X_WC = X_WP * bench_camera_pose_P(alt, tilt, yaw, az, aim);
        const Eigen::Isometry3d X_CP = X_WC.inverse() * X_WP;
        const bool in_view = target_in_view(X_CP);
        const cv::Mat rings = render(X_WC, MarkerKind::Rings, 0.0);
        const cv::Mat tag = render(X_WC, MarkerKind::AprilTag, 0.0);
        const cv::Mat aruco = render(X_WC, MarkerKind::Aruco, 0.0);
        const auto ring_truth = project_P(cam, X_CP, ring_centres_P);
        const auto corner_truth = project_P(cam, X_CP, corners_P);
        ++shadow_views;
        // One band direction per view; per width an offset at which the band's edges cross
        // at least one ring set (a band lying in a gap between sets casts no shadow on a ring).
        const double angle = M_PI * U(srng);
        for (double width : p.shadow_widths_m) {
          ShadowBand band;
          band.width_m = width;
          band.angle_rad = angle;
          std::vector<int> crossed;
          for (int tries = 0; tries < 200 && crossed.empty(); ++tries) {
            band.offset_m = p.shadow_max_offset_m * (2 * U(srng) - 1);
            crossed = ring_sets_crossed(g, band);
          }
          const int sets = std::min(4, static_cast<int>(crossed.size()));
          for (std::size_t li = 0; li < p.shadow_lights.size(); ++li) {
            band.light = p.shadow_lights[li];
            auto record = [&](ShadowGroups& G, auto&& f) {
              f(G.all);
              if (!in_view) return;
              f(G.in_view);
              f(G.by_width[width]);
              f(G.by_alt[alt]);
              f(G.by_sets[sets]);
            };
            cv::Mat img = rings.clone();
            apply_shadow_band(img, cam, X_CP, band);
            double ms = 0.0;
            const RingDetection d = timed([&] { return ours.detect(img); }, ms);
            record(sh[0][li], [&](Stats& s) { add_ours(s, d, ms, X_CP, ring_truth); });
            img = tag.clone();
            apply_shadow_band(img, cam, X_CP, band);
            const PeerDetection dt = timed([&] { return apriltag.detect(img, cam, g); }, ms);
            record(sh[1][li], [&](Stats& s) { add_square(s, dt, ms, X_CP, corner_truth); });
            img = aruco.clone();
            apply_shadow_band(img, cam, X_CP, band);
            const PeerDetection da = timed([&] { return detect_aruco(img, cam, g, false); }, ms);
            record(sh[2][li], [&](Stats& s) { add_square(s, da, ms, X_CP, corner_truth); });
            const PeerDetection ds = timed([&] { return detect_aruco(img, cam, g, true); }, ms);
            record(sh[3][li], [&](Stats& s) { add_square(s, ds, ms, X_CP, corner_truth); });
          }
        }
      }
    }
    if (progress) {
      *progress << "bench estimator: shadows, altitude " << alt << " m done, ours at "
                << p.shadow_lights.front() << " light " << sh[0][0].by_alt[alt].detected << "/"
                << sh[0][0].by_alt[alt].frames << " in view\n";
    }
  }
  // Target-free frames with a band (random width), at every light level.
  for (int i = 0; p.shadow_sweep && i < p.shadow_empty_frames; ++i) {
    const double alt = p.shadow_altitudes_m[i % p.shadow_altitudes_m.size()];
    const Eigen::Isometry3d X_WC = empty_pose(alt, srng);
    const Eigen::Isometry3d X_CP = X_WC.inverse() * X_WP;
    // The band's line through the point of the ground under the image centre.
    const Eigen::Isometry3d X_PC = X_CP.inverse();
    const Eigen::Vector3d o = X_PC.translation(), r = X_PC.linear().col(2);
    const Eigen::Vector3d q = r.z() < 0 ? Eigen::Vector3d(o - (o.z() / r.z()) * r) : o;
    ShadowBand band;
    band.angle_rad = M_PI * U(srng);
    band.width_m = p.shadow_widths_m[static_cast<std::size_t>(U(srng) * p.shadow_widths_m.size()) %
                                     p.shadow_widths_m.size()];
    band.offset_m = q.x() * std::cos(band.angle_rad) + q.y() * std::sin(band.angle_rad);
    const cv::Mat rings = render(X_WC, MarkerKind::Rings, 0.0);
    const cv::Mat tag = render(X_WC, MarkerKind::AprilTag, 0.0);
    const cv::Mat aruco = render(X_WC, MarkerKind::Aruco, 0.0);
    for (std::size_t li = 0; li < p.shadow_lights.size(); ++li) {
      band.light = p.shadow_lights[li];
      auto fp = [&](ShadowGroups& G, bool detected) {
        ++G.empty.empty;
        G.empty.false_pos += detected;
      };
      cv::Mat img = rings.clone();
      apply_shadow_band(img, cam, X_CP, band);
      double ms_empty = 0.0;
      fp(sh[0][li], timed([&] { return ours.detect(img); }, ms_empty).detected);
      sh[0][li].empty.ms_empty.push_back(ms_empty);
      img = tag.clone();
      apply_shadow_band(img, cam, X_CP, band);
      fp(sh[1][li], apriltag.detect(img, cam, g).detected);
      img = aruco.clone();
      apply_shadow_band(img, cam, X_CP, band);
      fp(sh[2][li], detect_aruco(img, cam, g, false).detected);
      fp(sh[3][li], detect_aruco(img, cam, g, true).detected);
    }
  }
  Json shadows = Json::object();
  if (p.shadow_sweep) {
    auto light_key = [](double l) { return "light_" + MethodStats::key(l); };
    for (int m = 0; m < kMethods; ++m) {
      Json jm = Json::object();
      for (std::size_t li = 0; li < p.shadow_lights.size(); ++li) {
        const ShadowGroups& G = sh[m][li];
        Json jl = Json::object();
        jl["in_view"] = G.in_view.json(false);
        jl["all"] = G.all.json(false);
        Json w = Json::object(), a = Json::object(), c = Json::object();
        for (const auto& [k, st] : G.by_width) w[MethodStats::key(k)] = st.json(false);
        for (const auto& [k, st] : G.by_alt) a[MethodStats::key(k)] = st.json(false);
        for (const auto& [k, st] : G.by_sets) c[std::to_string(k)] = st.json(false);
        jl["by_width_m"] = w;
        jl["by_altitude_m"] = a;
        jl["by_sets_crossed"] = c;
        Json e = Json::object();
        e["empty_frames"] = G.empty.empty;
        e["false_positives"] = G.empty.false_pos;
        e["false_positive_rate"] =
            G.empty.empty ? static_cast<double>(G.empty.false_pos) / G.empty.empty : kNaN;
        if (m == 0) e["ms_per_frame_median"] = summarize(G.empty.ms_empty).median;
        jl["empty"] = e;
        jm[light_key(p.shadow_lights[li])] = jl;
      }
      shadows[method_keys[m]] = jm;
    }
    Json sc = Json::object();
    sc["views"] = shadow_views;
    sc["altitudes_m"] = p.shadow_altitudes_m;
    sc["tilts_deg"] = p.shadow_tilts_deg;
    sc["widths_m"] = p.shadow_widths_m;
    sc["lights"] = p.shadow_lights;
    sc["views_per_pose"] = p.shadow_views_per_pose;
    sc["empty_frames"] = p.shadow_empty_frames;
    sc["model"] = "a band of the rendered frame (no blur) multiplied by the light, the ray of "
                  "each pixel meeting the platform plane inside the band; one random direction "
                  "a view, per width a random offset within shadow_max_offset_m at which the "
                  "band's edges cross >= 1 ring set; in_view: all ring sets and the marker's "
                  "corners inside the frame; by_sets_crossed counts sets cut by an edge (4 = 4+)";
    shadows["config"] = sc;
    if (progress) {
      // Console table: detection rate (in-view frames) per light and width, and per light and
      // altitude, for each method; false positives on the target-free frames with a band.
      auto rate = [](const Stats& st) {
        std::ostringstream os;
        os.setf(std::ios::fixed);
        os.precision(2);
        if (st.frames == 0) return std::string("   -  ");
        os << static_cast<double>(st.detected) / st.frames << " (" << st.frames << ")";
        return os.str();
      };
      auto& out_s = *progress;
      out_s << "\nshadow bands: detection rate on frames with the whole target in view (frames)\n";
      out_s << "light  group          ours          AprilTag      ArUco         ArUco+subpix\n";
      auto pad = [](std::string t, std::size_t n) {
        if (t.size() < n) t += std::string(n - t.size(), ' ');
        return t;
      };
      for (std::size_t li = 0; li < p.shadow_lights.size(); ++li) {
        auto line = [&](const std::string& grp, auto&& pick) {
          out_s << pad(MethodStats::key(p.shadow_lights[li]), 7) << pad(grp, 15);
          for (int m = 0; m < kMethods; ++m) out_s << pad(rate(pick(sh[m][li])), 14);
          out_s << "\n";
        };
        line("all in view", [](ShadowGroups& G) -> const Stats& { return G.in_view; });
        for (double w : p.shadow_widths_m) {
          line("width " + MethodStats::key(w) + " m",
               [w](ShadowGroups& G) -> const Stats& { return G.by_width[w]; });
        }
        for (double a : p.shadow_altitudes_m) {
          line("alt " + MethodStats::key(a) + " m",
               [a](ShadowGroups& G) -> const Stats& { return G.by_alt[a]; });
        }
        for (int c = 1; c <= 4; ++c) {
          line("sets cut " + std::to_string(c) + (c == 4 ? "+" : ""),
               [c](ShadowGroups& G) -> const Stats& { return G.by_sets[c]; });
        }
        out_s << pad(MethodStats::key(p.shadow_lights[li]), 7) << pad("false pos.", 15);
        for (int m = 0; m < kMethods; ++m) {
          out_s << pad(std::to_string(sh[m][li].empty.false_pos) + "/" +
                           std::to_string(sh[m][li].empty.empty), 14);
        }
        out_s << "\n";
      }
    }
  }

  Json out = Json::object();
  out["ours"] = s_ours.json(true);
  out["apriltag"] = s_tag.json(false);
  Json aruco = s_aruco.json(false);
  aruco["subpix"] = s_aruco_sub.json(false);
  out["aruco"] = aruco;
  if (p.shadow_sweep) out["shadows"] = shadows;
  if (p.camera_sweep) out["camera"] = run_camera_condition(render, X_WP, g, cam, vision, p, progress);
  Json cfg = Json::object();
  cfg["camera"] = std::to_string(cam.width_px) + "x" + std::to_string(cam.height_px) +
                  " fx " + MethodStats::key(cam.fx_px);
  cfg["marker_side_m"] = marker_side_m(g);
  cfg["yaws_per_view"] = p.yaws_per_view;
  cfg["empty_frames"] = p.empty_frames;
  cfg["seed"] = static_cast<long long>(p.seed);
  cfg["apriltag"] = "tag36h11 id 0, libapriltag 3.3, 1 thread, quad_decimate 1, corners -0.5 px";
  cfg["aruco"] = "DICT_6X6_250 id 0, OpenCV 4.6; aruco = CORNER_REFINE_NONE, aruco.subpix = "
                 "CORNER_REFINE_SUBPIX; both + solvePnP IPPE_SQUARE";
  cfg["ms_per_frame"] = "thread CPU time of one detection (+ PnP), one thread";
  cfg["reproj_err"] = "per-frame RMS of detected points vs the fitted pose (eq. 30 / N, sqrt)";
  out["config"] = cfg;
  out["views"] = views;
  return json_text(out);
}

BenchRenderFn make_synthetic_bench_renderer(const TargetGeometry& g, const CameraModel& cam,
                                            const Eigen::Isometry3d& X_WP) {
  auto views = std::make_shared<std::map<MarkerKind, std::unique_ptr<SyntheticPlatformView>>>();
  for (auto kind : {MarkerKind::Rings, MarkerKind::AprilTag, MarkerKind::Aruco}) {
    (*views)[kind] = std::make_unique<SyntheticPlatformView>(render_marker_texture(kind, g), g);
  }
  return [views, cam, X_WP](const Eigen::Isometry3d& X_WC, MarkerKind kind, double blur_px) {
    return views->at(kind)->render(cam, X_WC.inverse() * X_WP, blur_px, kSyntheticBlurDirectionDeg);
  };
}

}  // namespace lander::bench
