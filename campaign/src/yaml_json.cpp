#include "yaml_json.h"

#include <cmath>

#include <fmt/format.h>

namespace lander::campaign {

nlohmann::ordered_json yaml_to_json(const YAML::Node& v) {
  if (v.IsSequence()) {
    nlohmann::ordered_json a = nlohmann::ordered_json::array();
    for (std::size_t i = 0; i < v.size(); ++i) a.push_back(yaml_to_json(v[i]));
    return a;
  }
  if (!v.IsScalar()) return nullptr;
  const std::string& s = v.Scalar();
  // Whole numbers as integers; other numbers as doubles; the rest as strings.
  try {
    std::size_t used = 0;
    const long long i = std::stoll(s, &used);
    if (used == s.size()) return i;
  } catch (const std::exception&) {
  }
  try {
    std::size_t used = 0;
    const double d = std::stod(s, &used);
    if (used == s.size() && std::isfinite(d)) return d;
  } catch (const std::exception&) {
  }
  return s;
}

std::string json_scalar_text(const nlohmann::ordered_json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_number_integer()) return std::to_string(v.get<long long>());
  if (v.is_number()) return fmt::format("{}", v.get<double>());  // shortest round-trip form
  if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
  return "";
}

}  // namespace lander::campaign
