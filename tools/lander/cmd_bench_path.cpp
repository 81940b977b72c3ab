// `lander bench path --json FILE [--frames N] [--work-width PX]`
// Cost per frame of the estimator's path-extraction stage (seed 003 section 3: colour
// threshold, erosion, thinning, grid centre points; lander/estimator/path_extractor.h) on
// synthetic 1280x720 frames of a painted route: a noisy asphalt-like ground and a red route of
// random shape (a polyline with 1-3 corners, or an arc), width and pose, drawn as the tests
// draw it. Each frame is extracted at --work-width (default 320) and at the sweep's work widths
// 160, 320 and 640; only the extract() call is timed, single-threaded (cv::setNumThreads(1)).
// Writes per-frame milliseconds (mean, median, p95, max, min) per work width, the machine and
// the command line; prints a one-line summary.
#include <sys/utsname.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <thread>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "command.h"
#include "lander/estimator/path_extractor.h"
#include "lander/estimator/vision_detector.h"
#include "lander/sim/util/output_files.h"
#include "lander/sim/util/stats.h"

namespace lander::cli {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The route's paint as MuJoCo renders rgba (0.85, 0.1, 0.1) under the world's sun + ambient
// (about 1.22 of the colour on the ground seen from above, clamped), BGR.
const cv::Scalar kRedPaint(31, 31, 255);

// A large asphalt-like ground (grey stains + grain, B + 8, G + 4 as the simulator's ground
// texture); frames crop it at random offsets.
cv::Mat make_ground(cv::RNG& rng, int w, int h) {
  cv::Mat coarse(h / 80 + 2, w / 80 + 2, CV_32F), fine(h, w, CV_32F);
  rng.fill(coarse, cv::RNG::NORMAL, 0.0, 18.0);
  cv::Mat stains;
  cv::resize(coarse, stains, cv::Size(w, h), 0, 0, cv::INTER_CUBIC);
  rng.fill(fine, cv::RNG::NORMAL, 0.0, 8.0);
  cv::Mat grey = stains + fine + 95.0f, g8;
  grey.convertTo(g8, CV_8U);
  cv::Mat bgr;
  cv::merge(std::vector<cv::Mat>{g8 + 8, g8 + 4, g8}, bgr);
  return bgr;
}

// One synthetic frame: a crop of the ground, a route of random shape, width 20-52 px (0.2 m
// seen from 2.5 to 6.4 m with fx = 640 px), position and heading, then sensor noise (sigma 4).
cv::Mat make_frame(cv::RNG& rng, const cv::Mat& ground, int w, int h) {
  const int ox = rng.uniform(0, ground.cols - w), oy = rng.uniform(0, ground.rows - h);
  cv::Mat img = ground(cv::Rect(ox, oy, w, h)).clone();
  const double width_px = rng.uniform(20.0, 52.0);
  std::vector<cv::Point2d> pts;
  double heading = rng.uniform(0.0, 2 * kPi);
  cv::Point2d p(rng.uniform(0.25 * w, 0.75 * w), rng.uniform(0.25 * h, 0.75 * h));
  // Start outside the frame behind the start point, so the route enters the view.
  pts.push_back(p - 900.0 * cv::Point2d(std::cos(heading), std::sin(heading)));
  if (rng.uniform(0, 4) == 0) {
    // An arc of radius 200-700 px turning by up to 270 deg.
    const double radius = rng.uniform(200.0, 700.0), turn = rng.uniform(0.5, 1.5 * kPi);
    const double sign = rng.uniform(0, 2) ? 1.0 : -1.0;
    pts.push_back(p);
    const int n = 120;
    for (int i = 1; i <= n; ++i) {
      heading += sign * turn / n;
      p += radius * turn / n * cv::Point2d(std::cos(heading), std::sin(heading));
      pts.push_back(p);
    }
  } else {
    // A polyline with 1-3 corners turning by 30-140 deg (right, acute and obtuse corners).
    const int corners = rng.uniform(1, 4);
    pts.push_back(p);
    for (int c = 0; c < corners; ++c) {
      heading += (rng.uniform(0, 2) ? 1.0 : -1.0) * rng.uniform(30.0, 140.0) * kPi / 180.0;
      p += rng.uniform(150.0, 450.0) * cv::Point2d(std::cos(heading), std::sin(heading));
      pts.push_back(p);
    }
  }
  pts.push_back(p + 900.0 * cv::Point2d(std::cos(heading), std::sin(heading)));
  std::vector<cv::Point> fixed;  // 1/16 px
  for (const auto& q : pts) fixed.emplace_back(cvRound(q.x * 16), cvRound(q.y * 16));
  cv::polylines(img, std::vector<std::vector<cv::Point>>{fixed}, false, kRedPaint,
                cvRound(width_px), cv::LINE_AA, 4);
  cv::Mat noise(img.size(), CV_16SC3), s;
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 4.0);
  img.convertTo(s, CV_16SC3);
  s += noise;
  s.convertTo(img, CV_8UC3);
  return img;
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) return line.substr(line.find_first_not_of(' ', colon + 1));
    }
  return "";
}

nlohmann::ordered_json summary_json(const std::vector<double>& ms) {
  const sim::SampleSummary s = sim::summarize(ms);
  return {{"mean", s.mean}, {"median", s.median}, {"p95", s.p95}, {"max", s.max}, {"min", s.min}};
}

int bench_path(const Args& args) {
  ArgParser a(args, {"json", "frames", "work-width"}, {});
  if (!a.has("json") || !a.positional().empty())
    throw UsageError("usage: lander bench path --json FILE [--frames N] [--work-width PX]");
  const int n = static_cast<int>(a.integer("frames", 200, 1));
  const int main_width = static_cast<int>(a.integer("work-width", 320, 32));
  const CameraModel cam = load_camera_model(models_dir() + "/camera_default.yaml");
  // Extractors: the requested work width first, then the sweep (params validated here: a bad
  // --work-width is a ConfigError naming work_width_px, exit code 2).
  std::vector<int> widths = {main_width};
  for (int w : {160, 320, 640})
    if (w != main_width) widths.push_back(w);
  std::vector<PathExtractor> extractors;
  for (int w : widths) {
    PathExtractorParams p;
    p.work_width_px = w;
    extractors.emplace_back(cam, p);
  }
  cv::setNumThreads(1);  // the stage's cost on one core

  cv::RNG rng(20230321);
  const cv::Mat ground = make_ground(rng, cam.width_px + 400, cam.height_px + 300);
  std::vector<std::vector<double>> ms(widths.size());
  std::vector<int> valid(widths.size(), 0);
  std::vector<double> points(widths.size(), 0.0);
  // Warm-up (allocations, page faults) on one frame, not timed.
  {
    const cv::Mat f = make_frame(rng, ground, cam.width_px, cam.height_px);
    for (const auto& ex : extractors) ex.extract(f);
  }
  for (int i = 0; i < n; ++i) {
    const cv::Mat frame = make_frame(rng, ground, cam.width_px, cam.height_px);
    for (std::size_t k = 0; k < extractors.size(); ++k) {
      const auto t0 = std::chrono::steady_clock::now();
      const PathObservation obs = extractors[k].extract(frame);
      ms[k].push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      valid[k] += obs.valid;
      points[k] += obs.points_px.size();
    }
  }

  const auto width_json = [&](std::size_t k) {
    nlohmann::ordered_json j;
    j["work_width_px"] = widths[k];
    j["work_height_px"] = static_cast<int>(std::lround(double(cam.height_px) * widths[k] / cam.width_px));
    j["ms_per_frame"] = summary_json(ms[k]);
    j["valid_fraction"] = double(valid[k]) / n;
    j["points_per_frame_mean"] = points[k] / n;
    return j;
  };
  nlohmann::ordered_json j;
  j["bench"] = "path";
  j["frames"] =
      "synthetic: " + std::to_string(n) + " frames " + std::to_string(cam.width_px) + "x" +
      std::to_string(cam.height_px) +
      " (no renderer): asphalt-like noisy grey ground, a red route (BGR 31,31,255 = rgba "
      "0.85,0.1,0.1 lit by the world's sun + ambient) of random shape (polyline with 1-3 "
      "corners of 30-140 deg, or an arc of radius 200-700 px), width 20-52 px, random position "
      "and heading, anti-aliased, sensor noise sigma 4; seed 20230321";
  j["frame_count"] = n;
  j["image"] = {{"width_px", cam.width_px}, {"height_px", cam.height_px}};
  j["calibration"] = models_dir() + "/camera_default.yaml";
  j["params"] = "PathExtractorParams defaults except work_width_px";
  const nlohmann::ordered_json main_j = width_json(0);
  j["work_width_px"] = main_j["work_width_px"];
  j["work_height_px"] = main_j["work_height_px"];
  j["ms_per_frame"] = main_j["ms_per_frame"];
  j["valid_fraction"] = main_j["valid_fraction"];
  j["points_per_frame_mean"] = main_j["points_per_frame_mean"];
  j["ms_per_frame_all"] = ms[0];
  nlohmann::ordered_json sweep = nlohmann::ordered_json::array();
  std::vector<std::size_t> order(widths.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return widths[x] < widths[y]; });
  for (std::size_t k : order) sweep.push_back(width_json(k));
  j["sweep"] = sweep;
  j["threads"] = 1;
  struct utsname u {};
  nlohmann::ordered_json machine;
  if (uname(&u) == 0) {
    machine["sysname"] = u.sysname;
    machine["release"] = u.release;
    machine["version"] = u.version;
    machine["machine"] = u.machine;
  }
  machine["cpu_model"] = cpu_model();
  machine["cores"] = std::max(1u, std::thread::hardware_concurrency());
  j["machine"] = machine;
  std::string cmd = "lander bench path";
  for (const auto& s : args) cmd += " " + s;
  j["command_line"] = cmd;
  sim::write_json_file(a.value("json"), j);

  const auto& m = main_j["ms_per_frame"];
  std::printf("bench path: %d synthetic frames %dx%d, work %dx%d: %.2f ms mean, %.2f median, "
              "%.2f p95, %.2f max per frame (1 thread); sweep",
              n, cam.width_px, cam.height_px, widths[0], main_j["work_height_px"].get<int>(),
              m["mean"].get<double>(), m["median"].get<double>(), m["p95"].get<double>(),
              m["max"].get<double>());
  for (const auto& s : sweep)
    std::printf(" %d:%.2f", s["work_width_px"].get<int>(), s["ms_per_frame"]["median"].get<double>());
  std::printf(" ms median -> %s\n", a.value("json").c_str());
  return kExitOk;
}

const LanderCommand reg("path", "path --json FILE [--frames N] [--work-width PX]", Kind::Bench,
                        bench_path);

}  // namespace
}  // namespace lander::cli
