#include "lander/campaign/merge.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <fmt/format.h>

#include "lander/campaign/stats.h"
#include "lander/core/params_io.h"
#include "lander/sim/util/output_files.h"
#include "lander/sim/util/process.h"
#include "yaml_json.h"

namespace lander::campaign {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace {

// One completed run as the merge sees it.
struct Row {
  std::string id, scenario, status, outcome, detail;
  std::uint64_t seed{0};
  bool landed{false};
  double offset{NAN}, x_P{NAN}, y_P{NAN}, speed{NAN}, tilt{NAN}, time{NAN}, wall{NAN};
  json sampled;  // key -> value
  // Path following (summary.json path_following, worlds with a route; NaN where null).
  bool has_path{false}, path_covered{false};
  double xt_mean{NAN}, xt_p95{NAN}, xt_max_cap{NAN}, cover_t{NAN}, target_share{NAN};
  // Who flew (run.json's flight_software; empty where the run wrote none).
  std::string fs_name, fs_version, fs_sha256;
  // A moving deck (summary.json touchdown's deck figures at first contact, and the chosen
  // touchdown instant: the last deck_cut event; NaN where there is none).
  bool has_deck{false};
  double rel_vz{NAN}, deck_tilt{NAN}, deck_heave{NAN}, deck_vz{NAN}, contact_t{NAN}, deck_cut_t{NAN};
  std::string contact_mode;
};

// "name version" of a run's flight software, "" when unknown.
std::string flight_software_label(const Row& r) {
  return r.fs_name.empty() ? std::string() : r.fs_name + (r.fs_version.empty() ? "" : " " + r.fs_version);
}

// The path-following columns of campaign.csv and their values (campaigns with a route only).
const std::vector<std::string> kPathColumns = {"path_covered", "path_time_to_cover_s",
                                               "path_cross_track_mean_m", "path_cross_track_p95_m",
                                               "path_cross_track_max_after_capture_m",
                                               "path_target_share"};
// Moving-deck campaigns' columns (after the path-following ones).
const std::vector<std::string> kDeckColumns = {"touchdown_rel_vertical_speed_mps", "touchdown_deck_tilt_deg",
                                               "touchdown_deck_heave_m", "touchdown_deck_vz_mps", "contact_t_s",
                                               "contact_mode", "deck_cut_t_s"};

double num(const json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return NAN;
  return j[key].get<double>();
}

// The deck figures of summary.json (its touchdown block with deck_tilt_deg, the deck_cut
// events of landing_decision) into r.
void read_deck_figures(const json& s, Row* r) {
  if (!s.contains("touchdown") || !s["touchdown"].is_object() || !s["touchdown"].contains("deck_tilt_deg")) return;
  const json& td = s["touchdown"];
  r->has_deck = true;
  r->rel_vz = num(td, "rel_vertical_speed_mps");
  r->deck_tilt = num(td, "deck_tilt_deg");
  r->deck_heave = num(td, "deck_heave_m");
  r->deck_vz = num(td, "deck_vz_mps");
  r->contact_t = num(td, "t_s");
  if (td.contains("mode_at_contact") && td["mode_at_contact"].is_string()) r->contact_mode = td["mode_at_contact"];
  if (s.contains("landing_decision") && s["landing_decision"].is_object() &&
      s["landing_decision"].contains("events") && s["landing_decision"]["events"].is_array()) {
    for (const json& e : s["landing_decision"]["events"]) {
      if (e.is_object() && e.value("what", "") == "deck_cut") r->deck_cut_t = num(e, "t_s");
    }
  }
}

json stat_block(const std::vector<double>& x, bool with_p95_ci) {
  json s;
  s["n"] = x.size();
  auto v = [](double d) { return std::isfinite(d) ? json(d) : json(nullptr); };
  s["mean"] = v(mean(x));
  s["median"] = v(quantile(x, 0.5));
  s["p95"] = v(quantile(x, 0.95));
  s["max"] = x.empty() ? json(nullptr) : json(*std::max_element(x.begin(), x.end()));
  if (with_p95_ci) {
    const Interval ci = bootstrap95(x, [](const std::vector<double>& s) { return quantile(s, 0.95); });
    s["p95_ci95"] = x.empty() ? json(nullptr) : json::array({ci.lo, ci.hi});
  }
  return s;
}

json group_stats(const std::vector<const Row*>& rows) {
  json g;
  int landed = 0, landing_failures = 0, sim_failures = 0;
  std::map<std::string, int> outcomes;
  std::vector<double> off, speed, tilt, time;
  for (const Row* r : rows) {
    ++outcomes[r->outcome];
    if (r->status != "ok") {
      ++sim_failures;
      continue;
    }
    if (!r->landed) {
      ++landing_failures;
      continue;
    }
    ++landed;
    if (std::isfinite(r->offset)) off.push_back(r->offset);
    if (std::isfinite(r->speed)) speed.push_back(r->speed);
    if (std::isfinite(r->tilt)) tilt.push_back(r->tilt);
    if (std::isfinite(r->time)) time.push_back(r->time);
  }
  const int n = static_cast<int>(rows.size());
  g["runs"] = n;
  g["landed"] = landed;
  // The landing rate counts the runs the simulator completed: a simulator failure says nothing
  // about the landing stack and is counted apart.
  const int valid = n - sim_failures;
  const Interval ci = wilson95(landed, valid);
  g["landing_rate"] = {{"value", valid > 0 ? json(static_cast<double>(landed) / valid) : json(nullptr)},
                       {"ci95", json::array({ci.lo, ci.hi})},
                       {"of_runs", valid}};
  g["landing_failures"] = landing_failures;
  g["simulator_failures"] = sim_failures;
  json oc = json::object();
  for (const auto& [k, v] : outcomes) oc[k] = v;
  g["outcomes"] = oc;
  g["touchdown_offset_m"] = stat_block(off, true);
  g["touchdown_rel_speed_mps"] = stat_block(speed, false);
  g["touchdown_tilt_deg"] = stat_block(tilt, false);
  g["time_to_land_s"] = stat_block(time, false);
  // Path following (seed 003), over the completed runs with a route: how many covered their
  // route and ended at it, and the cross-track figures' distributions over the runs.
  std::vector<double> xt_mean, xt_p95, xt_cap, cover_t;
  int with_path = 0, covered = 0, route_end = 0;
  for (const Row* r : rows) {
    if (r->status != "ok" || !r->has_path) continue;
    ++with_path;
    if (r->path_covered) ++covered;
    if (r->outcome == "route_end") ++route_end;
    for (auto [v, out] : {std::pair<double, std::vector<double>*>{r->xt_mean, &xt_mean},
                          {r->xt_p95, &xt_p95}, {r->xt_max_cap, &xt_cap}, {r->cover_t, &cover_t}}) {
      if (std::isfinite(v)) out->push_back(v);
    }
  }
  if (with_path > 0) {
    g["path_following"] = {{"runs", with_path},
                           {"covered", covered},
                           {"route_end", route_end},
                           {"time_to_cover_s", stat_block(cover_t, false)},
                           {"cross_track_mean_m", stat_block(xt_mean, false)},
                           {"cross_track_p95_m", stat_block(xt_p95, false)},
                           {"cross_track_max_after_capture_m", stat_block(xt_cap, false)}};
  }
  return g;
}

std::string cell(double v) { return std::isfinite(v) ? fmt::format("{}", v) : ""; }

// Input columns: each sampled key flattened ("key" or "key[i]").
std::vector<std::string> input_columns(const json& keys, const std::vector<Row>& rows) {
  std::vector<std::string> cols;
  for (const auto& k : keys) {
    const std::string key = k.get<std::string>();
    std::size_t width = 0;
    for (const Row& r : rows) {
      if (r.sampled.contains(key) && r.sampled[key].is_array()) width = std::max(width, r.sampled[key].size());
    }
    if (width == 0) {
      cols.push_back(key);
    } else {
      for (std::size_t i = 0; i < width; ++i) cols.push_back(key + "[" + std::to_string(i) + "]");
    }
  }
  return cols;
}

json input_value(const Row& r, const std::string& col) {
  const auto b = col.find('[');
  if (b == std::string::npos) return r.sampled.contains(col) ? r.sampled[col] : json(nullptr);
  const std::string key = col.substr(0, b);
  const std::size_t i = std::stoul(col.substr(b + 1));
  if (!r.sampled.contains(key) || !r.sampled[key].is_array() || i >= r.sampled[key].size()) return nullptr;
  return r.sampled[key][i];
}

json sensitivity(const std::vector<std::string>& cols, const std::vector<Row>& rows) {
  json out = json::array();
  std::vector<const Row*> ok;
  for (const Row& r : rows) {
    if (r.status == "ok") ok.push_back(&r);
  }
  for (const std::string& col : cols) {
    bool numeric = true;
    for (const Row* r : ok) numeric &= input_value(*r, col).is_number();
    json s;
    s["input"] = col;
    if (numeric) {
      std::vector<double> xin, off, xall, fail;
      for (const Row* r : ok) {
        const double v = input_value(*r, col).get<double>();
        xall.push_back(v);
        fail.push_back(r->landed ? 0.0 : 1.0);
        if (r->landed && std::isfinite(r->offset)) {
          xin.push_back(v);
          off.push_back(r->offset);
        }
      }
      auto corr = [](const Correlation& c) {
        return json{{"rho", std::isfinite(c.rho) ? json(c.rho) : json(nullptr)}, {"p", c.p}, {"n", c.n}};
      };
      s["kind"] = "numeric";
      s["n"] = ok.size();
      s["offset_spearman"] = corr(spearman(xin, off));
      s["failure_spearman"] = corr(spearman(xall, fail));
    } else {
      s["kind"] = "categorical";
      std::map<std::string, std::vector<const Row*>> levels;
      for (const Row* r : ok) levels[json_scalar_text(input_value(*r, col))].push_back(r);
      json lv = json::object();
      for (const auto& [name, rs] : levels) {
        std::vector<double> off;
        int landed = 0;
        for (const Row* r : rs) {
          if (r->landed) {
            ++landed;
            if (std::isfinite(r->offset)) off.push_back(r->offset);
          }
        }
        const double med = quantile(off, 0.5);
        lv[name] = {{"runs", rs.size()},
                    {"landed", landed},
                    {"landing_rate", static_cast<double>(landed) / static_cast<double>(rs.size())},
                    {"offset_median_m", std::isfinite(med) ? json(med) : json(nullptr)}};
      }
      s["levels"] = lv;
    }
    out.push_back(s);
  }
  return out;
}

}  // namespace

std::string shell_quote(const std::string& s) {
  const bool plain = !s.empty() && std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || std::string("/._-+=:,@").find(c) != std::string::npos;
  });
  if (plain) return s;
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

namespace {

// DIR/plan.json, checked: a mapping with a list of runs.
json read_plan(const std::string& dir) {
  const std::string plan_path = dir + "/plan.json";
  if (!fs::exists(plan_path)) {
    throw ConfigError(plan_path + ": not found; is " + dir + " a campaign directory (lander campaign run ... --out DIR)?");
  }
  json plan;
  try {
    plan = json::parse(sim::read_file_text(plan_path, true));
  } catch (const json::exception& e) {
    throw ConfigError(plan_path + ": unreadable (" + e.what() + ")");
  }
  if (!plan.is_object() || !plan.contains("runs") || !plan["runs"].is_array()) {
    throw ConfigError(plan_path + ": no 'runs' list");
  }
  return plan;
}

// Every planned run with a run.json, in plan order (the others listed in res.missing);
// `scenario_order` gets the scenario ids in their first appearance's order.
std::vector<Row> read_rows(const std::string& dir, const json& plan, MergeResult& res,
                           std::vector<std::string>& scenario_order) {
  std::vector<Row> rows;
  for (const json& p : plan["runs"]) {
    const std::string id = p.at("id").get<std::string>();
    const std::string scen = p.at("scenario").get<std::string>();
    if (std::find(scenario_order.begin(), scenario_order.end(), scen) == scenario_order.end()) {
      scenario_order.push_back(scen);
    }
    ++res.planned;
    const std::string rdir = dir + "/runs/" + id;
    json rec;
    try {
      rec = json::parse(sim::read_file_text(rdir + "/run.json", true));
    } catch (const json::exception&) {
      res.missing.push_back(id);
      continue;
    }
    Row r;
    r.id = id;
    r.scenario = scen;
    r.seed = p.at("seed").get<std::uint64_t>();
    r.sampled = p.value("sampled", json::object());
    r.status = rec.value("status", "error");
    r.outcome = rec.value("outcome", r.status);
    r.detail = rec.value("detail", "");
    r.landed = rec.value("landed", false);
    r.wall = num(rec, "wall_s");
    if (rec.contains("flight_software") && rec["flight_software"].is_object()) {
      const json& f = rec["flight_software"];
      r.fs_name = f.value("name", "");
      r.fs_version = f.value("version", "");
      if (f.contains("plugin_sha256") && f["plugin_sha256"].is_string()) r.fs_sha256 = f["plugin_sha256"].get<std::string>();
    }
    if (r.status == "ok") {
      try {
        const json s = json::parse(sim::read_file_text(rdir + "/summary.json", true));
        r.offset = num(s, "touchdown_offset_m");
        r.speed = num(s, "touchdown_rel_speed_mps");
        r.tilt = num(s, "touchdown_tilt_deg");
        r.time = num(s, "time_to_land_s");
        if (s.contains("touchdown") && s["touchdown"].contains("offset_P_m") &&
            s["touchdown"]["offset_P_m"].is_array() && s["touchdown"]["offset_P_m"].size() == 2) {
          r.x_P = s["touchdown"]["offset_P_m"][0].get<double>();
          r.y_P = s["touchdown"]["offset_P_m"][1].get<double>();
        }
        read_deck_figures(s, &r);
        if (s.contains("path_following") && s["path_following"].is_object()) {
          const json& pf = s["path_following"];
          r.has_path = true;
          r.path_covered = pf.value("covered", false);
          r.cover_t = num(pf, "time_to_cover_s");
          r.xt_mean = num(pf, "cross_track_mean_m");
          r.xt_p95 = num(pf, "cross_track_p95_m");
          r.xt_max_cap = num(pf, "cross_track_max_after_capture_m");
          r.target_share = num(pf, "target_share");
        }
      } catch (const json::exception& e) {
        r.status = "error";
        r.outcome = "error";
        r.landed = false;
        r.detail = std::string("summary.json unreadable at merge: ") + e.what();
      }
    }
    if (r.status != "ok") ++res.simulator_failures;
    rows.push_back(r);
  }
  res.complete = static_cast<int>(rows.size());
  return rows;
}

// campaign.csv: one row a run, the sampled inputs `cols` after the outcome.
void write_campaign_csv(const std::string& dir, const std::vector<std::string>& cols, const std::vector<Row>& rows) {
  // campaign.csv (the project's one CSV writer; numbers in their shortest exact form)
  std::vector<std::string> header = {"id", "scenario", "seed", "outcome", "landed", "touchdown_offset_m"};
  header.insert(header.end(), cols.begin(), cols.end());
  for (const char* c : {"touchdown_x_P_m", "touchdown_y_P_m", "touchdown_rel_speed_mps", "touchdown_tilt_deg",
                        "time_to_land_s", "wall_s", "status", "detail"}) {
    header.push_back(c);
  }
  // Campaigns with a route get the path-following columns at the end (others keep their
  // columns exactly).
  const bool any_path = std::any_of(rows.begin(), rows.end(), [](const Row& r) { return r.has_path; });
  // Who flew each run, then (campaigns with a route) the path-following columns.
  for (const char* c : {"flight_software", "flight_software_version", "flight_plugin_sha256"}) header.push_back(c);
  if (any_path) header.insert(header.end(), kPathColumns.begin(), kPathColumns.end());
  // Moving-deck campaigns get the deck's figures at the end (others keep their columns).
  const bool any_deck = std::any_of(rows.begin(), rows.end(), [](const Row& r) { return r.has_deck; });
  if (any_deck) header.insert(header.end(), kDeckColumns.begin(), kDeckColumns.end());
  sim::CsvWriter csv(dir + "/campaign.csv", header);
  for (const Row& r : rows) {
    csv.text(r.id).text(r.scenario).text(std::to_string(r.seed)).text(r.outcome).integer(r.landed ? 1 : 0)
        .text(cell(r.offset));
    for (const std::string& c : cols) csv.text(json_scalar_text(input_value(r, c)));
    csv.text(cell(r.x_P)).text(cell(r.y_P)).text(cell(r.speed)).text(cell(r.tilt)).text(cell(r.time))
        .text(cell(r.wall)).text(r.status).text(r.detail);
    csv.text(r.fs_name).text(r.fs_version).text(r.fs_sha256);
    if (any_path) {
      csv.text(r.has_path ? (r.path_covered ? "1" : "0") : "").text(cell(r.cover_t)).text(cell(r.xt_mean))
          .text(cell(r.xt_p95)).text(cell(r.xt_max_cap)).text(cell(r.target_share));
    }
    if (any_deck) {
      csv.text(cell(r.rel_vz)).text(cell(r.deck_tilt)).text(cell(r.deck_heave)).text(cell(r.deck_vz))
          .text(cell(r.contact_t)).text(r.contact_mode).text(cell(r.deck_cut_t));
    }
    csv.end_row();
  }
  csv.commit();

}

// campaign.json's header, the flight softwares that flew and the statistics overall and per
// scenario.
json campaign_json(const json& plan, const MergeResult& res, const json& keys, const std::vector<Row>& rows,
                   const std::vector<std::string>& scenario_order) {
  json j;
  j["schema_version"] = 1;
  j["name"] = plan.value("name", "campaign");
  j["master_seed"] = plan.value("master_seed", json(nullptr));
  j["campaign_file"] = plan.value("campaign_file", "");
  j["offset_limit_m"] = plan.value("offset_limit_m", 0.10);
  j["runs_planned"] = res.planned;
  j["runs_complete"] = res.complete;
  j["missing"] = res.missing;
  j["dispersion_keys"] = keys;
  // The flight softwares that flew ("name version" -> runs; one entry unless mixed).
  json flown = json::object();
  for (const Row& r : rows) {
    const std::string who = flight_software_label(r);
    if (!who.empty()) flown[who] = flown.value(who, 0) + 1;
  }
  j["flight_software"] = flown;
  j["flight_plugin"] = plan.value("flight_plugin", json(nullptr));
  std::vector<const Row*> all;
  for (const Row& r : rows) all.push_back(&r);
  j["overall"] = group_stats(all);
  json per = json::object();
  for (const std::string& s : scenario_order) {
    std::vector<const Row*> g;
    for (const Row& r : rows) {
      if (r.scenario == s) g.push_back(&r);
    }
    per[s] = group_stats(g);
  }
  j["scenarios"] = per;
  return j;
}

// The ten worst runs (simulator failures, runs that did not land, then the largest offsets),
// each with the command that reruns it with videos.
json worst_runs(const std::vector<Row>& rows, const std::string& dir, const MergeOptions& o) {
  std::vector<const Row*> order;
  for (const Row& r : rows) order.push_back(&r);
  auto badness = [](const Row* r) { return r->status != "ok" ? 2 : (!r->landed ? 1 : 0); };
  std::stable_sort(order.begin(), order.end(), [&](const Row* a, const Row* b) {
    if (badness(a) != badness(b)) return badness(a) > badness(b);
    const double oa = std::isfinite(a->offset) ? a->offset : -1, ob = std::isfinite(b->offset) ? b->offset : -1;
    return oa > ob;
  });
  const std::string lander = o.lander_binary.empty() ? sim::self_executable() : o.lander_binary;
  const std::string abs_dir = fs::absolute(dir).lexically_normal().string();
  json worst = json::array();
  for (std::size_t i = 0; i < order.size() && i < 10; ++i) {
    const Row* r = order[i];
    json w;
    w["id"] = r->id;
    w["scenario"] = r->scenario;
    w["status"] = r->status;
    w["outcome"] = r->outcome;
    w["landed"] = r->landed;
    w["touchdown_offset_m"] = std::isfinite(r->offset) ? json(r->offset) : json(nullptr);
    w["detail"] = r->detail;
    w["rerun"] = shell_quote(lander) + " run " +
                 shell_quote(abs_dir + "/runs/" + r->id + "/scenario.resolved.yaml") + " --out " +
                 shell_quote(abs_dir + "/rerun/" + r->id) + " --video";
    worst.push_back(w);
  }
  return worst;
}

// report.html through tools/campaign_report.py.
void write_report_html(const std::string& dir, MergeResult& res) {
  const std::string script = std::string(LANDER_TOOLS_DIR) + "/campaign_report.py";
  try {
    sim::SpawnOptions so;
    so.stdout_to_null = true;
    sim::ChildProcess p = sim::ChildProcess::spawn({"python3", script, dir}, so);
    const sim::ExitStatus st = p.wait();
    res.html_written = st.ok();
    if (!st.ok()) res.html_error = script + " failed (" + st.describe() + ")";
  } catch (const std::exception& e) {
    res.html_error = e.what();
  }
}

}  // namespace

MergeResult merge_campaign(const std::string& dir, const MergeOptions& o) {
  const json plan = read_plan(dir);
  MergeResult res;
  std::vector<std::string> scenario_order;
  const std::vector<Row> rows = read_rows(dir, plan, res, scenario_order);
  const json keys = plan.value("dispersion_keys", json::array());
  const std::vector<std::string> cols = input_columns(keys, rows);
  write_campaign_csv(dir, cols, rows);
  json j = campaign_json(plan, res, keys, rows, scenario_order);
  j["worst_runs"] = worst_runs(rows, dir, o);
  j["sensitivity"] = sensitivity(cols, rows);
  res.campaign = j;
  sim::write_json_file(dir + "/campaign.json", j);
  if (o.html) write_report_html(dir, res);
  return res;
}

}  // namespace lander::campaign
