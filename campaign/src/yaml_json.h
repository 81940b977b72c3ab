// Sampled values travel from YAML (the campaign and scenario files) to JSON (plan.json,
// run.json, campaign.json): numbers stay numbers, everything else a string, lists arrays.
#pragma once

#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

namespace lander::campaign {

nlohmann::ordered_json yaml_to_json(const YAML::Node& v);

// A JSON number or string as the text a CSV cell or a message shows.
std::string json_scalar_text(const nlohmann::ordered_json& v);

}  // namespace lander::campaign
