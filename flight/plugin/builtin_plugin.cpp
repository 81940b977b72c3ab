// Our flight stack (FlightStack) as a flight plugin: `lander run S --flight-plugin
// build/flight/liblander_flight_plugin.so` flies exactly what the built-in run flies, through
// the plugin ABI (flight_plugin.h) and the seam; tests/tools/flight_plugin_test.cpp checks that
// summary.json and trace.csv come out byte for byte the same.
#include <memory>

#include <yaml-cpp/yaml.h>

#include "lander/flight/flight_plugin.h"
#include "lander/flight/flight_stack.h"

namespace {

std::unique_ptr<lander::flight::FlightSoftware> create(const LanderFlightPluginArgs& args) {
  lander::flight::FlightConfig config;
  lander::read_params(YAML::Load(args.flight_yaml), "the run's flight configuration", config);
  return std::make_unique<lander::flight::FlightStack>(config);
}

}  // namespace

LANDER_FLIGHT_PLUGIN(create)
