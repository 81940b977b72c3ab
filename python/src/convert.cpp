#include "convert.h"

#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "lander/core/params_io.h"

namespace lander::py {

namespace pyb = pybind11;

YAML::Node to_yaml(const pyb::handle& o) {
  if (o.is_none()) return YAML::Node(YAML::NodeType::Null);
  if (pyb::isinstance<pyb::bool_>(o)) return YAML::Node(o.cast<bool>() ? "true" : "false");
  if (pyb::isinstance<pyb::int_>(o)) return YAML::Node(pyb::str(o).cast<std::string>());
  if (pyb::isinstance<pyb::float_>(o)) {
    std::ostringstream s;
    s.precision(17);
    s << o.cast<double>();
    return YAML::Node(s.str());
  }
  if (pyb::isinstance<pyb::str>(o)) return YAML::Node(o.cast<std::string>());
  if (pyb::isinstance<pyb::dict>(o)) {
    YAML::Node m(YAML::NodeType::Map);
    for (const auto& kv : o.cast<pyb::dict>()) {
      if (!pyb::isinstance<pyb::str>(kv.first)) throw ConfigError("scenario keys must be strings, got " + std::string(pyb::repr(kv.first)));
      m[kv.first.cast<std::string>()] = to_yaml(kv.second);
    }
    return m;
  }
  if (pyb::isinstance<pyb::list>(o) || pyb::isinstance<pyb::tuple>(o)) {
    YAML::Node seq(YAML::NodeType::Sequence);
    for (const auto& x : o) seq.push_back(to_yaml(x));
    return seq;
  }
  // NumPy scalars and arrays: through their Python value.
  if (pyb::hasattr(o, "tolist")) return to_yaml(o.attr("tolist")());
  throw ConfigError("cannot use a " + std::string(pyb::str(o.get_type().attr("__name__"))) + " in a scenario (" +
                    std::string(pyb::repr(o)) + ")");
}

pyb::object from_yaml(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Map: {
      pyb::dict d;
      for (const auto& kv : n) d[pyb::str(kv.first.Scalar())] = from_yaml(kv.second);
      return std::move(d);
    }
    case YAML::NodeType::Sequence: {
      pyb::list l;
      for (const auto& x : n) l.append(from_yaml(x));
      return std::move(l);
    }
    case YAML::NodeType::Scalar: {
      const std::string& s = n.Scalar();
      if (n.Tag() == "!") return pyb::str(s);  // quoted: a string
      long long i;
      double d;
      bool b;
      if (YAML::convert<long long>::decode(n, i)) return pyb::int_(i);
      if (YAML::convert<double>::decode(n, d)) return pyb::float_(d);
      if (YAML::convert<bool>::decode(n, b)) return pyb::bool_(b);
      return pyb::str(s);
    }
    default:
      return pyb::none();
  }
}

pyb::object from_json_text(const std::string& text) {
  return pyb::module_::import("json").attr("loads")(text);
}

void assign_dotted(YAML::Node root, const std::string& key, const YAML::Node& value) {
  YAML::Node cur = root;
  std::size_t start = 0;
  for (;;) {
    const std::size_t dot = key.find('.', start);
    const std::string part = key.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (part.empty()) throw ConfigError("invalid override key '" + key + "': empty part");
    if (!cur.IsMap() && !cur.IsNull()) throw ConfigError("invalid override key '" + key + "': '" + part + "' is inside a value");
    if (dot == std::string::npos) {
      cur[part] = value;
      return;
    }
    YAML::Node next = cur[part];
    if (!next.IsDefined() || next.IsNull()) {
      cur[part] = YAML::Node(YAML::NodeType::Map);
      next = cur[part];
    }
    cur.reset(next);
    start = dot + 1;
  }
}

// The scenario a Python caller gives: a path, or a dict with a scenario file's keys; then the
// dotted overrides, then the seed.
sim::Scenario scenario_from(const pyb::object& scenario, const pyb::object& overrides, const pyb::object& seed) {
  YAML::Node root;
  std::string name;
  if (pyb::isinstance<pyb::str>(scenario) || pyb::hasattr(scenario, "__fspath__")) {
    name = pyb::str(pyb::module_::import("os").attr("fspath")(scenario));
    root = load_yaml_file(name);
  } else if (pyb::isinstance<pyb::dict>(scenario)) {
    name = (std::filesystem::current_path() / "<dict>").string();
    root = to_yaml(scenario);
  } else {
    throw ConfigError("scenario: expected a path or a dict, got " + std::string(pyb::repr(scenario)));
  }
  if (!overrides.is_none()) {
    if (!root.IsMap()) root = YAML::Node(YAML::NodeType::Map);
    for (const auto& kv : overrides.cast<pyb::dict>()) assign_dotted(root, kv.first.cast<std::string>(), to_yaml(kv.second));
  }
  sim::Scenario s = sim::Scenario::load_node(root, name);
  if (!seed.is_none()) s.seed = seed.cast<std::uint64_t>();
  return s;
}

}  // namespace lander::py
