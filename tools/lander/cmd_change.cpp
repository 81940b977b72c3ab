// `lander change [--dir DIR] [--accept] [--record] [--keep WORK]`: the change-indication tier
// of the regression checks (issue 15, README "Regression of landing error").
//
// DIR (default regression/change/) holds cases.yaml and, per case, inputs and expected
// outputs committed to the repository:
//   replay/<name>/vision.csv      the vision results a full run delivered (exact, recorded)
//   replay/<name>/expected.json   key summary fields and a 2 Hz trace of truth and estimates of
//                                 the same scenario driven by vision.csv: dynamics, sensors,
//                                 fusion and controller, no rendering
//   frames/frame_NNNNN.png        golden camera frames (lossless)
//   frames/expected.json          what the detector makes of each (stateless, one frame)
// Without options it recomputes everything and compares with the expected files, printing
// every field that moved and by how much; exit 1 on any difference beyond the tolerances.
// --accept rewrites the expected files from the recomputation (a behaviour change becomes a
// reviewed diff in the commit). --record first re-records the inputs with full rendered runs
// (after a deliberate change of the scenarios, the renderer or the vision pipeline; also
// after a controller change, so that the recorded vision matches the new trajectory), then
// accepts. Rendering never enters the comparison: llvmpipe's JIT may differ in the last bit
// between CPUs, the recorded inputs do not.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "command.h"
#include "lander/campaign/csv.h"
#include "lander/estimator/target.h"
#include "lander/estimator/vision_detector.h"
#include "lander/sim/run.h"
#include "lander/sim/scenario.h"
#include "lander/sim/util/output_files.h"

namespace lander::cli {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

// Tolerances of the comparison. Recomputation on the same machine and build is bit-identical;
// between CPUs of the project's kind (Debian 12, x86-64) glibc's libm and OpenCV pick
// different SIMD code paths at run time, which may move the last bits. A real change of
// behaviour moves these outputs by millimetres or more.
constexpr double kSummaryTol = 1e-6;  ///< summary numbers (m, s, m/s, deg): 1 um / 1 us
constexpr double kTraceTol = 2e-5;    ///< trace numbers, written with 5 decimals: 2 units of
                                      ///< the last decimal (rounding of a value on the edge)
constexpr double kFrameTol = 1e-6;    ///< detector outputs (m, quaternion, px)

// Trace columns kept (2 Hz): truth, navigation, fused altitude, the controller's belief.
const std::vector<std::string> kTraceColumns = {
    "t_s", "mode", "x_WB_m", "y_WB_m", "z_WB_m", "yaw_rad", "nav_x_m", "nav_y_m", "nav_z_m",
    "fused_z_m", "ctl_platform_x_m", "ctl_platform_y_m", "sp_x_m", "sp_y_m", "sp_z_m", "w0_radps"};
// Summary fields kept.
const std::vector<std::string> kSummaryFields = {
    "outcome", "landed", "touchdown_offset_m", "touchdown_rel_speed_mps", "touchdown_tilt_deg",
    "time_to_land_s", "final_mode", "mode_transitions", "rejected_samples", "altitude_fusion"};

struct Case {
  std::string name;
  std::string scenario;  // absolute
};

struct Cases {
  std::vector<Case> replay;
  std::string frames_scenario;  // absolute
};

Cases load_cases(const std::string& dir) {
  const std::string file = dir + "/cases.yaml";
  const YAML::Node root = load_yaml_file(file);
  Cases c;
  const YAML::Node rep = root["replay"];
  if (!rep || !rep.IsSequence()) throw ConfigError(yaml_where(root, file) + ": 'replay' must be a list");
  for (const YAML::Node& n : rep) {
    if (!n.IsMap() || !n["name"] || !n["scenario"]) {
      throw ConfigError(yaml_where(n, file) + ": each replay case needs 'name' and 'scenario'");
    }
    c.replay.push_back({n["name"].as<std::string>(),
                        (fs::path(dir) / n["scenario"].as<std::string>()).lexically_normal().string()});
  }
  if (!root["frames_scenario"]) throw ConfigError(file + ": missing 'frames_scenario'");
  c.frames_scenario = (fs::path(dir) / root["frames_scenario"].as<std::string>()).lexically_normal().string();
  return c;
}

double to_double(const std::string& s) {
  if (s == "nan") return std::nan("");
  return std::stod(s);
}

// Key outputs of one run directory.
Json key_outputs(const std::string& run_dir) {
  const Json summary = Json::parse(sim::read_file_text(run_dir + "/summary.json"));
  Json out;
  Json keys = Json::object();
  for (const std::string& k : kSummaryFields) keys[k] = summary.at(k);
  out["summary"] = keys;
  const campaign::CsvTable t = campaign::read_csv_file(run_dir + "/trace.csv");
  std::vector<int> cols;
  for (const std::string& c : kTraceColumns) {
    const int i = t.column(c);
    if (i < 0) throw std::runtime_error(run_dir + "/trace.csv: no column " + c);
    cols.push_back(i);
  }
  Json rows = Json::array();
  for (std::size_t r = 0; r < t.records.size(); r += 50) {  // 100 Hz -> 2 Hz
    Json row = Json::array();
    for (std::size_t j = 0; j < cols.size(); ++j) {
      const std::string& cell = t.records[r].cells[cols[j]];
      if (kTraceColumns[j] == "mode") {
        row.push_back(cell);
      } else {
        row.push_back(to_double(cell));
      }
    }
    rows.push_back(row);
  }
  out["trace"] = {{"columns", kTraceColumns}, {"rows", rows}};
  return out;
}

Json detect_frames(const std::string& frames_dir, const flight::FlightConfig& fc) {
  const TargetGeometry target = TargetGeometry::load(fc.target_path);
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(frames_dir)) {
    if (e.path().extension() == ".png") files.push_back(e.path().filename().string());
  }
  std::sort(files.begin(), files.end());
  Json out = Json::array();
  for (const std::string& f : files) {
    const cv::Mat img = cv::imread(frames_dir + "/" + f, cv::IMREAD_COLOR);
    if (img.empty()) throw ConfigError(frames_dir + "/" + f + ": cannot read the image");
    const Json d = Json::parse(to_json(detect_ring_target(img, fc.camera, target, fc.estimator.vision)));
    Json j;
    j["file"] = f;
    for (const char* k : {"detected", "status", "source", "p_CP_m", "q_CP_wxyz", "reproj_err_px"}) j[k] = d.at(k);
    j["rings"] = d.at("centres").size();
    out.push_back(j);
  }
  return out;
}

// Compares expected with actual; appends one line per difference to `diffs`.
void compare(const Json& exp, const Json& act, const std::string& path, double tol,
             std::vector<std::string>& diffs) {
  if (exp.is_number() && act.is_number()) {
    const double a = exp.get<double>(), b = act.get<double>();
    if (std::isnan(a) && std::isnan(b)) return;
    if (!(std::abs(a - b) <= tol)) {
      diffs.push_back(fmt::format("{}: {:.9g} -> {:.9g} (moved {:+.3g}, tolerance {:g})", path, a, b, b - a, tol));
    }
    return;
  }
  if (exp.is_null() && act.is_number() && std::isnan(act.get<double>())) return;  // NaN written as null
  if (exp.type() != act.type()) {
    diffs.push_back(fmt::format("{}: {} -> {}", path, exp.dump(), act.dump()));
    return;
  }
  if (exp.is_object()) {
    for (auto it = exp.begin(); it != exp.end(); ++it) {
      if (!act.contains(it.key())) {
        diffs.push_back(path + "." + it.key() + ": missing");
        continue;
      }
      compare(it.value(), act.at(it.key()), path + "." + it.key(), tol, diffs);
    }
    for (auto it = act.begin(); it != act.end(); ++it) {
      if (!exp.contains(it.key())) diffs.push_back(path + "." + it.key() + ": new field");
    }
  } else if (exp.is_array()) {
    if (exp.size() != act.size()) {
      diffs.push_back(fmt::format("{}: {} entries -> {}", path, exp.size(), act.size()));
    }
    for (std::size_t i = 0; i < std::min(exp.size(), act.size()); ++i) {
      compare(exp[i], act[i], fmt::format("{}[{}]", path, i), tol, diffs);
    }
  } else if (exp != act) {
    diffs.push_back(fmt::format("{}: {} -> {}", path, exp.dump(), act.dump()));
  }
}

// Trace rows are compared by time and column name, so a message names both.
void compare_trace(const Json& exp, const Json& act, const std::string& name, std::vector<std::string>& diffs) {
  const Json& er = exp.at("rows");
  const Json& ar = act.at("rows");
  const Json& cols = exp.at("columns");
  if (cols != act.at("columns")) diffs.push_back(name + ".trace: columns changed");
  if (er.size() != ar.size()) diffs.push_back(fmt::format("{}.trace: {} rows -> {} (the run ended at another time)", name, er.size(), ar.size()));
  for (std::size_t r = 0; r < std::min(er.size(), ar.size()); ++r) {
    for (std::size_t c = 0; c < cols.size(); ++c) {
      compare(er[r][c], ar[r][c], fmt::format("{}.trace[t={}].{}", name, er[r][0].dump(), cols[c].get<std::string>()),
              kTraceTol, diffs);
    }
  }
}

int change(const Args& args) {
  ArgParser a(args, {"dir", "keep"}, {"accept", "record"});
  if (!a.positional().empty()) {
    throw UsageError("usage: lander change [--dir DIR] [--accept] [--record] [--keep WORK_DIR]");
  }
  const std::string dir = fs::absolute(a.value("dir", std::string(LANDER_MODELS_DIR) + "/../regression/change")).lexically_normal().string();
  const bool record = a.flag("record"), accept = a.flag("accept") || record;
  const Cases cases = load_cases(dir);
  std::string work = a.value("keep");
  const bool temp_work = work.empty();
  if (temp_work) {
    char tmpl[] = "/tmp/lander_change_XXXXXX";
    if (!mkdtemp(tmpl)) throw std::runtime_error("cannot create a temporary directory");
    work = tmpl;
  }
  fs::create_directories(work);
  const sim::Scenario frames_s = sim::Scenario::load(cases.frames_scenario);
  if (record) {
    // Inputs from full rendered runs.
    for (const Case& c : cases.replay) {
      fs::create_directories(dir + "/replay/" + c.name);
      sim::RunOptions o;
      o.out_dir = work + "/record_" + c.name;
      o.record_vision = dir + "/replay/" + c.name + "/vision.csv";
      std::cout << "lander change: recording " << c.name << " (rendered)\n" << std::flush;
      sim::run_scenario(sim::Scenario::load(c.scenario), o);
    }
    fs::create_directories(dir + "/frames");
    for (const auto& e : fs::directory_iterator(dir + "/frames")) {
      if (e.path().extension() == ".png") fs::remove(e.path());
    }
    sim::RunOptions o;
    o.out_dir = work + "/record_frames";
    o.save_frames_dir = dir + "/frames";
    sim::run_scenario(frames_s, o);
  }
  std::vector<std::string> diffs;
  int checked = 0;
  for (const Case& c : cases.replay) {
    sim::RunOptions o;
    o.out_dir = work + "/replay_" + c.name;
    o.replay_vision = dir + "/replay/" + c.name + "/vision.csv";
    sim::run_scenario(sim::Scenario::load(c.scenario), o);
    const Json actual = key_outputs(o.out_dir);
    const std::string expected_file = dir + "/replay/" + c.name + "/expected.json";
    if (accept) {
      sim::write_json_file(expected_file, actual);
    } else {
      const Json expected = Json::parse(sim::read_file_text(expected_file));
      compare(expected.at("summary"), actual.at("summary"), c.name + ".summary", kSummaryTol, diffs);
      compare_trace(expected.at("trace"), actual.at("trace"), c.name, diffs);
    }
    ++checked;
  }
  const Json frames = detect_frames(dir + "/frames", frames_s.flight);
  if (frames.empty()) throw ConfigError(dir + "/frames: no golden frame");
  if (accept) {
    sim::write_json_file(dir + "/frames/expected.json", frames);
  } else {
    compare(Json::parse(sim::read_file_text(dir + "/frames/expected.json")), frames, "frames", kFrameTol, diffs);
  }
  if (temp_work) fs::remove_all(work);
  if (accept) {
    std::cout << fmt::format("lander change: accepted {} replay cases and {} golden frames into {}\n", checked,
                             frames.size(), dir);
    return kExitOk;
  }
  for (const std::string& d : diffs) std::cout << "  moved: " << d << "\n";
  std::cout << fmt::format("lander change: {} replay cases, {} golden frames: {}\n", checked, frames.size(),
                           diffs.empty() ? "unchanged" : fmt::format("{} differences", diffs.size()));
  return diffs.empty() ? kExitOk : kExitFailure;
}

const LanderCommand reg("change",
                        "change [--dir DIR] [--accept] [--record] [--keep WORK]: change indication: "
                        "recompute fixed-seed outputs from recorded vision and golden frames, compare",
                        Kind::Command, change);

}  // namespace
}  // namespace lander::cli
