// The regression gate's comparison: pairing the runs, the paired statistics per group, the
// checks against the thresholds, and regress.json.
#include "lander/campaign/regress.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <map>
#include <set>

#include "lander/campaign/merge.h"
#include "lander/campaign/stats.h"
#include "lander/core/params_io.h"
#include "lander/sim/util/process.h"

namespace lander::campaign {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace {

// Fewer runs landed in both than this and a bootstrap interval says nothing (it collapses onto
// the few values there are): the metric's checks are then not evaluable. With n pairs whose
// differences are pure noise of either sign, an interval wholly above 0 needs (about) all n of
// them positive, probability 2^-n: 3 % at n = 5, 12 % at n = 3, too many false alarms below 5.
constexpr int kMinPairsForInterval = 5;
// At most this many ids are named in a message.
constexpr std::size_t kListedInMessage = 20;

struct Pair {
  const RunResult* base;
  const RunResult* cur;
};

// The result of matching the two campaigns' runs by id.
struct Pairing {
  std::vector<Pair> pairs;  ///< in the current campaign's order
  std::vector<std::string> only_current, only_baseline;
  std::vector<std::string> inputs_only_current, inputs_only_baseline;
  double unpaired_share{0.0};
};

json finite_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

json interval_or_null(const Interval& i) {
  return std::isfinite(i.lo) && std::isfinite(i.hi) ? json::array({i.lo, i.hi}) : json(nullptr);
}

// "a, b, c and 12 more".
std::string list_some(const std::vector<std::string>& ids) {
  std::string out;
  for (std::size_t i = 0; i < ids.size() && i < kListedInMessage; ++i)
    out += (i ? ", " : "") + ids[i];
  if (ids.size() > kListedInMessage)
    out += fmt::format(" and {} more", ids.size() - kListedInMessage);
  return out;
}

std::vector<std::string> columns_missing_in(const std::vector<std::string>& a,
                                            const std::vector<std::string>& b) {
  std::vector<std::string> out;
  for (const std::string& c : a) {
    if (std::find(b.begin(), b.end(), c) == b.end()) out.push_back(c);
  }
  return out;
}

const std::string* input_value(const RunResult& r, const std::string& col) {
  for (const auto& [k, v] : r.inputs) {
    if (k == col) return &v;
  }
  return nullptr;
}

// Why a pair with the same id is not the same run ("" when it is): scenario, seed, and the
// sampled inputs both campaigns have.
std::string pair_mismatch(const RunResult& b, const RunResult& c) {
  if (b.scenario != c.scenario) {
    return fmt::format("{}: scenario '{}' in the baseline, '{}' in the current campaign", c.id,
                       b.scenario, c.scenario);
  }
  if (b.seed != c.seed)
    return fmt::format("{}: seed {} in the baseline, {} in the current campaign", c.id, b.seed,
                       c.seed);
  for (const auto& [col, v] : c.inputs) {
    const std::string* bv = input_value(b, col);
    if (bv && *bv != v) {
      return fmt::format("{}: sampled {} = {} in the baseline, {} in the current campaign", c.id,
                         col, *bv, v);
    }
  }
  return "";
}

// Matches runs by id and refuses campaigns that are not the same runs (ConfigError).
Pairing pair_runs(const CampaignResults& base, const CampaignResults& cur,
                  double max_unpaired_share) {
  Pairing p;
  std::map<std::string, const RunResult*> by_id;
  for (const RunResult& r : base.runs) by_id[r.id] = &r;
  std::set<std::string> in_current;
  std::vector<std::string> mismatches;
  for (const RunResult& r : cur.runs) {
    in_current.insert(r.id);
    const auto it = by_id.find(r.id);
    if (it == by_id.end()) {
      p.only_current.push_back(r.id);
      continue;
    }
    const std::string why = pair_mismatch(*it->second, r);
    if (!why.empty()) mismatches.push_back(why);
    p.pairs.push_back({it->second, &r});
  }
  for (const RunResult& r : base.runs) {
    if (!in_current.count(r.id)) p.only_baseline.push_back(r.id);
  }
  if (!mismatches.empty()) {
    throw ConfigError(fmt::format(
        "{} and {} are not the same runs: {} of {} ids have another scenario, seed or sampled "
        "inputs:\n  {}\n"
        "a paired comparison needs both campaigns made from the same campaign file (scenarios, "
        "runs, master "
        "seed and dispersions)",
        cur.dir, base.dir, mismatches.size(), p.pairs.size(),
        fmt::join(mismatches.begin(),
                  mismatches.begin() + std::min(mismatches.size(), kListedInMessage), "\n  ")));
  }
  const std::size_t unpaired = p.only_current.size() + p.only_baseline.size();
  const std::size_t all = p.pairs.size() + unpaired;
  if (all == 0)
    throw ConfigError(cur.dir + " and " + base.dir + ": no runs in either campaign.csv");
  p.unpaired_share = static_cast<double>(unpaired) / static_cast<double>(all);
  if (p.pairs.empty() || p.unpaired_share > max_unpaired_share) {
    throw ConfigError(fmt::format(
        "the run sets differ: {} of {} ids are in one campaign only ({:.1f} %, more than the "
        "{:.1f} % "
        "unpaired_runs_max_share allows)\n  only in the current campaign ({}): {}\n  only in the "
        "baseline ({}): {}",
        unpaired, all, 100 * p.unpaired_share, 100 * max_unpaired_share, p.only_current.size(),
        list_some(p.only_current), p.only_baseline.size(), list_some(p.only_baseline)));
  }
  p.inputs_only_current = columns_missing_in(cur.input_columns, base.input_columns);
  p.inputs_only_baseline = columns_missing_in(base.input_columns, cur.input_columns);
  return p;
}

// ---- paired statistics of one group of pairs ----

// Landing rates over the pairs the simulator completed on both sides, and the Newcombe
// interval of their difference (stats.h).
json landing_block(const std::vector<Pair>& pairs) {
  int both = 0, only_base = 0, only_cur = 0, neither = 0;
  for (const Pair& p : pairs) {
    if (!p.base->simulator_ok() || !p.cur->simulator_ok()) continue;
    if (p.base->landed && p.cur->landed)
      ++both;
    else if (p.base->landed)
      ++only_base;
    else if (p.cur->landed)
      ++only_cur;
    else
      ++neither;
  }
  const int n = both + only_base + only_cur + neither;
  json j;
  j["pairs"] = n;
  const double rb = n ? static_cast<double>(both + only_base) / n : NAN;
  const double rc = n ? static_cast<double>(both + only_cur) / n : NAN;
  j["baseline"] = finite_or_null(rb);
  j["current"] = finite_or_null(rc);
  j["difference"] = finite_or_null(rc - rb);
  j["ci95"] =
      n ? interval_or_null(paired_proportion_difference95(both, only_base, only_cur, neither))
        : json(nullptr);
  j["counts"] = {{"landed_in_both", both},
                 {"landed_in_baseline_only", only_base},
                 {"landed_in_current_only", only_cur},
                 {"landed_in_neither", neither}};
  return j;
}

using Stat = std::function<double(const std::vector<double>&)>;

// One statistic of a metric on both sides, its difference and the paired bootstrap interval.
json stat_difference(const std::vector<double>& base, const std::vector<double>& cur,
                     const Stat& stat, const RegressOptions& o) {
  json j;
  const double b = base.empty() ? NAN : stat(base), c = cur.empty() ? NAN : stat(cur);
  j["baseline"] = finite_or_null(b);
  j["current"] = finite_or_null(c);
  j["difference"] = finite_or_null(c - b);
  j["ci95"] = static_cast<int>(base.size()) >= kMinPairsForInterval
                  ? interval_or_null(paired_bootstrap95(base, cur, stat, o.resamples, o.seed))
                  : json(nullptr);
  return j;
}

// A touchdown figure over the runs landed in both campaigns (and with a value in both).
json metric_block(const std::vector<Pair>& pairs, double RunResult::*field, bool with_p95,
                  const RegressOptions& o) {
  std::vector<double> base, cur;
  for (const Pair& p : pairs) {
    const RunResult &b = *p.base, &c = *p.cur;
    if (!b.simulator_ok() || !c.simulator_ok() || !b.landed || !c.landed) continue;
    if (!std::isfinite(b.*field) || !std::isfinite(c.*field)) continue;
    base.push_back(b.*field);
    cur.push_back(c.*field);
  }
  json j;
  j["n"] = base.size();
  j["median"] = stat_difference(
      base, cur, [](const std::vector<double>& x) { return quantile(x, 0.5); }, o);
  if (with_p95) {
    j["p95"] = stat_difference(
        base, cur, [](const std::vector<double>& x) { return quantile(x, 0.95); }, o);
  }
  return j;
}

// Everything the report holds for one group of pairs (a scenario, or all of them).
json compare_group(const std::vector<Pair>& pairs, const RegressOptions& o) {
  json g;
  int fail_b = 0, fail_c = 0, lost = 0, gained = 0;
  for (const Pair& p : pairs) {
    fail_b += !p.base->simulator_ok();
    fail_c += !p.cur->simulator_ok();
    if (p.base->simulator_ok() && p.cur->simulator_ok() && p.base->landed != p.cur->landed) {
      (p.base->landed ? lost : gained) += 1;
    }
  }
  g["runs"] = pairs.size();
  g["landing_rate"] = landing_block(pairs);
  g["touchdown_offset_m"] = metric_block(pairs, &RunResult::offset_m, true, o);
  g["touchdown_rel_speed_mps"] = metric_block(pairs, &RunResult::rel_speed_mps, false, o);
  g["time_to_land_s"] = metric_block(pairs, &RunResult::time_to_land_s, false, o);
  g["landed_to_not_landed"] = lost;
  g["not_landed_to_landed"] = gained;
  g["simulator_failures"] = {{"baseline", fail_b}, {"current", fail_c}};
  return g;
}

// ---- checks ----

// How a threshold reads its figure from a group and how it is shown.
struct CheckSpec {
  const char* key;
  const char* label;            ///< in messages
  std::vector<const char*> at;  ///< path of the {difference, ci95} object in the group
  const char* si_unit;          ///< unit of the statistic (and of the threshold, but points)
  const char* unit;             ///< unit shown in messages
  double scale;                 ///< shown = statistic * scale
};

const std::vector<CheckSpec>& check_specs() {
  static const std::vector<CheckSpec> s = {
      {"landing_rate_drop_points", "landing rate", {"landing_rate"}, "1", "points", 100.0},
      {"offset_p95_growth_m",
       "touchdown offset p95",
       {"touchdown_offset_m", "p95"},
       "m",
       "cm",
       100.0},
      {"offset_median_growth_m",
       "touchdown offset median",
       {"touchdown_offset_m", "median"},
       "m",
       "cm",
       100.0},
      {"rel_speed_median_growth_mps",
       "touchdown relative speed median",
       {"touchdown_rel_speed_mps", "median"},
       "m/s",
       "m/s",
       1.0},
      {"time_to_land_median_growth_s",
       "time to land median",
       {"time_to_land_s", "median"},
       "s",
       "s",
       1.0},
  };
  return s;
}

// The check of one statistical threshold on one group. Its value, interval and limit are in the
// threshold's unit (points for the landing rate, else the metric's SI unit).
json evaluate_check(const CheckSpec& spec, const Threshold& t, const std::string& group,
                    const json& g) {
  const json* d = &g;
  for (const char* k : spec.at) d = &d->at(k);
  const bool rate = std::string(spec.key) == "landing_rate_drop_points";
  const int n =
      rate ? g.at("landing_rate").at("pairs").get<int>() : g.at(spec.at[0]).at("n").get<int>();
  const double unit = rate ? 100.0 : 1.0;  // the threshold's unit per the statistic's
  json c;
  c["group"] = group;
  c["check"] = spec.key;
  c["status"] = "not_evaluable";
  c["value"] = nullptr;
  c["ci95"] = nullptr;
  c["limit"] = t.limit;
  c["unit"] = rate ? "points" : spec.si_unit;
  c["n"] = n;
  c["rule"] =
      rate ? "fails when the 95 % interval of (current - baseline) lies wholly below -limit"
           : "fails when (current - baseline) > limit and the 95 % interval's lower bound > 0";
  c["reason"] = t.reason;
  const std::string what = fmt::format("{}: {}", group, spec.label);
  const std::string over =
      rate ? fmt::format("{} pairs", n) : fmt::format("{} runs landed in both", n);
  if (d->at("difference").is_null() || d->at("ci95").is_null()) {
    c["message"] = fmt::format("{}: not evaluable over {} (at least {} are needed for an interval)",
                               what, over, rate ? 1 : kMinPairsForInterval);
    return c;
  }
  const double v = d->at("difference").get<double>() * unit;
  const double lo = d->at("ci95").at(0).get<double>() * unit,
               hi = d->at("ci95").at(1).get<double>() * unit;
  const bool fail = rate ? hi < -t.limit : (v > t.limit && lo > 0);
  c["status"] = fail ? "fail" : "pass";
  c["value"] = v;
  c["ci95"] = json::array({lo, hi});
  // Shown in the display unit (cm for offsets).
  const double s = spec.scale / unit;
  const std::string figure =
      fmt::format("{} changed by {:+.2f} {} (95 % interval {:+.2f} to {:+.2f}) over {}", what,
                  v * s, spec.unit, lo * s, hi * s, over);
  std::string verdict;
  if (rate) {
    verdict = fail ? fmt::format("the interval lies wholly below -{:.2f} points", t.limit)
                   : fmt::format("not wholly below -{:.2f} points", t.limit);
  } else if (fail) {
    verdict = fmt::format("above the limit {:.2f} {} and the interval excludes 0", t.limit * s,
                          spec.unit);
  } else {
    verdict = fmt::format("{} the limit {:.2f} {}{}", v > t.limit ? "above" : "within", t.limit * s,
                          spec.unit, v > t.limit ? " but the interval includes 0" : "");
  }
  c["message"] = figure + ": " + verdict;
  return c;
}

// The simulator-failure check: more failures in the current campaign than the limit allows.
json simulator_check(const Threshold& t, const json& overall) {
  const int b = overall.at("simulator_failures").at("baseline").get<int>();
  const int cur = overall.at("simulator_failures").at("current").get<int>();
  const bool fail = cur - b > t.limit;
  json c;
  c["group"] = "overall";
  c["check"] = "simulator_failures_increase";
  c["status"] = fail ? "fail" : "pass";
  c["value"] = cur - b;
  c["ci95"] = nullptr;
  c["limit"] = t.limit;
  c["unit"] = "runs";
  c["n"] = overall.at("runs");
  c["rule"] = "fails when (current - baseline) simulator failures over the paired runs > limit";
  c["reason"] = t.reason;
  c["message"] = fmt::format(
      "overall: simulator failures: {} in the baseline, {} in the current campaign ({:+d}): {} the "
      "limit {}",
      b, cur, cur - b, fail ? "above" : "within", t.limit);
  return c;
}

// Every configured check on the overall group and on each scenario (when there are several).
json evaluate_checks(const Thresholds& th, const json& overall, const json& scenarios,
                     std::vector<std::string>& failed) {
  json checks = json::array();
  std::vector<std::pair<std::string, const json*>> groups = {{"overall", &overall}};
  if (scenarios.size() > 1) {
    for (const auto& [name, g] : scenarios.items()) groups.emplace_back(name, &g);
  }
  for (const CheckSpec& spec : check_specs()) {
    const Threshold* t = th.find(spec.key);
    if (!t) continue;
    for (const auto& [name, g] : groups) checks.push_back(evaluate_check(spec, *t, name, *g));
  }
  if (const Threshold* t = th.find("simulator_failures_increase"))
    checks.push_back(simulator_check(*t, overall));
  for (const json& c : checks) {
    if (c.at("status") == "fail")
      failed.push_back(c.at("group").get<std::string>() + ": " + c.at("check").get<std::string>());
  }
  return checks;
}

// ---- runs worth a look ----

std::string rerun_command(const std::string& lander, const std::string& abs_dir,
                          const std::string& id) {
  return shell_quote(lander) + " run " +
         shell_quote(abs_dir + "/runs/" + id + "/scenario.resolved.yaml") + " --out " +
         shell_quote(abs_dir + "/rerun/" + id) + " --video";
}

json inputs_json(const RunResult& r) {
  json j = json::object();
  for (const auto& [k, v] : r.inputs) j[k] = v;
  return j;
}

// A pair whose landing changed: both sides' outcome and offset, and how to rerun it.
json transition_entry(const Pair& p, const std::string& lander, const std::string& abs_dir) {
  json t;
  t["id"] = p.cur->id;
  t["scenario"] = p.cur->scenario;
  t["baseline"] = {{"outcome", p.base->outcome},
                   {"touchdown_offset_m", finite_or_null(p.base->offset_m)}};
  t["current"] = {{"outcome", p.cur->outcome},
                  {"touchdown_offset_m", finite_or_null(p.cur->offset_m)},
                  {"detail", p.cur->detail}};
  t["inputs"] = inputs_json(*p.cur);
  t["rerun"] = rerun_command(lander, abs_dir, p.cur->id);
  return t;
}

json transitions(const std::vector<Pair>& pairs, const std::string& lander,
                 const std::string& abs_dir) {
  json lost = json::array(), gained = json::array();
  for (const Pair& p : pairs) {
    if (!p.base->simulator_ok() || !p.cur->simulator_ok() || p.base->landed == p.cur->landed)
      continue;
    (p.base->landed ? lost : gained).push_back(transition_entry(p, lander, abs_dir));
  }
  return {{"landed_to_not_landed", lost}, {"not_landed_to_landed", gained}};
}

// Simulator failures of both campaigns (paired or not), the current ones with a rerun command.
json simulator_failures(const CampaignResults& base, const CampaignResults& cur,
                        const json& overall, const std::string& lander,
                        const std::string& abs_dir) {
  std::map<std::string, const RunResult*> base_by_id;
  for (const RunResult& r : base.runs) base_by_id[r.id] = &r;
  json cur_runs = json::array(), base_runs = json::array();
  for (const RunResult& r : cur.runs) {
    if (r.simulator_ok()) continue;
    const auto it = base_by_id.find(r.id);
    cur_runs.push_back(
        {{"id", r.id},
         {"scenario", r.scenario},
         {"status", r.status},
         {"detail", r.detail},
         {"baseline_status", it == base_by_id.end() ? json(nullptr) : json(it->second->status)},
         {"rerun", rerun_command(lander, abs_dir, r.id)}});
  }
  for (const RunResult& r : base.runs) {
    if (!r.simulator_ok()) {
      base_runs.push_back(
          {{"id", r.id}, {"scenario", r.scenario}, {"status", r.status}, {"detail", r.detail}});
    }
  }
  json j;
  j["paired_baseline"] = overall.at("simulator_failures").at("baseline");
  j["paired_current"] = overall.at("simulator_failures").at("current");
  j["current_runs"] = cur_runs;
  j["baseline_runs"] = base_runs;
  return j;
}

// ---- assembling the report ----

json campaign_info(const CampaignResults& c) {
  const json& s = c.summary;
  int failures = 0;
  for (const RunResult& r : c.runs) failures += !r.simulator_ok();
  json j;
  j["dir"] = fs::absolute(c.dir).lexically_normal().string();
  j["name"] = s.value("name", json(nullptr));
  j["master_seed"] = s.value("master_seed", json(nullptr));
  j["runs_planned"] = s.value("runs_planned", json(nullptr));
  j["runs"] = c.runs.size();
  j["missing"] = s.contains("missing") && s["missing"].is_array() ? s["missing"].size() : 0;
  j["simulator_failures"] = failures;
  // Which flight software flew (campaign.json's "name version" -> runs; a campaign merged
  // before it was recorded says so).
  std::string who;
  if (s.contains("flight_software") && s["flight_software"].is_object() && !s["flight_software"].empty()) {
    for (const auto& [name, n] : s["flight_software"].items()) who += (who.empty() ? "" : ", ") + name;
  } else {
    who = "not recorded";
  }
  j["flight_software"] = who;
  j["flight_plugin"] = s.value("flight_plugin", json(nullptr));
  return j;
}

// Scenario names in the current campaign.json's order, then any others the pairs have.
std::vector<std::string> scenario_order(const CampaignResults& base, const CampaignResults& cur,
                                        const std::vector<Pair>& pairs) {
  std::vector<std::string> names;
  auto add = [&](const std::string& n) {
    if (std::find(names.begin(), names.end(), n) == names.end()) names.push_back(n);
  };
  std::set<std::string> present;
  for (const Pair& p : pairs) present.insert(p.cur->scenario);
  for (const CampaignResults* c : {&cur, &base}) {
    if (c->summary.contains("scenarios") && c->summary.at("scenarios").is_object()) {
      for (const auto& [k, v] : c->summary.at("scenarios").items()) {
        if (present.count(k)) add(k);
      }
    }
  }
  for (const Pair& p : pairs) add(p.cur->scenario);
  return names;
}

json pairing_json(const Pairing& p, double max_share) {
  json j;
  j["paired"] = p.pairs.size();
  j["only_in_current"] = p.only_current;
  j["only_in_baseline"] = p.only_baseline;
  j["unpaired_share"] = p.unpaired_share;
  j["unpaired_max_share"] = max_share;
  j["inputs_only_in_current"] = p.inputs_only_current;
  j["inputs_only_in_baseline"] = p.inputs_only_baseline;
  return j;
}

json thresholds_json(const Thresholds& th) {
  json j;
  j["file"] = fs::absolute(th.file).lexically_normal().string();
  json items = json::object();
  json absent = json::array();
  for (const std::string& k : Thresholds::keys()) {
    if (const Threshold* t = th.find(k)) {
      items[k] = {{"limit", t->limit}, {"reason", t->reason}, {"where", t->where}};
    } else {
      absent.push_back(k);
    }
  }
  j["items"] = items;
  j["not_configured"] = absent;
  return j;
}

json methods_json(const RegressOptions& o) {
  return {
      {"pairing", "runs paired by id; same scenario, seed and sampled inputs required"},
      {"landing_rate_interval",
       "Newcombe (1998) method 10 for paired proportions (Wilson intervals of each rate combined "
       "with "
       "the continuity-corrected correlation), over the pairs the simulator completed in both "
       "campaigns"},
      {"touchdown_interval",
       fmt::format(
           "paired percentile bootstrap of the difference of the statistic, {} resamples, seed {}, "
           "over the runs landed in both campaigns; none below {} such runs",
           o.resamples, o.seed, kMinPairsForInterval)},
      {"quantile", "linear interpolation between order statistics (numpy's default)"}};
}

}  // namespace

RegressResult regress(const std::string& current_dir, const std::string& baseline_dir,
                      const RegressOptions& o) {
  const Thresholds th = Thresholds::load(
      o.thresholds_path.empty() ? baseline_dir + "/thresholds.yaml" : o.thresholds_path);
  const CampaignResults base = CampaignResults::load(baseline_dir);
  const CampaignResults cur = CampaignResults::load(current_dir);
  const Pairing pairing = pair_runs(base, cur, th.max_unpaired_share());
  const std::string lander = o.lander_binary.empty() ? sim::self_executable() : o.lander_binary;
  const std::string abs_dir = fs::absolute(current_dir).lexically_normal().string();

  const json overall = compare_group(pairing.pairs, o);
  json scenarios = json::object();
  for (const std::string& s : scenario_order(base, cur, pairing.pairs)) {
    std::vector<Pair> group;
    for (const Pair& p : pairing.pairs) {
      if (p.cur->scenario == s) group.push_back(p);
    }
    scenarios[s] = compare_group(group, o);
  }
  RegressResult res;
  json checks = evaluate_checks(th, overall, scenarios, res.failed_checks);

  json& r = res.report;
  r["schema_version"] = 1;
  r["verdict"] = res.failed() ? "fail" : "pass";
  r["failed_checks"] = res.failed_checks;
  r["current"] = campaign_info(cur);
  r["baseline"] = campaign_info(base);
  r["thresholds"] = thresholds_json(th);
  r["methods"] = methods_json(o);
  r["pairing"] = pairing_json(pairing, th.max_unpaired_share());
  r["checks"] = checks;
  r["overall"] = overall;
  r["scenarios"] = scenarios;
  r["transitions"] = transitions(pairing.pairs, lander, abs_dir);
  r["simulator_failures"] = simulator_failures(base, cur, overall, lander, abs_dir);
  return res;
}

}  // namespace lander::campaign
