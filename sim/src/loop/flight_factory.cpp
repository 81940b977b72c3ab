#include "lander/sim/loop/flight_factory.h"

#include "lander/flight/flight_stack.h"

namespace lander::sim {

std::unique_ptr<flight::FlightSoftware> make_flight_software(const Scenario& s) {
  if (!s.flight.python.empty()) {
    throw ConfigError("invalid value for 'flight.python': a flight software written in Python flies in the Python "
                      "package (python3 -m lander run SCENARIO --out DIR, or lander.run() in Python)");
  }
  if (s.flight.plugin.empty()) return std::make_unique<flight::FlightStack>(s.flight);
  const std::string flight_yaml = yaml_to_string(params_to_yaml(s.flight));
  const std::string config_yaml = YAML::Dump(s.flight.plugin_config.IsDefined() ? s.flight.plugin_config
                                                                                  : YAML::Node(YAML::NodeType::Map));
  return flight::load_flight_plugin(s.flight.plugin, flight_yaml, config_yaml);
}

flight::FlightSoftwareSource flight_software_source(const Scenario& s) {
  flight::FlightSoftwareSource src;
  if (!s.flight.python.empty()) {
    src.kind = "python";
    src.plugin_path = s.flight.python;
    src.plugin_sha256 = flight::file_sha256(s.flight.python.substr(0, s.flight.python.rfind(':')));
    return src;
  }
  if (s.flight.plugin.empty()) return src;
  src.kind = "plugin";
  src.plugin_path = s.flight.plugin;
  src.plugin_sha256 = flight::file_sha256(s.flight.plugin);
  return src;
}

}  // namespace lander::sim
