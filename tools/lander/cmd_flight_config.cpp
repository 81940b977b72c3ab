// `lander flight-config [SCENARIO.yaml] [--defaults]`: prints what the flight software
// believes (the resolved flight configuration) as YAML: the scenario's `flight:` section on top
// of the file it names (default models/flight.yaml), or with --defaults the in-class defaults
// (the content models/flight.yaml must hold; tests/flight checks they agree).
#include <iostream>

#include "command.h"
#include "lander/flight/flight_config.h"
#include "lander/sim/scenario.h"

namespace lander::cli {
namespace {

int flight_config(const Args& args) {
  ArgParser a(args, {}, {"defaults"});
  if (a.positional().size() > 1 || (a.flag("defaults") && !a.positional().empty())) {
    throw UsageError("usage: lander flight-config [SCENARIO.yaml | --defaults]");
  }
  flight::FlightConfig c;
  if (a.flag("defaults")) {
    c.validate();
  } else if (a.positional().empty()) {
    c = flight::FlightConfig::load(flight::default_flight_file());
  } else {
    c = sim::Scenario::load(a.positional()[0]).flight;
  }
  YAML::Node node = params_to_yaml(c);
  if (a.flag("defaults")) {
    node.remove("file");
    node.remove("target");
    node.remove("plugin");  // which software flies, not one of its parameters
    node.remove("python");
    node.remove("plugin_config");
  }
  std::cout << yaml_to_string(node) << "\n";
  return kExitOk;
}

const LanderCommand reg("flight-config",
                        "flight-config [SCENARIO.yaml | --defaults]: print the flight software's "
                        "resolved configuration (what it believes)",
                        Kind::Command, flight_config);

}  // namespace
}  // namespace lander::cli
