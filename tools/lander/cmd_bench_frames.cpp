// `lander bench frames --frames DIR --profile FRAMES.csv --json FILE [--scenario FILE]
// [--csv FILE] [--baseline CSV]`: the ring detector, with tracking, over a landing's saved
// camera frames (`lander bench loop --save-frames DIR --frames-csv FRAMES.csv`), each frame
// with the blur the flight software predicted for it in the loop. The same frames and blur
// every time, so a change of the detector is measured on the same input: thread CPU per frame
// by frame class (tracked: the predicted region gave the pose; code: the code map searched;
// acquisition: neither) with the wall time of each stage (predicted region, fallback passes,
// code map, checks), detections, and with --baseline (an earlier --csv) the detections
// gained and lost and the largest pose difference where both detect.
#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <map>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>

#include "command.h"
#include "lander/campaign/csv.h"
#include "lander/estimator/target.h"
#include "lander/estimator/vision_detector.h"
#include "lander/sim/scenario.h"
#include "lander/sim/util/output_files.h"

namespace lander::cli {
namespace {

// One saved frame and the blur the loop gave the detector with it.
struct SavedFrame {
  int index{0};
  std::string png;
  Eigen::Vector2d blur_px{Eigen::Vector2d::Zero()};
  double min_depth_m{0.0};  ///< the stack's least target depth (0: unknown)
};

// One frame's detection as the bench's CSV holds it.
struct FrameResult {
  int index{0};
  bool detected{false};
  std::string status, frame_class;
  Eigen::Vector3d p_CP{Eigen::Vector3d::Constant(std::nan(""))};
  Eigen::Vector4d q_CP{Eigen::Vector4d::Constant(std::nan(""))};  // w x y z
  int rings{0};
  double cpu_ms{0.0};
  RingDetection::StageTimes stage_ms;  // wall time by stage (RingDetection::stage_ms)
};

double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

const std::string& cell(const campaign::CsvTable& t, const campaign::CsvTable::Record& r,
                        const std::string& column) {
  const int c = t.column(column);
  if (c < 0) throw ConfigError(t.source + ": no column '" + column + "'");
  return r.cells[static_cast<std::size_t>(c)];
}

double number_cell(const campaign::CsvTable& t, const campaign::CsvTable::Record& r,
                   const std::string& column) {
  const std::string& s = cell(t, r, column);
  try {
    std::size_t used = 0;
    const double v = std::stod(s, &used);
    if (used == s.size()) return v;
  } catch (const std::exception&) {
  }
  throw ConfigError(fmt::format("{}:{}: column '{}': not a number: '{}'", t.source, r.line, column, s));
}

// The frames of `dir` that the profile lists, in its order, with their blur.
std::vector<SavedFrame> saved_frames(const std::string& dir, const std::string& profile_csv) {
  const campaign::CsvTable t = campaign::read_csv_file(profile_csv);
  std::vector<SavedFrame> frames;
  for (const auto& r : t.records) {
    SavedFrame f;
    f.index = static_cast<int>(number_cell(t, r, "frame"));
    f.png = fmt::format("{}/frame_{:05d}.png", dir, f.index);
    f.blur_px = {number_cell(t, r, "predicted_blur_x_px"), number_cell(t, r, "predicted_blur_y_px")};
    // Profiles written before the depth hint have no column: unknown, as those runs had it.
    if (t.column("min_depth_m") >= 0) f.min_depth_m = number_cell(t, r, "min_depth_m");
    if (!std::filesystem::is_regular_file(f.png)) {
      throw ConfigError(fmt::format("{}:{}: frame {} has no image {}", t.source, r.line, f.index, f.png));
    }
    frames.push_back(std::move(f));
  }
  if (frames.empty()) throw ConfigError(profile_csv + ": no frames listed");
  return frames;
}

std::string frame_class(const RingDetection& d) {
  if (d.used_roi) return "tracked";
  if (d.code_searched) return "code";
  return "acquisition";
}

FrameResult result_of(int index, const RingDetection& d, double cpu_ms) {
  FrameResult r;
  r.index = index;
  r.detected = d.detected;
  r.status = to_string(d.status);
  r.frame_class = frame_class(d);
  r.rings = static_cast<int>(d.centres.size());
  r.cpu_ms = cpu_ms;
  r.stage_ms = d.stage_ms;
  if (d.detected) {
    const Eigen::Quaterniond q(d.X_CP.linear());
    r.p_CP = d.X_CP.translation();
    r.q_CP = {q.w(), q.x(), q.y(), q.z()};
  }
  return r;
}

// The detector with the scenario's flight configuration over the frames, in order.
std::vector<FrameResult> detect_all(const sim::Scenario& s, const std::vector<SavedFrame>& frames) {
  const flight::FlightConfig& c = s.flight;
  RingTargetDetector detector(c.camera, TargetGeometry::load(c.target_path), c.estimator.vision);
  std::vector<FrameResult> out;
  for (const SavedFrame& f : frames) {
    const cv::Mat image = cv::imread(f.png, cv::IMREAD_COLOR);
    if (image.empty()) throw ConfigError("cannot read image: " + f.png);
    const double c0 = thread_cpu_ms();
    const RingDetection d = detector.detect(image, f.blur_px, f.min_depth_m);
    out.push_back(result_of(f.index, d, thread_cpu_ms() - c0));
  }
  return out;
}

void write_results_csv(const std::string& path, const std::vector<FrameResult>& results) {
  sim::CsvWriter w(path, {"frame", "detected", "status", "class", "rings", "cpu_ms", "px_m", "py_m",
                          "pz_m", "qw", "qx", "qy", "qz", "region_ms", "passes_ms", "code_ms",
                          "checks_ms"});
  for (const FrameResult& r : results) {
    w.integer(r.index).integer(r.detected ? 1 : 0).text(r.status).text(r.frame_class).integer(r.rings);
    w.num(r.cpu_ms, 3);
    for (int i = 0; i < 3; ++i) w.num(r.p_CP[i], 17);
    for (int i = 0; i < 4; ++i) w.num(r.q_CP[i], 17);
    const RingDetection::StageTimes& t = r.stage_ms;
    for (const double ms : {t.region_ms, t.passes_ms, t.code_ms, t.checks_ms}) w.num(ms, 3);
    w.end_row();
  }
  w.commit();
}

// Per class and over all frames: frames, detected, mean and worst thread CPU (ms), and the
// mean wall time of each stage (ms).
nlohmann::ordered_json cost_by_class(const std::vector<FrameResult>& results) {
  struct Sum {
    int frames{0}, detected{0};
    double cpu{0.0}, worst{0.0};
    RingDetection::StageTimes stages;
  };
  std::map<std::string, Sum> sums;
  for (const FrameResult& r : results) {
    for (const std::string& k : {std::string("all"), r.frame_class}) {
      Sum& s = sums[k];
      ++s.frames;
      s.detected += r.detected ? 1 : 0;
      s.cpu += r.cpu_ms;
      s.worst = std::max(s.worst, r.cpu_ms);
      s.stages += r.stage_ms;
    }
  }
  nlohmann::ordered_json j;
  for (const auto& [k, s] : sums) {
    const double n = s.frames;
    j[k] = {{"frames", s.frames}, {"detected", s.detected}, {"cpu_ms_mean", s.cpu / n},
            {"cpu_ms_total", s.cpu}, {"cpu_ms_worst", s.worst},
            {"stage_ms_mean", {{"region", s.stages.region_ms / n}, {"passes", s.stages.passes_ms / n},
                               {"code", s.stages.code_ms / n}, {"checks", s.stages.checks_ms / n}}}};
  }
  return j;
}

// The results against an earlier run's CSV of the same frames.
nlohmann::ordered_json against_baseline(const std::vector<FrameResult>& results, const std::string& path) {
  const campaign::CsvTable t = campaign::read_csv_file(path);
  std::map<int, const campaign::CsvTable::Record*> base;
  for (const auto& r : t.records) base[static_cast<int>(number_cell(t, r, "frame"))] = &r;
  int gained = 0, lost = 0, both = 0, missing = 0;
  double worst_p = 0.0, worst_q = 0.0, base_cpu = 0.0;
  std::vector<int> lost_frames;
  for (const FrameResult& r : results) {
    const auto it = base.find(r.index);
    if (it == base.end()) {
      ++missing;
      continue;
    }
    const auto& b = *it->second;
    base_cpu += number_cell(t, b, "cpu_ms");
    const bool was = number_cell(t, b, "detected") != 0;
    if (was && !r.detected) lost_frames.push_back(r.index);
    lost += was && !r.detected;
    gained += !was && r.detected;
    if (!(was && r.detected)) continue;
    ++both;
    const Eigen::Vector3d p{number_cell(t, b, "px_m"), number_cell(t, b, "py_m"), number_cell(t, b, "pz_m")};
    const Eigen::Vector4d q{number_cell(t, b, "qw"), number_cell(t, b, "qx"), number_cell(t, b, "qy"),
                            number_cell(t, b, "qz")};
    worst_p = std::max(worst_p, (p - r.p_CP).norm());
    worst_q = std::max(worst_q, std::min((q - r.q_CP).norm(), (q + r.q_CP).norm()));
  }
  return {{"baseline", path}, {"frames_not_in_baseline", missing}, {"detected_both", both},
          {"gained", gained}, {"lost", lost}, {"lost_frames", lost_frames},
          {"max_position_difference_m", worst_p}, {"max_quaternion_difference", worst_q},
          {"baseline_cpu_ms_mean", base_cpu / std::max<std::size_t>(1, results.size() - missing)}};
}

int bench_frames(const Args& args) {
  ArgParser a(args, {"frames", "profile", "json", "scenario", "csv", "baseline"}, {});
  if (!a.has("frames") || !a.has("profile") || !a.has("json")) {
    throw UsageError("usage: lander bench frames --frames DIR --profile FRAMES.csv --json FILE "
                     "[--scenario FILE] [--csv FILE] [--baseline CSV]");
  }
  const std::string scenario = a.value("scenario", std::string(LANDER_SCENARIOS_DIR) + "/default.yaml");
  const sim::Scenario s = sim::Scenario::load(scenario);
  const std::vector<SavedFrame> frames = saved_frames(a.value("frames"), a.value("profile"));
  const std::vector<FrameResult> results = detect_all(s, frames);
  if (a.has("csv")) write_results_csv(a.value("csv"), results);
  nlohmann::ordered_json j{{"scenario", scenario}, {"frames_dir", a.value("frames")},
                           {"cost_by_class", cost_by_class(results)}};
  if (a.has("baseline")) j["against_baseline"] = against_baseline(results, a.value("baseline"));
  sim::write_json_file(a.value("json"), j);
  std::cout << sim::json_text(j);
  return kExitOk;
}

const LanderCommand reg("frames",
                        "frames --frames DIR --profile FRAMES.csv --json FILE [--scenario FILE] [--csv FILE] "
                        "[--baseline CSV]",
                        Kind::Bench, bench_frames);

}  // namespace
}  // namespace lander::cli
