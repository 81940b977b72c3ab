// The run's flight software, through one factory: ours built in (flight::FlightStack), or the
// plugin that the scenario's flight.plugin names (`lander run --flight-plugin` sets it).
#pragma once

#include <memory>
#include <string>

#include "lander/flight/flight_plugin.h"
#include "lander/flight/flight_software.h"
#include "lander/sim/run.h"
#include "lander/sim/scenario.h"

namespace lander::sim {

// Builds the flight software from the scenario's flight configuration only. A plugin gets the
// resolved configuration as YAML text (what flight.resolved.yaml holds) and its
// plugin_config. Throws ConfigError for a bad configuration, flight::PluginError for a plugin
// that cannot be loaded or created.
std::unique_ptr<flight::FlightSoftware> make_flight_software(const Scenario& s);

// Where the run's flight software comes from (flight_software.json, run.json, campaign.csv).
flight::FlightSoftwareSource flight_software_source(const Scenario& s);

}  // namespace lander::sim
