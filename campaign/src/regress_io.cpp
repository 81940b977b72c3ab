// The gate's inputs and the baseline's files: thresholds.yaml, a merged campaign's
// campaign.json and campaign.csv, and `lander regress --accept`.
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "lander/campaign/csv.h"
#include "lander/campaign/regress.h"
#include "lander/core/params_io.h"
#include "lander/sim/util/output_files.h"

namespace lander::campaign {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace {

constexpr double kDefaultMaxUnpairedShare = 0.05;

std::string join(const std::vector<std::string>& v, const std::string& sep) {
  std::string out;
  for (std::size_t i = 0; i < v.size(); ++i) out += (i ? sep : "") + v[i];
  return out;
}

// ---- thresholds.yaml ----

// `limit:` of an entry: a finite number >= 0 (and <= 1 for a share).
double read_limit(const YAML::Node& v, const std::string& key, const std::string& where) {
  double x = NAN;
  try {
    if (v.IsScalar()) x = v.as<double>();
  } catch (const YAML::Exception&) {
  }
  if (!std::isfinite(x)) {
    throw ConfigError(fmt::format("{}: '{}.limit' must be a number, got '{}'", where, key,
                                  v.IsScalar() ? v.Scalar() : std::string("a list or mapping")));
  }
  if (x < 0) throw ConfigError(fmt::format("{}: '{}.limit' must be >= 0, got {}", where, key, x));
  if (key == "unpaired_runs_max_share" && x > 1) {
    throw ConfigError(
        fmt::format("{}: '{}.limit' is a share of the runs, in [0, 1]; got {}", where, key, x));
  }
  return x;
}

// `reason:` of an entry: a non-blank string.
std::string read_reason(const YAML::Node& v, const std::string& key, const std::string& where) {
  const std::string s = v.IsScalar() ? v.Scalar() : "";
  if (s.find_first_not_of(" \t\r\n") == std::string::npos) {
    throw ConfigError(fmt::format(
        "{}: '{}.reason' must be a sentence saying why the limit is set there", where, key));
  }
  return s;
}

// One entry `key: {limit: L, reason: "..."}`; `where` is the key's file:line.
Threshold read_threshold(const YAML::Node& v, const std::string& key, const std::string& where,
                         const std::string& file) {
  if (!v.IsMap()) {
    throw ConfigError(
        fmt::format("{}: '{}' must be a mapping {{limit: L, reason: \"...\"}}", where, key));
  }
  Threshold t;
  t.where = where;
  bool has_limit = false, has_reason = false;
  for (auto it = v.begin(); it != v.end(); ++it) {
    const std::string sub = it->first.as<std::string>();
    const std::string w = yaml_where(it->first, file);
    if (sub == "limit") {
      t.limit = read_limit(it->second, key, w);
      has_limit = true;
    } else if (sub == "reason") {
      t.reason = read_reason(it->second, key, w);
      has_reason = true;
    } else {
      throw ConfigError(
          fmt::format("{}: unknown key '{}.{}' (an entry has 'limit' and 'reason')", w, key, sub));
    }
  }
  if (!has_limit) throw ConfigError(fmt::format("{}: '{}' has no 'limit'", where, key));
  if (!has_reason) {
    throw ConfigError(fmt::format(
        "{}: '{}' has no 'reason' (every threshold says why it is set there)", where, key));
  }
  return t;
}

// ---- campaign.csv ----

// The columns merge.cpp writes around the sampled inputs (which sit between the two lists).
const std::vector<std::string> kLeadingColumns = {"id",      "scenario", "seed",
                                                  "outcome", "landed",   "touchdown_offset_m"};
const std::vector<std::string> kTrailingColumns = {"touchdown_x_P_m",
                                                   "touchdown_y_P_m",
                                                   "touchdown_rel_speed_mps",
                                                   "touchdown_tilt_deg",
                                                   "time_to_land_s",
                                                   "wall_s",
                                                   "status",
                                                   "detail"};

// Reads cells of one record by column name, with file:line messages.
struct RowReader {
  const CsvTable& t;
  const CsvTable::Record& r;

  [[noreturn]] void fail(const std::string& col, const std::string& problem) const {
    throw ConfigError(fmt::format("{}:{}: column '{}': {}", t.source, r.line, col, problem));
  }
  const std::string& text(const std::string& col) const { return r.cells[t.column(col)]; }
  std::string required(const std::string& col) const {
    if (text(col).empty()) fail(col, "empty");
    return text(col);
  }
  // A number, or NaN for an empty cell.
  double number(const std::string& col) const {
    const std::string& s = text(col);
    if (s.empty()) return NAN;
    char* end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (end != s.c_str() + s.size() || std::isspace(static_cast<unsigned char>(s[0]))) {
      fail(col, "'" + s + "' is not a number");
    }
    return v;
  }
  std::uint64_t seed(const std::string& col) const {
    const std::string s = required(col);
    if (s.find_first_not_of("0123456789") != std::string::npos || s.size() > 20) {
      fail(col, "'" + s + "' is not a whole number");
    }
    return std::strtoull(s.c_str(), nullptr, 10);
  }
  bool flag(const std::string& col) const {
    const std::string& s = text(col);
    if (s != "0" && s != "1") fail(col, "'" + s + "' is neither 0 nor 1");
    return s == "1";
  }
};

// Checks the fixed columns are present and returns the sampled input columns between them.
std::vector<std::string> sampled_input_columns(const CsvTable& t) {
  std::vector<std::string> missing;
  for (const auto* list : {&kLeadingColumns, &kTrailingColumns}) {
    for (const std::string& c : *list) {
      if (t.column(c) < 0) missing.push_back(c);
    }
  }
  if (!missing.empty()) {
    throw ConfigError(t.source + ":1: not a campaign.csv of `lander campaign report`: no column " +
                      join(missing, ", "));
  }
  const int first = t.column("touchdown_offset_m") + 1, last = t.column("touchdown_x_P_m");
  return std::vector<std::string>(t.header.begin() + first,
                                  t.header.begin() + std::max(first, last));
}

RunResult read_run(const CsvTable& t, const CsvTable::Record& rec,
                   const std::vector<std::string>& inputs) {
  const RowReader c{t, rec};
  RunResult r;
  r.line = rec.line;
  r.id = c.required("id");
  r.scenario = c.required("scenario");
  r.seed = c.seed("seed");
  r.outcome = c.text("outcome");
  r.landed = c.flag("landed");
  r.offset_m = c.number("touchdown_offset_m");
  r.x_P_m = c.number("touchdown_x_P_m");
  r.y_P_m = c.number("touchdown_y_P_m");
  r.rel_speed_mps = c.number("touchdown_rel_speed_mps");
  r.tilt_deg = c.number("touchdown_tilt_deg");
  r.time_to_land_s = c.number("time_to_land_s");
  r.wall_s = c.number("wall_s");
  r.status = c.required("status");
  r.detail = c.text("detail");
  for (const std::string& col : inputs) r.inputs.emplace_back(col, c.text(col));
  return r;
}

json read_json_object(const std::string& path, const std::string& hint) {
  if (!fs::exists(path)) throw ConfigError(path + ": not found; " + hint);
  json j;
  try {
    j = json::parse(sim::read_file_text(path));
  } catch (const json::exception& e) {
    throw ConfigError(path + ": not valid JSON (" + e.what() + ")");
  }
  if (!j.is_object()) throw ConfigError(path + ": not a JSON object");
  return j;
}

const char* kDefaultThresholds =
    R"(# Thresholds of the statistical regression gate (`lander regress CURRENT --baseline THIS_DIR`).
# Each entry is {limit: L, reason: "why L"}; a check whose key is absent is not made. A check
# fails only with confidence: a growth when the paired difference (current - baseline) is above
# its limit AND the difference's paired bootstrap 95 % interval lies wholly above 0; the landing
# rate when the 95 % interval of its difference (Newcombe, paired) lies wholly below -limit
# points. Every check is made overall and, when the campaign has several scenarios, per
# scenario. `lander regress --accept` replaces the baseline's results and keeps this file.
landing_rate_drop_points:
  limit: 2.0
  reason: "Landing is the stack's job: two points fewer landings is a loss a user notices, and smaller drops are within what a campaign of a few hundred runs can resolve."
offset_p95_growth_m:
  limit: 0.01
  reason: "The p95 offset is judged against the campaign's 10 cm offset limit; 1 cm more uses a tenth of that margin."
offset_median_growth_m:
  limit: 0.01
  reason: "The typical touchdown 1 cm further from the centre is a systematic change of the estimator or controller, not run-to-run spread."
rel_speed_median_growth_mps:
  limit: 0.1
  reason: "A harder touchdown loads the landing gear and the platform; 0.1 m/s more in the median is a change of the touchdown phase."
time_to_land_median_growth_s:
  limit: 5.0
  reason: "Five seconds more to land in the median means more searching, recoveries or go-arounds: battery spent and closer to the 60 s run limit."
simulator_failures_increase:
  limit: 0
  reason: "A crash, error, hang or divergence of the simulator is a bug of the tree under test, never an acceptable landing outcome."
unpaired_runs_max_share:
  limit: 0.05
  reason: "Runs complete in only one campaign are left out of the comparison; leaving out more than 5 % could hide a regression in the missing runs."
)";

}  // namespace

// ---- Thresholds ----

const std::vector<std::string>& Thresholds::keys() {
  static const std::vector<std::string> k = {
      "landing_rate_drop_points",    "offset_p95_growth_m",          "offset_median_growth_m",
      "rel_speed_median_growth_mps", "time_to_land_median_growth_s", "simulator_failures_increase",
      "unpaired_runs_max_share"};
  return k;
}

Thresholds Thresholds::load(const std::string& path) {
  const YAML::Node root = load_yaml_file(path);
  if (!root || root.IsNull())
    throw ConfigError(path + ": empty; expected thresholds (key: {limit: L, reason: \"...\"})");
  if (!root.IsMap())
    throw ConfigError(yaml_where(root, path) + ": expected a mapping of thresholds");
  Thresholds t;
  t.file = path;
  for (auto it = root.begin(); it != root.end(); ++it) {
    const std::string key = it->first.as<std::string>();
    const std::string where = yaml_where(it->first, path);
    if (std::find(keys().begin(), keys().end(), key) == keys().end()) {
      throw ConfigError(
          fmt::format("{}: unknown key '{}' (known: {})", where, key, join(keys(), ", ")));
    }
    if (t.items.count(key)) {
      throw ConfigError(
          fmt::format("{}: '{}' appears twice (first at {})", where, key, t.items[key].where));
    }
    t.items[key] = read_threshold(it->second, key, where, path);
  }
  return t;
}

std::string Thresholds::default_yaml() { return kDefaultThresholds; }

const Threshold* Thresholds::find(const std::string& key) const {
  const auto it = items.find(key);
  return it == items.end() ? nullptr : &it->second;
}

double Thresholds::max_unpaired_share() const {
  const Threshold* t = find("unpaired_runs_max_share");
  return t ? t->limit : kDefaultMaxUnpairedShare;
}

// ---- CampaignResults ----

CampaignResults CampaignResults::load(const std::string& dir) {
  const std::string hint =
      "is " + dir + " a merged campaign (`lander campaign report DIR` writes it)?";
  CampaignResults c;
  c.dir = dir;
  c.summary = read_json_object(dir + "/campaign.json", hint);
  const std::string csv_path = dir + "/campaign.csv";
  if (!fs::exists(csv_path)) throw ConfigError(csv_path + ": not found; " + hint);
  const CsvTable t = read_csv_file(csv_path);
  c.input_columns = sampled_input_columns(t);
  std::map<std::string, int> lines;
  for (const CsvTable::Record& rec : t.records) {
    RunResult r = read_run(t, rec, c.input_columns);
    const auto [it, fresh] = lines.emplace(r.id, r.line);
    if (!fresh)
      throw ConfigError(
          fmt::format("{}:{}: id '{}' also at line {}", csv_path, r.line, r.id, it->second));
    c.runs.push_back(std::move(r));
  }
  return c;
}

// ---- accept ----

AcceptResult accept_baseline(const std::string& current_dir, const std::string& baseline_dir) {
  std::error_code ec;
  if (fs::exists(baseline_dir) && fs::equivalent(current_dir, baseline_dir, ec)) {
    throw ConfigError(baseline_dir + " is the current campaign's own directory");
  }
  // Everything is read and checked before anything is written.
  const CampaignResults cur = CampaignResults::load(current_dir);
  const json& s = cur.summary;
  const std::size_t missing =
      s.contains("missing") && s["missing"].is_array() ? s["missing"].size() : 0;
  if (missing > 0) {
    throw ConfigError(fmt::format(
        "{}: {} planned runs are not complete; finish the campaign (the same "
        "`lander campaign run` resumes it) and merge it before accepting it as a baseline",
        current_dir, missing));
  }
  if (s.contains("runs_complete") && s["runs_complete"].is_number_integer() &&
      s["runs_complete"].get<std::size_t>() != cur.runs.size()) {
    throw ConfigError(fmt::format(
        "{}: campaign.json counts {} complete runs, campaign.csv has {}; merge again "
        "(lander campaign report {})",
        current_dir, s["runs_complete"].get<std::size_t>(), cur.runs.size(), current_dir));
  }
  read_json_object(current_dir + "/plan.json", "the campaign's plan is needed in the baseline");
  std::vector<std::pair<std::string, std::string>> files;
  for (const char* f : {"campaign.csv", "campaign.json", "plan.json", "campaign.yaml"}) {
    const std::string p = current_dir + "/" + f;
    if (std::string(f) == "campaign.yaml" && !fs::exists(p)) continue;  // older campaigns
    files.emplace_back(f, sim::read_file_text(p));
  }
  AcceptResult res;
  res.thresholds_path = baseline_dir + "/thresholds.yaml";
  const bool had_thresholds = fs::exists(res.thresholds_path);
  if (had_thresholds) Thresholds::load(res.thresholds_path);  // a broken file is not kept silently
  fs::create_directories(baseline_dir);
  for (const auto& [name, text] : files) {
    sim::write_file_atomic(baseline_dir + "/" + name, text);
    res.copied.push_back(baseline_dir + "/" + name);
  }
  if (!had_thresholds) {
    sim::write_file_atomic(res.thresholds_path, Thresholds::default_yaml());
    res.thresholds_written = true;
  }
  return res;
}

}  // namespace lander::campaign
