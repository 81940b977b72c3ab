// Conversions between Python objects and the project's YAML and JSON trees (the Python
// package, python/src/module.cpp).
#pragma once

#include <string>

#include <pybind11/pybind11.h>
#include <yaml-cpp/yaml.h>

#include "lander/sim/scenario.h"

namespace lander::py {

// A Python scenario (dict, list, str, int, float, bool, None) as a YAML tree, as if read from
// a file (no line marks).
YAML::Node to_yaml(const pybind11::handle& o);
// A YAML tree as Python objects: mappings -> dict, sequences -> list, scalars -> int, float,
// bool or str (in that order of tries), null -> None.
pybind11::object from_yaml(const YAML::Node& n);
// JSON text as Python objects (json.loads: NaN and null as they are written).
pybind11::object from_json_text(const std::string& text);
// Sets the dotted key ("cart.speed_mps") of a scenario tree to `value`, creating mappings on
// the way; a non-mapping in the way is an error naming the key.
void assign_dotted(YAML::Node root, const std::string& key, const YAML::Node& value);

// The scenario a Python caller gives: a path, or a dict with a scenario file's keys (relative
// paths from the working directory); then the dotted overrides, then the seed (None: the
// scenario's). Throws ConfigError naming the key (and, for a file, the line).
sim::Scenario scenario_from(const pybind11::object& scenario, const pybind11::object& overrides,
                            const pybind11::object& seed);

}  // namespace lander::py
