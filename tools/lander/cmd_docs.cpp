// `lander docs probe PROBES.yaml`: the validation the scenario loader applies to single keys,
// for tools/docs/gen_reference.py, which generates docs/reference/ (the allowed range of
// every key) from it. `lander docs transitions`: the landing mode machine's transition table
// (ctl::mode_transitions(), the one the machine enforces) as JSON, for the reference page and
// the diagram (tools/docs/mode_diagram.py). `lander docs keys`: every key's unit, range and
// description as its visitor gives them (core/include/lander/core/field_spec.h).
//
// PROBES.yaml is a list of {key: DOTTED.KEY, value: VALUE}. For each item, in order, a scenario
// that sets only that key to that value is loaded exactly as `lander run` and
// `lander flight-config` load a file (sim::Scenario::load: defaults, the flight file, the keys,
// validate()), and one line is printed: "ok" when it loads, else "error: " and the message
// (newlines as spaces). In-process, so that a thousand probes take seconds instead of the
// minutes a process per probe costs. Exit 0 when every probe ran, 2 for a bad PROBES.yaml.
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

#include "command.h"
#include <nlohmann/json.hpp>

#include "lander/controller/landing_controller.h"
#include "lander/core/params_io.h"
#include "lander/sim/scenario.h"

namespace lander::cli {
namespace {

// The scenario tree that sets only `key` (a dotted path) to `value`.
YAML::Node nested(const std::string& key, const YAML::Node& value) {
  YAML::Node node = value;
  std::string rest = key;
  for (std::size_t dot = rest.rfind('.');; dot = rest.rfind('.')) {
    YAML::Node parent(YAML::NodeType::Map);
    parent[dot == std::string::npos ? rest : rest.substr(dot + 1)] = node;
    node = parent;
    if (dot == std::string::npos) break;
    rest = rest.substr(0, dot);
  }
  return node;
}

std::string one_line(std::string s) {
  for (char& c : s) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return s;
}

int probe(const Args& rest) {
  ArgParser a(rest, {}, {});
  if (a.positional().size() != 1) throw UsageError("usage: lander docs probe PROBES.yaml");
  const YAML::Node probes = load_yaml_file(a.positional()[0]);
  if (!probes.IsSequence()) {
    throw ConfigError(a.positional()[0] + ": expected a list of {key, value}");
  }
  char dir_template[] = "/tmp/lander-docs-probe-XXXXXX";
  if (mkdtemp(dir_template) == nullptr) throw std::runtime_error("cannot create a temporary directory");
  const std::string dir = dir_template;
  const std::string file = dir + "/probe.yaml";
  for (std::size_t i = 0; i < probes.size(); ++i) {
    const YAML::Node p = probes[i];
    if (!p.IsMap() || !p["key"] || !p["key"].IsScalar() || !p["value"]) {
      std::filesystem::remove_all(dir);
      throw ConfigError(yaml_where(p, a.positional()[0]) + ": expected {key: DOTTED.KEY, value: VALUE}");
    }
    {
      std::ofstream out(file, std::ios::trunc);
      out << yaml_to_string(nested(p["key"].Scalar(), p["value"])) << "\n";
    }
    try {
      (void)sim::Scenario::load(file);
      std::cout << "ok\n";
    } catch (const std::exception& e) {
      std::cout << "error: " << one_line(e.what()) << "\n";
    }
  }
  std::filesystem::remove_all(dir);
  return kExitOk;
}

// The transition table: [{from, to, trigger}, ...] in the table's order.
int transitions(const Args& rest) {
  ArgParser a(rest, {}, {});
  if (!a.positional().empty()) throw UsageError("usage: lander docs transitions");
  nlohmann::ordered_json table = nlohmann::ordered_json::array();
  for (const ctl::ModeTransitionRule& r : ctl::mode_transitions()) {
    table.push_back({{"from", ctl::to_string(r.from)}, {"to", ctl::to_string(r.to)}, {"trigger", r.trigger}});
  }
  std::cout << table.dump(2) << "\n";
  return kExitOk;
}

// Every key of the scenario tree (the flight configuration under flight.) with what its
// visitor says of it (field_spec.h): [{key, type, unit, allowed, doc}, ...] in visit order,
// list items as "key[].item".
int keys(const Args& rest) {
  ArgParser a(rest, {}, {});
  if (!a.positional().empty()) throw UsageError("usage: lander docs keys");
  sim::Scenario defaults = sim::Scenario::defaults();
  std::vector<FieldInfo> fields;
  FieldLister lister(&fields);
  visit_fields(lister, defaults);
  nlohmann::ordered_json out = nlohmann::ordered_json::array();
  for (const FieldInfo& f : fields) {
    out.push_back({{"key", f.key}, {"type", f.type}, {"unit", f.unit}, {"allowed", f.allowed},
                   {"doc", f.doc}});
  }
  std::cout << out.dump(2) << "\n";
  return kExitOk;
}

constexpr const char* kDocsUsage =
    "usage: lander docs probe PROBES.yaml | lander docs keys | lander docs transitions";

int docs(const Args& args) {
  if (args.empty()) throw UsageError(kDocsUsage);
  if (args[0] == "probe") return probe(Args(args.begin() + 1, args.end()));
  if (args[0] == "transitions") return transitions(Args(args.begin() + 1, args.end()));
  if (args[0] == "keys") return keys(Args(args.begin() + 1, args.end()));
  throw UsageError(kDocsUsage);
}

const LanderCommand reg("docs",
                        "docs probe PROBES.yaml: validate one key at a time as a scenario would; "
                        "docs keys: every configuration key with its unit, range and "
                        "description as JSON; "
                        "docs transitions: the mode machine's transition table as JSON "
                        "(for tools/docs/gen_reference.py)",
                        Kind::Command, docs);

}  // namespace
}  // namespace lander::cli
