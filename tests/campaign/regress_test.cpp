// The regression gate (`lander regress`) on synthetic campaign directories: campaign.csv,
// campaign.json and plan.json of 300 runs made from a seeded generator, then changed the way a
// regression (or no regression) would change them. Runs the real `lander` binary and reads
// regress.json with a JSON parser; a missing or null value fails the test.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "campaign/support/campaign_support.h"
#include "lander/campaign/stats.h"

namespace lander::test {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// ---- synthetic campaigns ----

// One run as campaign.csv holds it.
struct SynthRun {
  std::string id, scenario, outcome{"landed"}, status{"ok"}, detail;
  std::uint64_t seed{0};
  bool landed{true};
  double offset_m{NAN}, x_P_m{NAN}, y_P_m{NAN}, speed_mps{NAN}, tilt_deg{NAN}, time_s{NAN},
      wall_s{30};
  std::string path;  // sampled inputs
  double cart_speed_mps{0}, start_z_m{10};
};

// A run that did not land (`status` "ok") or that the simulator did not complete (else); its
// sampled inputs stay.
void make_not_landed(SynthRun& r, const std::string& outcome, const std::string& status,
                     const std::string& detail) {
  r.outcome = outcome;
  r.status = status;
  r.detail = detail;
  r.landed = false;
  r.offset_m = r.x_P_m = r.y_P_m = r.speed_mps = r.tilt_deg = r.time_s = NAN;
}

// 200 runs of "default" and 100 of "turning": ~90 % landed with offsets of a few cm, the rest
// timeouts or touched_ground, two simulator failures (hung) and details that need quoting.
std::vector<SynthRun> make_runs() {
  std::mt19937_64 rng(20260401);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::vector<SynthRun> runs;
  for (const auto& [scenario, count] :
       std::vector<std::pair<std::string, int>>{{"default", 200}, {"turning", 100}}) {
    for (int i = 0; i < count; ++i) {
      SynthRun r;
      r.id = fmt::format("{}-{:04d}", scenario, i);
      r.scenario = scenario;
      r.seed = rng() >> 11;  // 53 bits, like the campaign's run seeds
      r.path = u(rng) < 0.5 ? "straight" : "arc";
      r.cart_speed_mps = 1.5 * u(rng);
      r.start_z_m = 6 + 9 * u(rng);
      r.wall_s = 20 + 40 * u(rng);
      const double p = u(rng);
      if (p < 0.05) {
        r.landed = false;
        r.outcome = "timeout";
        r.detail = "no landing within 60 s, last mode \"search\"";
      } else if (p < 0.10) {
        r.landed = false;
        r.outcome = "touched_ground";
        r.offset_m = 1.2 + u(rng);
        r.detail = "touched the ground, 1.4 m from the cart\nbeside the platform";
      } else {
        r.offset_m = 0.005 + 0.03 * std::abs(n01(rng)) + 0.02 * u(rng);
        const double a = 6.283185307179586 * u(rng);
        r.x_P_m = r.offset_m * std::cos(a);
        r.y_P_m = r.offset_m * std::sin(a);
        r.speed_mps = 0.3 + 0.05 * n01(rng);
        r.tilt_deg = 2 + std::abs(n01(rng));
        r.time_s = 20 + 3 * n01(rng);
        if (i % 17 == 0) r.detail = "landed, \"softly\"";
      }
      runs.push_back(r);
    }
  }
  for (SynthRun& r : runs) {
    if (r.id == "default-0007" || r.id == "turning-0011") {
      make_not_landed(r, "hung", "hung", "killed after 900 s, \"wall-clock\" limit,\nno summary");
    }
  }
  return runs;
}

// RFC 4180 quoting, as merge.cpp writes campaign.csv.
std::string field(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

std::string cell(double v) { return std::isfinite(v) ? fmt::format("{}", v) : ""; }

void write(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  f << text;
  ASSERT_TRUE(f.good()) << path;
}

// A merged campaign directory: campaign.csv, campaign.json, plan.json, campaign.yaml.
void write_campaign(const std::string& dir, const std::vector<SynthRun>& runs) {
  fs::create_directories(dir);
  std::string csv =
      "id,scenario,seed,outcome,landed,touchdown_offset_m,cart.path,cart.speed_mps,vehicle.start_m["
      "2],"
      "touchdown_x_P_m,touchdown_y_P_m,touchdown_rel_speed_mps,touchdown_tilt_deg,time_to_land_s,"
      "wall_s,status,"
      "detail\n";
  json plan_runs = json::array();
  for (const SynthRun& r : runs) {
    csv += fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", r.id, r.scenario,
                       r.seed, r.outcome, r.landed ? 1 : 0, cell(r.offset_m), r.path,
                       cell(r.cart_speed_mps), cell(r.start_z_m), cell(r.x_P_m), cell(r.y_P_m),
                       cell(r.speed_mps), cell(r.tilt_deg), cell(r.time_s), cell(r.wall_s),
                       r.status, field(r.detail));
    plan_runs.push_back({{"id", r.id},
                         {"scenario", r.scenario},
                         {"seed", r.seed},
                         {"sampled",
                          {{"cart.path", r.path},
                           {"cart.speed_mps", r.cart_speed_mps},
                           {"vehicle.start_m", r.start_z_m}}}});
  }
  write(dir + "/campaign.csv", csv);
  const json campaign = {{"schema_version", 1},
                         {"name", "synthetic"},
                         {"master_seed", 7},
                         {"runs_planned", runs.size()},
                         {"runs_complete", runs.size()},
                         {"missing", json::array()},
                         {"scenarios", {{"default", json::object()}, {"turning", json::object()}}}};
  write(dir + "/campaign.json", campaign.dump(1));
  write(dir + "/plan.json",
        json{{"schema_version", 1}, {"master_seed", 7}, {"runs", plan_runs}}.dump(1));
  write(dir + "/campaign.yaml", "name: synthetic\nseed: 7\n");
}

// The brief's thresholds; line 1 is a comment, the keys are on lines 2-7.
const char* kThresholds =
    "# synthetic baseline\n"
    "landing_rate_drop_points: {limit: 2.0, reason: \"two points fewer landings is a real loss\"}\n"
    "offset_p95_growth_m: {limit: 0.01, reason: \"a tenth of the 10 cm offset limit\"}\n"
    "offset_median_growth_m: {limit: 0.01, reason: \"systematic bias of the touchdown point\"}\n"
    "rel_speed_median_growth_mps: {limit: 0.1, reason: \"harder touchdowns load the gear\"}\n"
    "time_to_land_median_growth_s: {limit: 5.0, reason: \"more searching or go-arounds\"}\n"
    "simulator_failures_increase: {limit: 0, reason: \"a simulator failure is a bug\"}\n";

// A baseline directory (with thresholds) and a current one, with the runs given.
struct Dirs {
  std::string base, cur;
};
Dirs make_dirs(const std::vector<SynthRun>& base_runs, const std::vector<SynthRun>& cur_runs,
               const std::string& thresholds = kThresholds) {
  const std::string root = temp_dir("lander_regress");
  Dirs d{root + "/baseline", root + "/current campaign"};  // a space: rerun commands are quoted
  write_campaign(d.base, base_runs);
  write_campaign(d.cur, cur_runs);
  write(d.base + "/thresholds.yaml", thresholds);
  return d;
}

// ---- reading regress.json strictly ----

// j[path...], failing (throwing) when a key is missing or the value is null.
const json& at(const json& j, const std::vector<std::string>& path) {
  const json* v = &j;
  std::string where;
  for (const std::string& k : path) {
    where += "/" + k;
    if (!v->is_object() || !v->contains(k)) throw std::runtime_error("regress.json: no " + where);
    v = &(*v)[k];
    if (v->is_null()) throw std::runtime_error("regress.json: " + where + " is null");
  }
  return *v;
}
double num(const json& j, const std::vector<std::string>& path) {
  return at(j, path).get<double>();
}

json read_report(const Dirs& d) { return json::parse(read_text(d.cur + "/regress.json")); }

std::vector<std::string> failed_checks(const json& r) {
  return at(r, {"failed_checks"}).get<std::vector<std::string>>();
}

bool has(const std::vector<std::string>& v, const std::string& x) {
  return std::find(v.begin(), v.end(), x) != v.end();
}

Result regress(const Dirs& d, std::vector<std::string> extra = {}) {
  std::vector<std::string> args{"regress", d.cur, "--baseline", d.base};
  args.insert(args.end(), extra.begin(), extra.end());
  return lander(args);
}

const std::vector<std::string> kGroups = {"overall", "default", "turning"};

// ---- tests ----

TEST(PairedProportions, MatchesPublishedNewcombeInterval) {
  // Fagerland, Lydersen & Laake, the paired 2x2 table of Cavo et al. (2012): n11 = 59, n12 = 6,
  // n21 = 16, n22 = 80; Newcombe square-and-add: -0.0621 (-0.1186 to -0.0046) for p1+ - p+1.
  // Here a = the column margin (16 only-a), b = the row margin (6 only-b).
  const campaign::Interval ci = campaign::paired_proportion_difference95(59, 16, 6, 80);
  EXPECT_NEAR(ci.lo, -0.1186, 5e-5);
  EXPECT_NEAR(ci.hi, -0.0046, 5e-5);
  // Swapping the campaigns mirrors the interval.
  const campaign::Interval m = campaign::paired_proportion_difference95(59, 6, 16, 80);
  EXPECT_NEAR(m.lo, -ci.hi, 1e-12);
  EXPECT_NEAR(m.hi, -ci.lo, 1e-12);
  // No discordant pair: an interval around 0; no pair at all: no information.
  const campaign::Interval same = campaign::paired_proportion_difference95(270, 0, 0, 30);
  EXPECT_LT(same.lo, 0.0);
  EXPECT_GT(same.hi, 0.0);
  EXPECT_NEAR(same.lo, -same.hi, 1e-12);
  const campaign::Interval none = campaign::paired_proportion_difference95(0, 0, 0, 0);
  EXPECT_EQ(none.lo, -1.0);
  EXPECT_EQ(none.hi, 1.0);
}

// (a) The same results on both sides: the gate passes and every difference is exactly 0.
TEST(Regress, IdenticalCampaignsPassWithZeroDifferences) {
  const std::vector<SynthRun> runs = make_runs();
  const Dirs d = make_dirs(runs, runs);
  const Result r = regress(d);
  ASSERT_EQ(r.code, 0) << r.output;
  const json j = read_report(d);
  EXPECT_EQ(at(j, {"verdict"}), "pass");
  EXPECT_TRUE(failed_checks(j).empty());
  EXPECT_EQ(num(j, {"pairing", "paired"}), 300);
  for (const std::string& g : kGroups) {
    const json& grp = g == "overall" ? at(j, {"overall"}) : at(j, {"scenarios", g});
    EXPECT_EQ(num(grp, {"landing_rate", "difference"}), 0.0) << g;
    EXPECT_EQ(num(grp, {"landing_rate", "counts", "landed_in_baseline_only"}), 0) << g;
    for (const auto& path :
         std::vector<std::vector<std::string>>{{"touchdown_offset_m", "median"},
                                               {"touchdown_offset_m", "p95"},
                                               {"touchdown_rel_speed_mps", "median"},
                                               {"time_to_land_s", "median"}}) {
      const json& s = at(grp, path);
      EXPECT_EQ(num(s, {"difference"}), 0.0) << g << " " << path[0];
      // Every resample of identical pairs differs by exactly 0.
      EXPECT_EQ(at(s, {"ci95"}).at(0).get<double>(), 0.0);
      EXPECT_EQ(at(s, {"ci95"}).at(1).get<double>(), 0.0);
    }
  }
  // Every configured check was made, overall and per scenario, and passed.
  const json& checks = at(j, {"checks"});
  EXPECT_EQ(checks.size(), 5u * 3u + 1u);
  for (const json& c : checks) EXPECT_EQ(at(c, {"status"}), "pass") << c.dump();
  EXPECT_TRUE(at(j, {"transitions", "landed_to_not_landed"}).empty());
  EXPECT_TRUE(at(j, {"transitions", "not_landed_to_landed"}).empty());
  EXPECT_EQ(num(j, {"simulator_failures", "paired_current"}), 2);
  EXPECT_NE(r.output.find("gate: PASS"), std::string::npos) << r.output;
}

// (b) Every landed run 3 cm further out: the offset median and p95 grew with confidence.
TEST(Regress, OffsetsThreeCentimetresWorseFail) {
  const std::vector<SynthRun> base = make_runs();
  std::vector<SynthRun> cur = base;
  for (SynthRun& r : cur) {
    if (r.landed) r.offset_m += 0.03;
  }
  const Dirs d = make_dirs(base, cur);
  const Result r = regress(d);
  ASSERT_EQ(r.code, 1) << r.output;
  const json j = read_report(d);
  EXPECT_EQ(at(j, {"verdict"}), "fail");
  const auto failed = failed_checks(j);
  EXPECT_TRUE(has(failed, "overall: offset_p95_growth_m")) << r.output;
  EXPECT_TRUE(has(failed, "overall: offset_median_growth_m")) << r.output;
  EXPECT_TRUE(has(failed, "turning: offset_median_growth_m")) << r.output;
  EXPECT_FALSE(has(failed, "overall: landing_rate_drop_points"));
  EXPECT_NEAR(num(j, {"overall", "touchdown_offset_m", "median", "difference"}), 0.03, 1e-9);
  EXPECT_NEAR(num(j, {"overall", "touchdown_offset_m", "p95", "difference"}), 0.03, 1e-9);
  EXPECT_GT(at(j, {"overall", "touchdown_offset_m", "p95", "ci95"}).at(0).get<double>(), 0.0);
  // The summary names the checks and gives the reason of a failed one.
  EXPECT_NE(r.output.find("FAIL  offset_p95_growth_m "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("overall: touchdown offset p95 changed by +3.00 cm"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("reason: a tenth of the 10 cm offset limit"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("gate: FAIL"), std::string::npos) << r.output;
}

// (c) One landed run in ten now times out: the landing rate dropped with confidence, and each
// such run is listed with the command that reruns it.
TEST(Regress, TenPercentMoreTimeoutsFailOnLandingRate) {
  const std::vector<SynthRun> base = make_runs();
  std::vector<SynthRun> cur = base;
  std::vector<std::string> lost;
  int landed = 0;
  for (SynthRun& r : cur) {
    if (!r.landed || landed++ % 10 != 0) continue;
    make_not_landed(r, "timeout", "ok", "no landing within 60 s");
    lost.push_back(r.id);
  }
  const Dirs d = make_dirs(base, cur);
  const Result r = regress(d);
  ASSERT_EQ(r.code, 1) << r.output;
  const json j = read_report(d);
  const auto failed = failed_checks(j);
  EXPECT_TRUE(has(failed, "overall: landing_rate_drop_points")) << r.output;
  EXPECT_FALSE(has(failed, "overall: offset_median_growth_m"))
      << r.output;  // the rest landed as before
  EXPECT_LT(at(j, {"overall", "landing_rate", "ci95"}).at(1).get<double>(), -0.02);
  EXPECT_NEAR(num(j, {"overall", "landing_rate", "difference"}),
              -static_cast<double>(lost.size()) / 298, 1e-12);
  const json& t = at(j, {"transitions", "landed_to_not_landed"});
  ASSERT_EQ(t.size(), lost.size());
  const std::string abs_cur = fs::absolute(d.cur).lexically_normal().string();
  for (const json& e : t) {
    const std::string id = at(e, {"id"}).get<std::string>();
    EXPECT_TRUE(has(lost, id));
    EXPECT_EQ(at(e, {"baseline", "outcome"}), "landed");
    EXPECT_EQ(at(e, {"current", "outcome"}), "timeout");
    EXPECT_EQ(at(e, {"rerun"}).get<std::string>(),
              fmt::format("{} run '{}/runs/{}/scenario.resolved.yaml' --out '{}/rerun/{}' --video",
                          LANDER_BINARY, abs_cur, id, abs_cur, id));
  }
  EXPECT_NE(r.output.find("FAIL  landing_rate_drop_points "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("overall: landing rate changed by -"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("runs that stopped landing (" + std::to_string(lost.size()) + ")"),
            std::string::npos);
}

// (d) Offsets moved by +-2 mm at random: within the thresholds, the gate passes.
TEST(Regress, SmallNoisePasses) {
  const std::vector<SynthRun> base = make_runs();
  std::vector<SynthRun> cur = base;
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> noise(-0.002, 0.002);
  for (SynthRun& r : cur) {
    if (r.landed) r.offset_m = std::max(0.0, r.offset_m + noise(rng));
  }
  const Dirs d = make_dirs(base, cur);
  const Result r = regress(d);
  EXPECT_EQ(r.code, 0) << r.output;
  const json j = read_report(d);
  EXPECT_EQ(at(j, {"verdict"}), "pass");
  EXPECT_LT(std::abs(num(j, {"overall", "touchdown_offset_m", "median", "difference"})), 0.002);
}

// (e) Runs that are not the same runs are refused: a different seed on one id, or run sets that
// differ by more than the allowed share. A few runs missing on one side are left out and listed.
TEST(Regress, MismatchedSeedsOrRunSetsAreRefused) {
  const std::vector<SynthRun> base = make_runs();
  std::vector<SynthRun> cur = base;
  cur[42].seed += 1;
  Dirs d = make_dirs(base, cur);
  Result r = regress(d);
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find(cur[42].id + ": seed"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("not the same runs"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(d.cur + "/regress.json"));

  cur = base;
  cur[5].cart_speed_mps += 0.1;  // another sampled condition under the same id
  d = make_dirs(base, cur);
  r = regress(d);
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find(cur[5].id + ": sampled cart.speed_mps"), std::string::npos) << r.output;

  cur = base;
  for (int i = 0; i < 30; ++i) cur[i].id = fmt::format("other-{:04d}", i);
  d = make_dirs(base, cur);
  r = regress(d);
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("run sets differ"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("only in the current campaign (30): other-0000"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("only in the baseline (30): default-0000"), std::string::npos)
      << r.output;

  cur = base;
  cur.erase(cur.begin() + 10, cur.begin() + 13);  // 1 %: left out, listed
  d = make_dirs(base, cur);
  r = regress(d);
  EXPECT_EQ(r.code, 0) << r.output;
  const json j = read_report(d);
  EXPECT_EQ(at(j, {"pairing", "only_in_baseline"}).get<std::vector<std::string>>(),
            (std::vector<std::string>{base[10].id, base[11].id, base[12].id}));
  EXPECT_EQ(num(j, {"pairing", "paired"}), 297);
}

// (f) thresholds.yaml is checked like every config file: file:line and the key.
TEST(Regress, BadThresholdsFileNamesFileAndLine) {
  const std::vector<SynthRun> runs = make_runs();
  const std::string unknown =
      std::string(kThresholds) + "offset_p99_growth_m: {limit: 0.02, reason: \"x\"}\n";
  Dirs d = make_dirs(runs, runs, unknown);
  Result r = regress(d);
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("thresholds.yaml:8: unknown key 'offset_p99_growth_m'"),
            std::string::npos)
      << r.output;

  const std::string no_reason = "# x\n\nlanding_rate_drop_points: {limit: 2.0}\n";
  d = make_dirs(runs, runs, no_reason);
  r = regress(d);
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("thresholds.yaml:3: 'landing_rate_drop_points' has no 'reason'"),
            std::string::npos)
      << r.output;

  const std::string no_limit = "offset_p95_growth_m:\n  reason: \"why\"\n";
  d = make_dirs(runs, runs, no_limit);
  r = regress(d);
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("thresholds.yaml:1: 'offset_p95_growth_m' has no 'limit'"),
            std::string::npos)
      << r.output;

  const std::string bad_sub = "offset_p95_growth_m:\n  limit: 0.01\n  reason: \"why\"\n  limt: 3\n";
  d = make_dirs(runs, runs, bad_sub);
  r = regress(d);
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("thresholds.yaml:4: unknown key 'offset_p95_growth_m.limt'"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(d.cur + "/regress.json"));

  fs::remove(d.base + "/thresholds.yaml");
  r = regress(d);
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("thresholds.yaml: cannot open file"), std::string::npos) << r.output;
}

// A simulator failure more than the baseline fails the gate by itself.
TEST(Regress, MoreSimulatorFailuresFail) {
  const std::vector<SynthRun> base = make_runs();
  std::vector<SynthRun> cur = base;
  make_not_landed(cur[100], "crashed", "crashed", "killed by signal 11 (Segmentation fault)");
  const Dirs d = make_dirs(base, cur);
  const Result r = regress(d);
  ASSERT_EQ(r.code, 1) << r.output;
  const json j = read_report(d);
  EXPECT_EQ(failed_checks(j), (std::vector<std::string>{"overall: simulator_failures_increase"}))
      << r.output;
  const json& f = at(j, {"simulator_failures", "current_runs"});
  ASSERT_EQ(f.size(), 3u);
  EXPECT_EQ(at(f[1], {"id"}), cur[100].id);
  EXPECT_EQ(at(f[1], {"baseline_status"}), "ok");
  EXPECT_NE(at(f[1], {"rerun"})
                .get<std::string>()
                .find("/runs/" + cur[100].id + "/scenario.resolved.yaml"),
            std::string::npos);
}

// --accept copies the merged results (not runs/) into the baseline, writes a default
// thresholds.yaml once and keeps it afterwards; the accepted baseline then gates the campaign.
TEST(Regress, AcceptMakesTheBaseline) {
  const std::vector<SynthRun> runs = make_runs();
  const std::string root = temp_dir("lander_regress_accept");
  const std::string cur = root + "/cur", base = root + "/regression/synthetic";
  write_campaign(cur, runs);
  fs::create_directories(cur + "/runs/default-0000");
  Result r = lander({"regress", "--accept", cur, "--baseline", base});
  ASSERT_EQ(r.code, 0) << r.output;
  for (const char* f : {"campaign.csv", "campaign.json", "plan.json", "campaign.yaml"}) {
    EXPECT_EQ(read_text(base + "/" + f), read_text(cur + "/" + f)) << f;
  }
  EXPECT_FALSE(fs::exists(base + "/runs"));
  const std::string thresholds = read_text(base + "/thresholds.yaml");
  EXPECT_NE(thresholds.find("offset_p95_growth_m:"), std::string::npos);
  r = lander({"regress", cur, "--baseline", base});
  EXPECT_EQ(r.code, 0) << r.output;
  const json j = json::parse(read_text(cur + "/regress.json"));
  EXPECT_EQ(at(j, {"checks"}).size(), 16u);  // every default threshold is in force
  EXPECT_TRUE(at(j, {"thresholds", "not_configured"}).empty());

  // A second accept keeps an edited thresholds file.
  write(base + "/thresholds.yaml", kThresholds);
  ASSERT_EQ(lander({"regress", "--accept", cur, "--baseline", base}).code, 0);
  EXPECT_EQ(read_text(base + "/thresholds.yaml"), kThresholds);

  // An incomplete campaign is not accepted.
  json c = json::parse(read_text(cur + "/campaign.json"));
  c["missing"] = {"default-0199"};
  write(cur + "/campaign.json", c.dump());
  r = lander({"regress", "--accept", cur, "--baseline", base});
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("1 planned runs are not complete"), std::string::npos) << r.output;
}

// --json writes a copy of regress.json; --html a self-contained page through
// tools/regress_report.py.
TEST(Regress, JsonCopyAndHtmlPage) {
  const std::vector<SynthRun> base = make_runs();
  std::vector<SynthRun> cur = base;
  for (SynthRun& r : cur) {
    if (r.landed) r.offset_m += 0.03;
  }
  const auto first_landed =
      std::find_if(cur.begin(), cur.end(), [](const SynthRun& r) { return r.landed; });
  make_not_landed(*first_landed, "timeout", "ok", "<script>alert(\"x\")</script>, \"quoted\"");
  const Dirs d = make_dirs(base, cur);
  const std::string html = d.cur + "/regress.html", copy = d.cur + "/../copy.json";
  const Result r = regress(d, {"--json", copy, "--html", html});
  ASSERT_EQ(r.code, 1) << r.output;
  EXPECT_EQ(read_text(copy), read_text(d.cur + "/regress.json"));
  const std::string page = read_text(html);
  ASSERT_FALSE(page.empty()) << r.output;
  EXPECT_NE(page.find("data-plot=\"offset_cdf\""), std::string::npos);
  EXPECT_NE(page.find("data-plot=\"touchdown\""), std::string::npos);
  EXPECT_NE(page.find("offset_p95_growth_m"), std::string::npos);
  EXPECT_EQ(page.find("src=\"http"), std::string::npos);  // self-contained
  // A detail from campaign.csv is shown escaped.
  EXPECT_EQ(page.find("<script>"), std::string::npos);
  EXPECT_NE(page.find("&lt;script&gt;alert(&quot;x&quot;)&lt;/script&gt;, &quot;quoted&quot;"),
            std::string::npos);
}

TEST(Regress, UsageErrorsExitTwo) {
  EXPECT_EQ(lander({"regress"}).code, 2);
  EXPECT_EQ(lander({"regress", "/tmp"}).code, 2);  // no --baseline
  EXPECT_EQ(lander({"regress", "--accept", "/tmp", "--baseline", "/tmp/x", "--html", "f"}).code, 2);
  const Result r = lander({"regress", "/nonexistent/cur", "--baseline", "/nonexistent/base"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("thresholds.yaml"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace lander::test
