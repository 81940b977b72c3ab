// `lander batch SCENARIO.yaml --seeds N [--first-seed S] --out DIR`: Monte-Carlo landing
// statistics. Runs the scenario with seeds S .. S+N-1 (every random stream of a run derives
// from its seed: sensor noise, GPS errors, wind, camera noise), each into DIR/seed_<s>/, and
// writes DIR/batch.json (landing rate, touchdown offset / speed / tilt statistics, outcome
// counts) and DIR/batch.csv (one row per run). A run that fails with an error is recorded
// with its message and the batch goes on; the exit code is 0 when every run ended (landed or
// not), 1 when a run ended in an error, 2 for bad input.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "command.h"
#include "lander/sim/json.h"
#include "lander/sim/run.h"

namespace lander::cli {
namespace {

struct RunRow {
  std::uint64_t seed{0};
  std::string outcome;
  bool landed{false};
  double offset_m{NAN}, rel_speed_mps{NAN}, tilt_deg{NAN}, time_s{NAN};
  std::string error;
};

double number_or_nan(const sim::Json& j, const char* key) {
  const sim::Json* v = j.find(key);
  return (v && v->type() == sim::Json::Type::Number) ? v->number() : NAN;
}

// Mean, median, 95th percentile and max of the finite values; null when there are none.
sim::Json stats(std::vector<double> x) {
  x.erase(std::remove_if(x.begin(), x.end(), [](double v) { return !std::isfinite(v); }),
          x.end());
  sim::Json s = sim::Json::object();
  s["n"] = static_cast<int>(x.size());
  if (x.empty()) return s;
  std::sort(x.begin(), x.end());
  double sum = 0.0;
  for (double v : x) sum += v;
  // Nearest-rank percentile.
  auto pct = [&](double p) {
    const auto k = static_cast<std::size_t>(std::ceil(p * static_cast<double>(x.size())));
    return x[std::min(x.size() - 1, k > 0 ? k - 1 : 0)];
  };
  s["mean"] = sum / static_cast<double>(x.size());
  s["median"] = pct(0.5);
  s["p95"] = pct(0.95);
  s["max"] = x.back();
  return s;
}

std::string csv_number(double v) {
  if (!std::isfinite(v)) return "";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.5f", v);
  return buf;
}

int batch(const Args& args) {
  ArgParser a(args, {"out", "seeds", "first-seed"}, {});
  const char* usage =
      "usage: lander batch SCENARIO.yaml --seeds N [--first-seed S] --out DIR";
  if (a.positional().size() != 1) throw UsageError(usage);
  if (!a.has("out")) throw UsageError(std::string("missing --out DIR\n") + usage);
  if (!a.has("seeds")) throw UsageError(std::string("missing --seeds N\n") + usage);
  const long long n = a.integer("seeds", 0, 1);
  sim::Scenario s = sim::Scenario::load(a.positional()[0]);
  const auto first = static_cast<std::uint64_t>(
      a.integer("first-seed", static_cast<long long>(s.seed), 0));
  if (s.vehicle.control != "closed_loop") {
    throw UsageError(a.positional()[0] +
                     ": vehicle.control is '" + s.vehicle.control +
                     "'; landing statistics need a closed_loop scenario");
  }
  const std::string out = a.value("out");
  sim::RunOptions o;
  o.out_dir = out + "/seed_" + std::to_string(first);
  sim::preflight(s, o);  // bad inputs end the command before any run
  std::filesystem::create_directories(out);

  std::vector<RunRow> rows;
  bool any_error = false;
  for (long long i = 0; i < n; ++i) {
    RunRow r;
    r.seed = first + static_cast<std::uint64_t>(i);
    s.seed = r.seed;
    o.out_dir = out + "/seed_" + std::to_string(r.seed);
    try {
      const sim::Json sum = sim::run_scenario(s, o);
      r.outcome = sum.find("outcome") ? sum.find("outcome")->string() : "unknown";
      r.landed = sum.find("landed") && sum.find("landed")->boolean();
      r.offset_m = number_or_nan(sum, "touchdown_offset_m");
      r.rel_speed_mps = number_or_nan(sum, "touchdown_rel_speed_mps");
      r.tilt_deg = number_or_nan(sum, "touchdown_tilt_deg");
      r.time_s = number_or_nan(sum, "time_to_land_s");
    } catch (const std::exception& e) {
      r.outcome = "error";
      r.error = e.what();
      any_error = true;
    }
    std::printf("lander batch: %s seed %llu: %s", s.name.c_str(),
                static_cast<unsigned long long>(r.seed), r.outcome.c_str());
    if (std::isfinite(r.offset_m)) std::printf(", touchdown offset %.3f m", r.offset_m);
    if (!r.error.empty()) std::printf(" (%s)", r.error.c_str());
    std::printf("\n");
    std::fflush(stdout);
    rows.push_back(r);
  }

  // batch.csv: one row per run.
  std::ofstream csv(out + "/batch.csv");
  if (!csv) throw std::runtime_error(out + "/batch.csv: cannot write");
  csv << "seed,outcome,landed,touchdown_offset_m,touchdown_rel_speed_mps,touchdown_tilt_deg,"
         "time_to_land_s\n";
  for (const RunRow& r : rows) {
    csv << r.seed << "," << r.outcome << "," << (r.landed ? 1 : 0) << ","
        << csv_number(r.offset_m) << "," << csv_number(r.rel_speed_mps) << ","
        << csv_number(r.tilt_deg) << "," << csv_number(r.time_s) << "\n";
  }

  // batch.json: the statistics over the landed runs.
  int landed = 0;
  std::map<std::string, int> outcomes;
  std::vector<double> off, speed, tilt, time;
  for (const RunRow& r : rows) {
    ++outcomes[r.outcome];
    if (!r.landed) continue;
    ++landed;
    off.push_back(r.offset_m);
    speed.push_back(r.rel_speed_mps);
    tilt.push_back(r.tilt_deg);
    time.push_back(r.time_s);
  }
  sim::Json j = sim::Json::object();
  j["scenario"] = s.name;
  j["runs"] = static_cast<int>(rows.size());
  j["first_seed"] = static_cast<long long>(first);
  j["landed"] = landed;
  j["landing_rate"] = static_cast<double>(landed) / static_cast<double>(rows.size());
  sim::Json oc = sim::Json::object();
  for (const auto& [k, v] : outcomes) oc[k] = v;
  j["outcomes"] = oc;
  j["touchdown_offset_m"] = stats(off);
  j["touchdown_rel_speed_mps"] = stats(speed);
  j["touchdown_tilt_deg"] = stats(tilt);
  j["time_to_land_s"] = stats(time);
  sim::Json errs = sim::Json::array();
  for (const RunRow& r : rows) {
    if (r.error.empty()) continue;
    sim::Json e = sim::Json::object();
    e["seed"] = static_cast<long long>(r.seed);
    e["error"] = r.error;
    errs.push(e);
  }
  j["errors"] = errs;
  sim::write_text_file(out + "/batch.json", j.dump() + "\n");
  std::printf("lander batch: %s: %d of %zu landed; outputs in %s/ (batch.json, batch.csv, "
              "seed_*/)\n",
              s.name.c_str(), landed, rows.size(), out.c_str());
  return any_error ? kExitFailure : kExitOk;
}

const LanderCommand reg("batch",
                        "batch SCENARIO.yaml --seeds N [--first-seed S] --out DIR: Monte-Carlo "
                        "landing statistics over N seeds (batch.json, batch.csv)",
                        Kind::Command, batch);

}  // namespace
}  // namespace lander::cli
