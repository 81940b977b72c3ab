// Flight softwares written in Python behind the seam (lander/flight/flight_software.h): an
// object with the seam's methods (on_imu, begin_frame, ...) flies as a FlightSoftware; an
// object with a landing logic's `update` flies on our estimator, detector and autopilot
// (CompanionStack, lander/flight/components.h). Every call into Python holds the GIL; the
// simulator's loop runs without it.
#pragma once

#include <memory>
#include <string>

#include <pybind11/pybind11.h>

#include "lander/flight/flight_software.h"
#include "lander/sim/scenario.h"

namespace lander::py {

// The flight software for `obj`, built with the scenario's flight configuration. Throws
// ConfigError when obj has neither shape.
std::unique_ptr<flight::FlightSoftware> make_python_flight(const sim::Scenario& s, pybind11::object obj);

// The object flight.python ("FILE.py:CLASS") names, built as CLASS(flight_config: dict,
// plugin_config: dict) (lander/_flight.py).
pybind11::object load_python_flight(const sim::Scenario& s);

// Registers the sample, estimate and frame types the Python flight softwares receive.
void bind_flight_types(pybind11::module_& m);

}  // namespace lander::py
