#include "lander/campaign/campaign.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>

#include <fmt/format.h>

#include "lander/core/params_io.h"
#include "lander/sim/scenario.h"

namespace lander::campaign {

namespace fs = std::filesystem;

namespace {

// SplitMix64: a small, portable generator, so sampled values are the same on every machine
// and standard library (std:: distributions are implementation-defined).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : s_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (s_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform on [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  // Standard normal (Box-Muller; one value per call keeps the stream simple).
  double normal() {
    double u1 = uniform();
    while (u1 <= 0.0) u1 = uniform();
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }

 private:
  std::uint64_t s_;
};

// Child of a mapping without inserting it (yaml-cpp's operator[] on a non-const node inserts).
YAML::Node child(const YAML::Node& map, const std::string& key) {
  if (!map.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
  for (auto it = map.begin(); it != map.end(); ++it) {
    if (it->first.as<std::string>() == key) return it->second;
  }
  return YAML::Node(YAML::NodeType::Undefined);
}

std::vector<std::string> split_key(const std::string& key) {
  std::vector<std::string> parts;
  std::string cur;
  for (char c : key) {
    if (c == '.') {
      parts.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  parts.push_back(cur);
  return parts;
}

// The value at a dotted key inside a resolved scenario tree; undefined when absent.
YAML::Node lookup(const YAML::Node& root, const std::string& key) {
  YAML::Node cur = root;
  for (const std::string& part : split_key(key)) {
    YAML::Node next = child(cur, part);
    if (!next.IsDefined()) return next;
    cur.reset(next);
  }
  return cur;
}

// Sets a dotted key in a scenario tree, creating the mappings on the way.
void assign(YAML::Node& root, const std::string& key, const YAML::Node& value) {
  const std::vector<std::string> parts = split_key(key);
  YAML::Node cur = root;
  for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
    YAML::Node next = child(cur, parts[i]);
    if (!next.IsDefined() || !next.IsMap()) {
      cur[parts[i]] = YAML::Node(YAML::NodeType::Map);
      next.reset(child(cur, parts[i]));  // reset, not =: = would write into the old node
    }
    cur.reset(next);
  }
  cur[parts.back()] = YAML::Clone(value);
}

[[noreturn]] void fail(const std::string& where, const std::string& msg) {
  throw ConfigError(where + ": " + msg);
}

double number(const YAML::Node& n, const std::string& where, const std::string& what) {
  if (!n.IsDefined() || !n.IsScalar()) fail(where, what + ": expected a number");
  double v = 0;
  try {
    v = n.as<double>();
  } catch (const YAML::Exception&) {
    fail(where, what + ": expected a number, got '" + n.Scalar() + "'");
  }
  if (!std::isfinite(v)) fail(where, what + ": must be finite");
  return v;
}

// A number or a list of n numbers (a scalar is used for every component).
std::vector<double> numbers(const YAML::Node& n, std::size_t count, const std::string& where,
                            const std::string& what) {
  if (n.IsSequence()) {
    if (n.size() != count) {
      fail(where, fmt::format("{}: expected {} values, got {}", what, count, n.size()));
    }
    std::vector<double> v;
    for (std::size_t i = 0; i < count; ++i) v.push_back(number(n[i], where, what));
    return v;
  }
  return std::vector<double>(count, number(n, where, what));
}

// [lo, hi] bounds for `count` components: [a, b] with scalars, or [[a...], [b...]].
std::pair<std::vector<double>, std::vector<double>> bounds(const YAML::Node& n, std::size_t count,
                                                           const std::string& where,
                                                           const std::string& what) {
  if (!n.IsSequence() || n.size() != 2) fail(where, what + ": expected [low, high]");
  auto lo = numbers(n[0], count, where, what);
  auto hi = numbers(n[1], count, where, what);
  for (std::size_t i = 0; i < count; ++i) {
    if (lo[i] > hi[i]) fail(where, fmt::format("{}: low {} > high {}", what, lo[i], hi[i]));
  }
  return {lo, hi};
}

YAML::Node to_node(const std::vector<double>& v, bool scalar) {
  if (scalar) return YAML::Node(v.at(0));
  YAML::Node seq(YAML::NodeType::Sequence);
  for (double x : v) seq.push_back(x);
  return seq;
}

const std::set<std::string> kKinds = {"uniform", "normal", "loguniform", "integer",
                                      "choice",  "polar",  "constant"};

// The spec's one distribution kind; its other keys must be min / max (normal) or weights
// (choice).
std::string distribution_kind(const YAML::Node& spec, const std::string& key,
                              const std::string& where) {
  std::string kind;
  for (auto it = spec.begin(); it != spec.end(); ++it) {
    const std::string k = it->first.as<std::string>();
    if (kKinds.count(k)) {
      if (!kind.empty()) fail(where, "'" + key + "': give one distribution, not '" + kind + "' and '" + k + "'");
      kind = k;
    } else if (k != "min" && k != "max" && k != "weights") {
      fail(where, "'" + key + "': unknown distribution key '" + k +
                      "' (uniform, normal, loguniform, integer, choice, polar, constant; min, "
                      "max, weights)");
    }
  }
  if (kind.empty()) fail(where, "'" + key + "': no distribution given");
  const std::string what = "'" + key + "' " + kind;
  if (kind != "normal" && (child(spec, "min").IsDefined() || child(spec, "max").IsDefined())) {
    fail(where, what + ": min/max apply to normal only");
  }
  if (kind != "choice" && child(spec, "weights").IsDefined()) {
    fail(where, what + ": weights apply to choice only");
  }
  return kind;
}

// `choice` and `constant`: the options, their weights, and each option of the key's shape.
ChoiceDistribution parse_choice(const YAML::Node& spec, const std::string& kind,
                                const YAML::Node& like, const std::string& where,
                                const std::string& what) {
  const YAML::Node arg = child(spec, kind);
  std::vector<YAML::Node> options;
  if (kind == "constant") {
    options.push_back(arg);
  } else {
    if (!arg.IsSequence() || arg.size() == 0) fail(where, what + ": expected a non-empty list");
    for (std::size_t i = 0; i < arg.size(); ++i) options.push_back(arg[i]);
  }
  ChoiceDistribution d;
  d.weights.assign(options.size(), 1.0);
  if (const YAML::Node wn = child(spec, "weights"); wn.IsDefined()) {
    if (!wn.IsSequence() || wn.size() != options.size()) {
      fail(where, what + ": weights must list one number per choice");
    }
    for (std::size_t i = 0; i < d.weights.size(); ++i) {
      d.weights[i] = number(wn[i], where, what + " weights");
      if (d.weights[i] < 0) fail(where, what + ": weights must be >= 0");
    }
  }
  for (double x : d.weights) d.total_weight += x;
  if (!(d.total_weight > 0)) fail(where, what + ": weights must not all be 0");
  // Every option must have the key's shape (a list of the same length, or a scalar).
  for (const YAML::Node& o : options) {
    if (like.IsSequence() != o.IsSequence() || (like.IsSequence() && like.size() != o.size()) ||
        (!o.IsScalar() && !o.IsSequence())) {
      fail(where, what + ": value '" + YAML::Dump(o) + "' does not have the shape of the key (" +
                      (like.IsSequence() ? std::to_string(like.size()) + " numbers" : "one value") + ")");
    }
  }
  // Detached from the campaign file's tree: a draw hands out a copy of one of them.
  for (const YAML::Node& o : options) d.options.push_back(YAML::Clone(o));
  return d;
}

// The number of components of a key a numeric distribution can disperse (1 for a scalar).
std::size_t numeric_components(const YAML::Node& like, const std::string& key,
                               const std::string& where, const std::string& what) {
  if (like.IsScalar()) {
    // A numeric key? Strings only take choice / constant.
    try {
      like.as<double>();
    } catch (const YAML::Exception&) {
      fail(where, what + ": '" + key + "' is not a number; use choice or constant");
    }
    return 1;
  }
  if (!like.IsSequence()) fail(where, "'" + key + "' is a section, not a value: disperse its keys");
  return like.size();
}

// `uniform`, `loguniform` and `integer`: [lo, hi] per component.
Distribution parse_bounded(const std::string& kind, const YAML::Node& arg, std::size_t n,
                           const std::string& where, const std::string& what) {
  const auto [lo, hi] = bounds(arg, n, where, what);
  for (std::size_t i = 0; i < n; ++i) {
    if (kind == "loguniform" && !(lo[i] > 0)) fail(where, what + ": bounds must be > 0");
    if (kind == "integer" && (lo[i] != std::floor(lo[i]) || hi[i] != std::floor(hi[i]))) {
      fail(where, what + ": bounds must be whole numbers");
    }
  }
  if (kind == "uniform") return UniformDistribution{lo, hi};
  if (kind == "loguniform") return LogUniformDistribution{lo, hi};
  return IntegerDistribution{lo, hi};
}

// `normal: {mean, std}` with the spec's optional `min` / `max`, per component.
NormalDistribution parse_normal(const YAML::Node& spec, std::size_t n, const std::string& where,
                                const std::string& what) {
  const YAML::Node arg = child(spec, "normal");
  if (!arg.IsMap()) fail(where, what + ": expected {mean: m, std: s}");
  for (auto it = arg.begin(); it != arg.end(); ++it) {
    const std::string k = it->first.as<std::string>();
    if (k != "mean" && k != "std") fail(where, what + ": unknown key '" + k + "' (mean, std)");
  }
  NormalDistribution d;
  d.mean = numbers(child(arg, "mean"), n, where, what + " mean");
  d.std = numbers(child(arg, "std"), n, where, what + " std");
  d.min.assign(n, -INFINITY);
  d.max.assign(n, INFINITY);
  if (child(spec, "min").IsDefined()) d.min = numbers(child(spec, "min"), n, where, what + " min");
  if (child(spec, "max").IsDefined()) d.max = numbers(child(spec, "max"), n, where, what + " max");
  for (std::size_t i = 0; i < n; ++i) {
    if (d.std[i] < 0) fail(where, what + ": std must be >= 0");
    if (d.min[i] > d.max[i]) fail(where, what + ": min > max");
  }
  return d;
}

// `polar: {radius, direction_deg, center, z, uniform_in}` for a key of 2 or 3 numbers.
PolarDistribution parse_polar(const YAML::Node& arg, std::size_t n, bool scalar,
                              const std::string& where, const std::string& what) {
  if (scalar || (n != 2 && n != 3)) fail(where, what + ": needs a key of 2 or 3 numbers");
  if (!arg.IsMap()) fail(where, what + ": expected {radius: [r0, r1], ...}");
  for (auto it = arg.begin(); it != arg.end(); ++it) {
    const std::string k = it->first.as<std::string>();
    if (k != "radius" && k != "direction_deg" && k != "center" && k != "z" && k != "uniform_in") {
      fail(where, what + ": unknown key '" + k + "' (radius, direction_deg, center, z, uniform_in)");
    }
  }
  PolarDistribution d;
  d.components = n;
  const auto [r0, r1] = bounds(child(arg, "radius"), 1, where, what + " radius");
  if (r0[0] < 0) fail(where, what + ": radius must be >= 0");
  d.radius_lo_m = r0[0];
  d.radius_hi_m = r1[0];
  if (child(arg, "direction_deg").IsDefined()) {
    const auto [d0, d1] = bounds(child(arg, "direction_deg"), 1, where, what + " direction_deg");
    d.direction_lo_deg = d0[0];
    d.direction_hi_deg = d1[0];
  }
  if (child(arg, "center").IsDefined()) {
    const std::vector<double> c = numbers(child(arg, "center"), 2, where, what + " center");
    d.center_x = c[0];
    d.center_y = c[1];
  }
  std::string law = "radius";
  if (const YAML::Node l = child(arg, "uniform_in"); l.IsDefined()) law = l.as<std::string>();
  if (law != "radius" && law != "area") fail(where, what + ": uniform_in must be radius or area");
  d.uniform_in_area = law == "area";
  if (n == 3) {
    const YAML::Node z = child(arg, "z");
    if (!z.IsDefined()) fail(where, what + ": a 3-vector key needs z: value or [z0, z1]");
    if (z.IsSequence()) {
      const auto [z0, z1] = bounds(z, 1, where, what + " z");
      d.z_drawn = true;
      d.z_lo = z0[0];
      d.z_hi = z1[0];
    } else {
      d.z_lo = number(z, where, what + " z");
    }
  }
  return d;
}

// The draws. Each takes its generator's values in a fixed order (one uniform per component,
// a normal per accepted or rejected component value, two or three uniforms for polar), so a
// run's values depend only on its stream seed.

YAML::Node draw(const ChoiceDistribution& d, Rng& rng, const Dispersion&) {
  const double u = rng.uniform() * d.total_weight;
  double acc = 0;
  for (std::size_t i = 0; i < d.options.size(); ++i) {
    acc += d.weights[i];
    if (u < acc || i + 1 == d.options.size()) return YAML::Clone(d.options[i]);
  }
  return YAML::Clone(d.options.back());  // not reached: the last option is taken above
}

YAML::Node draw(const UniformDistribution& d, Rng& rng, const Dispersion& disp) {
  std::vector<double> v(d.lo.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    const double u = rng.uniform();
    v[i] = d.lo[i] + (d.hi[i] - d.lo[i]) * u;
  }
  return to_node(v, disp.scalar);
}

YAML::Node draw(const LogUniformDistribution& d, Rng& rng, const Dispersion& disp) {
  std::vector<double> v(d.lo.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    const double u = rng.uniform();
    v[i] = std::exp(std::log(d.lo[i]) + (std::log(d.hi[i]) - std::log(d.lo[i])) * u);
  }
  return to_node(v, disp.scalar);
}

YAML::Node draw(const IntegerDistribution& d, Rng& rng, const Dispersion& disp) {
  std::vector<double> v(d.lo.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    const double u = rng.uniform();
    v[i] = std::min(d.hi[i], d.lo[i] + std::floor((d.hi[i] - d.lo[i] + 1) * u));
  }
  if (disp.scalar) return YAML::Node(static_cast<long long>(v[0]));
  return to_node(v, false);
}

// Truncated by rejection: at most 10000 draws per component.
YAML::Node draw(const NormalDistribution& d, Rng& rng, const Dispersion& disp) {
  std::vector<double> v(d.mean.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    int tries = 0;
    do {
      if (++tries > 10000) {
        fail(disp.where, fmt::format("'{}' normal: [min, max] = [{}, {}] is too improbable for "
                                     "mean {} and std {} (10000 draws, none inside)",
                                     disp.key, d.min[i], d.max[i], d.mean[i], d.std[i]));
      }
      v[i] = d.mean[i] + d.std[i] * rng.normal();
    } while (v[i] < d.min[i] || v[i] > d.max[i]);
  }
  return to_node(v, disp.scalar);
}

YAML::Node draw(const PolarDistribution& d, Rng& rng, const Dispersion&) {
  const double ur = rng.uniform(), ud = rng.uniform();
  const double r0 = d.radius_lo_m, r1 = d.radius_hi_m;
  const double r = d.uniform_in_area ? std::sqrt(r0 * r0 + (r1 * r1 - r0 * r0) * ur)
                                     : r0 + (r1 - r0) * ur;
  const double dir =
      (d.direction_lo_deg + (d.direction_hi_deg - d.direction_lo_deg) * ud) * M_PI / 180.0;
  std::vector<double> v(d.components);
  v[0] = d.center_x + r * std::cos(dir);
  v[1] = d.center_y + r * std::sin(dir);
  if (d.components == 3) v[2] = d.z_drawn ? d.z_lo + (d.z_hi - d.z_lo) * rng.uniform() : d.z_lo;
  return to_node(v, false);
}

}  // namespace

// Distribution kinds (one per mapping; `min` / `max` truncate `normal`):
//   uniform: [lo, hi] | [[lo...], [hi...]]       per component for a list key
//   normal: {mean: m, std: s}, min: a, max: b    m, s, a, b numbers or lists; truncated by
//                                                rejection (at most 10000 draws)
//   loguniform: [lo, hi]                         0 < lo <= hi; uniform in log
//   integer: [lo, hi]                            whole numbers, both ends included
//   choice: [v1, v2, ...], weights: [w1, ...]    any YAML values; weights optional
//   polar: {radius: [r0, r1], direction_deg: [d0, d1], center: [x, y], z: z | [z0, z1],
//           uniform_in: radius | area}           a 2- or 3-vector at a random bearing
//   constant: v
Dispersion Dispersion::parse(const std::string& key, const std::string& where,
                             const YAML::Node& spec, const YAML::Node& like) {
  Dispersion d;
  d.key = key;
  d.where = where;
  const std::string kind = distribution_kind(spec, key, where);
  const std::string what = "'" + key + "' " + kind;
  if (kind == "choice" || kind == "constant") {
    d.distribution = parse_choice(spec, kind, like, where, what);
    d.scalar = !like.IsSequence();
    return d;
  }
  const std::size_t n = numeric_components(like, key, where, what);
  d.scalar = like.IsScalar();
  if (kind == "normal") {
    d.distribution = parse_normal(spec, n, where, what);
  } else if (kind == "polar") {
    d.distribution = parse_polar(child(spec, kind), n, d.scalar, where, what);
  } else {
    d.distribution = parse_bounded(kind, child(spec, kind), n, where, what);
  }
  return d;
}

YAML::Node Dispersion::sample(std::uint64_t stream_seed) const {
  Rng rng(stream_seed);
  return std::visit([&](const auto& dist) { return draw(dist, rng, *this); }, distribution);
}

// 53 bits: the seed stays exact in every JSON reader (JavaScript's numbers are doubles).
std::uint64_t run_seed(std::uint64_t master_seed, const std::string& scenario_id, int index) {
  return sim::derive_seed(master_seed, "run/" + scenario_id + "/" + std::to_string(index)) &
         ((std::uint64_t{1} << 53) - 1);
}

namespace {

// Reads a `dispersions:` mapping; every key must name a value of the resolved scenario.
std::vector<Dispersion> read_dispersions(const YAML::Node& node, const std::string& file,
                                         const YAML::Node& resolved_defaults) {
  std::vector<Dispersion> out;
  if (!node.IsDefined() || node.IsNull()) return out;
  if (!node.IsMap()) fail(yaml_where(node, file), "dispersions: expected a mapping key -> distribution");
  for (auto it = node.begin(); it != node.end(); ++it) {
    const std::string key = it->first.as<std::string>();
    const std::string where = yaml_where(it->first, file);
    const YAML::Node spec = it->second;
    if (!spec.IsMap()) fail(where, "'" + key + "': expected a distribution mapping, e.g. {uniform: [0, 1]}");
    if (key == "seed" || key == "name") fail(where, "'" + key + "' cannot be dispersed (the campaign sets it)");
    const YAML::Node like = lookup(resolved_defaults, key);
    if (!like.IsDefined()) fail(where, "unknown scenario key '" + key + "'");
    if (like.IsMap()) fail(where, "'" + key + "' is a section, not a value: disperse its keys");
    for (const Dispersion& other : out) {
      if (other.key == key) fail(where, "'" + key + "' dispersed twice (also at " + other.where + ")");
    }
    // Shape and parameters checked now, once, not at run i.
    Dispersion d = Dispersion::parse(key, where, spec, like);
    // A truncated normal whose [min, max] the rejection cannot reach fails now too: one trial
    // draw (the other kinds cannot fail to draw).
    if (std::holds_alternative<NormalDistribution>(d.distribution)) d.sample(0);
    out.push_back(std::move(d));
  }
  return out;
}

void check_keys(const YAML::Node& map, const std::string& file, const std::set<std::string>& allowed,
                const std::string& context) {
  for (auto it = map.begin(); it != map.end(); ++it) {
    const std::string k = it->first.as<std::string>();
    if (!allowed.count(k)) {
      std::string list;
      for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
      fail(yaml_where(it->first, file), "unknown " + context + "key '" + k + "' (" + list + ")");
    }
  }
}

// The run's scenario tree: its scenario file with the sampled values and the run's seed in
// force (what make_plan checks and run_scenario_yaml writes).
YAML::Node run_node(const YAML::Node& file_node, const PlannedRun& r) {
  YAML::Node node = YAML::Clone(file_node);
  if (!node.IsMap()) node = YAML::Node(YAML::NodeType::Map);
  for (const auto& [key, v] : r.sampled) assign(node, key, v);
  node["seed"] = r.seed;
  return node;
}

YAML::Node resolved_defaults() {
  return params_to_yaml(sim::Scenario::defaults());
}

}  // namespace

Campaign Campaign::load(const std::string& path) {
  const YAML::Node root = load_yaml_file(path);
  if (!root.IsMap()) fail(yaml_where(root, path), "a campaign file is a mapping (name, seed, scenarios, dispersions)");
  check_unique_keys(root, path);  // a repeated key (seed: twice) would be silently ignored
  check_keys(root, path,
             {"name", "description", "seed", "offset_limit_m", "run_timeout_s", "flight_plugin", "scenarios", "dispersions"},
             "");
  Campaign c;
  c.file = path;
  const YAML::Node defaults = resolved_defaults();
  if (const YAML::Node n = child(root, "name"); n.IsDefined()) {
    c.name = n.as<std::string>();
    if (c.name.empty()) fail(yaml_where(n, path), "name: must not be empty");
  } else {
    c.name = fs::path(path).stem().string();
  }
  if (const YAML::Node n = child(root, "seed"); n.IsDefined()) {
    try {
      c.seed = n.as<std::uint64_t>();
    } catch (const YAML::Exception&) {
      fail(yaml_where(n, path), "seed: expected a non-negative integer, got '" + n.Scalar() + "'");
    }
  }
  if (const YAML::Node n = child(root, "offset_limit_m"); n.IsDefined()) {
    c.offset_limit_m = number(n, yaml_where(n, path), "offset_limit_m");
    if (!(c.offset_limit_m > 0)) fail(yaml_where(n, path), "offset_limit_m: must be > 0");
  }
  if (const YAML::Node n = child(root, "run_timeout_s"); n.IsDefined()) {
    c.run_timeout_s = number(n, yaml_where(n, path), "run_timeout_s");
    if (!(c.run_timeout_s > 0)) fail(yaml_where(n, path), "run_timeout_s: must be > 0");
  }
  if (const YAML::Node n = child(root, "flight_plugin"); n.IsDefined()) {
    if (!n.IsScalar() || n.Scalar().empty()) fail(yaml_where(n, path), "flight_plugin: expected the path of a plugin file");
    c.flight_plugin = flight::resolve_plugin_path(n.Scalar(), path);
    if (!fs::is_regular_file(c.flight_plugin)) fail(yaml_where(n, path), "flight_plugin: no such file: " + c.flight_plugin);
  }
  c.dispersions = read_dispersions(child(root, "dispersions"), path, defaults);
  const YAML::Node list = child(root, "scenarios");
  if (!list.IsDefined() || !list.IsSequence() || list.size() == 0) {
    fail(yaml_where(list.IsDefined() ? list : root, path), "scenarios: expected a non-empty list of {file, runs}");
  }
  const fs::path base = fs::path(path).parent_path();
  std::set<std::string> ids;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const YAML::Node e = list[i];
    const std::string where = yaml_where(e, path);
    if (!e.IsMap()) fail(where, "scenarios[" + std::to_string(i) + "]: expected {file: ..., runs: N}");
    check_keys(e, path, {"file", "runs", "id", "first_seed", "dispersions"}, "scenario entry ");
    ScenarioEntry s;
    s.where = where;
    const YAML::Node f = child(e, "file");
    if (!f.IsDefined() || !f.IsScalar()) fail(where, "scenarios[" + std::to_string(i) + "]: missing file");
    const fs::path fp(f.as<std::string>());
    s.file = (fp.is_absolute() ? fp : base / fp).lexically_normal().string();
    if (!fs::is_regular_file(s.file)) fail(yaml_where(f, path), "scenario file " + s.file + " not found");
    const YAML::Node r = child(e, "runs");
    if (!r.IsDefined()) fail(where, "scenarios[" + std::to_string(i) + "]: missing runs");
    try {
      s.runs = r.as<int>();
    } catch (const YAML::Exception&) {
      fail(yaml_where(r, path), "runs: expected a whole number, got '" + r.Scalar() + "'");
    }
    if (s.runs < 1 || s.runs > 100000) fail(yaml_where(r, path), "runs: must be in [1, 100000]");
    s.id = fs::path(s.file).stem().string();
    if (const YAML::Node n = child(e, "id"); n.IsDefined()) s.id = n.as<std::string>();
    if (const YAML::Node n = child(e, "first_seed"); n.IsDefined()) {
      try {
        s.first_seed = static_cast<long long>(n.as<std::uint32_t>());
      } catch (const YAML::Exception&) {
        fail(yaml_where(n, path), "first_seed: expected a whole number in [0, 4294967295], got '" + n.Scalar() + "'");
      }
    }
    // Ids become directory names: keep them to a safe alphabet.
    if (s.id.empty() || s.id.size() > 64 ||
        !std::all_of(s.id.begin(), s.id.end(), [](char ch) {
          return std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-';
        })) {
      fail(where, "scenario id '" + s.id + "' must be 1-64 letters, digits, '_' or '-' (set id:)");
    }
    if (!ids.insert(s.id).second) fail(where, "scenario id '" + s.id + "' used twice (set a distinct id:)");
    s.dispersions = read_dispersions(child(e, "dispersions"), path, defaults);
    c.scenarios.push_back(s);
  }
  return c;
}

std::vector<PlannedRun> make_plan(const Campaign& c) {
  std::vector<PlannedRun> plan;
  const sim::Scenario defaults_s = sim::Scenario::defaults();  // read models/vehicle.yaml once
  for (const ScenarioEntry& e : c.scenarios) {
    const YAML::Node file_node = load_yaml_file(e.file);
    // Entry dispersions replace campaign ones of the same key; in key order. (Sorted through
    // a map: yaml-cpp's Node assignment writes into the shared node, so no std::sort of specs.)
    std::map<std::string, const Dispersion*> by_key;
    for (const Dispersion& d : c.dispersions) by_key[d.key] = &d;
    for (const Dispersion& d : e.dispersions) by_key[d.key] = &d;
    std::vector<const Dispersion*> ds;
    for (const auto& kv : by_key) ds.push_back(kv.second);
    {
      sim::Scenario base = defaults_s;
      read_params(file_node, e.file, base);
      if (base.vehicle.control != "closed_loop") {
        fail(e.where, e.file + ": vehicle.control is '" + base.vehicle.control +
                          "'; a campaign needs closed_loop scenarios");
      }
    }
    const int width = std::max<int>(4, static_cast<int>(std::to_string(e.runs - 1).size()));
    for (int i = 0; i < e.runs; ++i) {
      PlannedRun r;
      r.scenario = e.id;
      r.scenario_file = e.file;
      r.index = i;
      r.plan_index = static_cast<int>(plan.size());
      r.id = fmt::format("{}-{:0{}d}", e.id, i, width);
      r.seed = e.first_seed >= 0 ? static_cast<std::uint64_t>(e.first_seed + i) : run_seed(c.seed, e.id, i);
      for (const Dispersion* d : ds) {
        r.sampled.emplace_back(d->key, d->sample(sim::derive_seed(r.seed, "dispersion/" + d->key)));
      }
      sim::Scenario s = defaults_s;
      try {
        read_params(run_node(file_node, r), e.file, s);
      } catch (const ConfigError& err) {
        const std::string msg = err.what();
        std::string where = e.where, key;
        for (const auto& [k, v] : r.sampled) {
          if (msg.find(k) != std::string::npos) {
            key = k;
            where = by_key.at(k)->where;
          }
        }
        if (!key.empty()) {
          std::string value;
          for (const auto& [k, v] : r.sampled) {
            if (k == key) value = YAML::Dump(v);
          }
          fail(where, "dispersion of '" + key + "' gave run " + r.id + " the value " + value +
                          ", which the scenario rejects: " + msg);
        }
        fail(where, "run " + r.id + " with its sampled values is not a valid scenario: " + msg);
      }
      r.duration_s = s.duration_s;
      r.flight_plugin = c.flight_plugin;
      plan.push_back(std::move(r));
    }
  }
  return plan;
}

std::string run_scenario_yaml(const PlannedRun& r) {
  const sim::Scenario defaults_s = sim::Scenario::defaults();
  sim::Scenario s = defaults_s;
  const std::string plugin_default = s.flight.plugin, python_default = s.flight.python;
  read_params(run_node(load_yaml_file(r.scenario_file), r), r.scenario_file, s);
  // The campaign's flight plugin, else the scenario's (a relative path from its file).
  if (!r.flight_plugin.empty()) {
    s.flight.plugin = r.flight_plugin;
  } else if (s.flight.plugin != plugin_default) {
    s.flight.plugin = flight::resolve_plugin_path(s.flight.plugin, r.scenario_file);
  }
  if (s.flight.python != python_default) s.flight.python = flight::resolve_python_path(s.flight.python, r.scenario_file);
  // Taken to its fixed point: unit scales such as deg -> rad round once.
  std::string text = yaml_to_string(params_to_yaml(s));
  for (int k = 0; k < 3; ++k) {
    sim::Scenario again = defaults_s;
    read_params(YAML::Load(text), r.id + "/scenario.yaml", again);
    const std::string next = yaml_to_string(params_to_yaml(again));
    if (next == text) break;
    text = next;
  }
  return text;
}

std::vector<std::pair<std::string, std::string>> flatten_value(const std::string& key,
                                                               const YAML::Node& v) {
  std::vector<std::pair<std::string, std::string>> out;
  if (v.IsSequence()) {
    for (std::size_t i = 0; i < v.size(); ++i) {
      out.emplace_back(key + "[" + std::to_string(i) + "]", v[i].Scalar());
    }
  } else {
    out.emplace_back(key, v.Scalar());
  }
  return out;
}

}  // namespace lander::campaign
