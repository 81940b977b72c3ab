#include "lander/flight/flight_config.h"

#include "lander/core/annotated_yaml.h"

#include <cmath>
#include <filesystem>

namespace lander::flight {

ExposureInterval FlightCamera::believed_exposure(const ExposureInterval& reported, double stamp_s) const {
  ExposureInterval e = reported;
  if (stamp_delay_s != 0.0) {  // the exposure ends stamp_delay before the stamp
    const double shift = (stamp_s - stamp_delay_s) - e.t_end_s;
    e.t_start_s += shift;
    e.t_end_s += shift;
  }
  if (readout_s >= 0.0 && readout_s != e.readout_s) {  // the believed readout, rows' exposure kept
    const double row_exposure = e.row_exposure_s();
    e.readout_s = readout_s;
    e.t_start_s = e.t_end_s - row_exposure - readout_s;
  }
  return e;
}

void FlightConfig::validate() const {
  require(!target_path.empty(), "target", "must name a target YAML");
  require(plugin.empty() || python.empty(), "python", "one flight software flies: flight.plugin is set too");
  require(python.empty() || (python.rfind(':') != std::string::npos && python.rfind(':') + 1 < python.size()),
          "python", "must be FILE.py:CLASS (got '" + python + "')");
  validate_nested("camera", camera);
  validate_nested("mount", mount);
  validate_nested("estimator", estimator);
  validate_nested("controller", controller);
  const double g_nav = estimator.navigation.gravity_mps2;
  const double g_veh = controller.vehicle.gravity_mps2;
  require(std::abs(g_nav - g_veh) <= 1e-9 * std::max(1.0, std::abs(g_veh)),
          "estimator.navigation.gravity_mps2",
          "must equal controller.vehicle.gravity_mps2 (the flight software has one belief about "
          "gravity)");
}

FlightConfig FlightConfig::load(const std::string& path) {
  namespace fs = std::filesystem;
  FlightConfig c;
  const YAML::Node root = load_yaml_file(path);
  read_params(root, path, c);
  c.file = fs::absolute(path).lexically_normal().string();
  // A relative target path is taken from this file's folder.
  if (root.IsMap() && root["target"] && fs::path(c.target_path).is_relative()) {
    c.target_path = (fs::path(c.file).parent_path() / c.target_path).lexically_normal().string();
  }
  c.plugin = resolve_plugin_path(c.plugin, c.file);
  c.python = resolve_python_path(c.python, c.file);
  return c;
}

std::string default_flight_file() { return models_dir() + "/flight.yaml"; }

std::string resolve_flight_file(const std::string& file_value, const std::string& scenario_file) {
  namespace fs = std::filesystem;
  if (file_value.empty()) return fs::absolute(default_flight_file()).lexically_normal().string();
  fs::path p(file_value);
  if (p.is_relative()) p = fs::path(scenario_file).parent_path() / p;
  return fs::absolute(p).lexically_normal().string();
}

std::string resolve_python_path(const std::string& python, const std::string& naming_file) {
  const auto colon = python.rfind(':');
  if (python.empty() || colon == std::string::npos) return python;
  return resolve_plugin_path(python.substr(0, colon), naming_file) + python.substr(colon);
}

std::string resolve_plugin_path(const std::string& plugin, const std::string& naming_file) {
  namespace fs = std::filesystem;
  if (plugin.empty() || fs::path(plugin).is_absolute()) return plugin;
  return fs::absolute(fs::path(naming_file).parent_path() / plugin).lexically_normal().string();
}

std::string flight_defaults_yaml() {
  FlightConfig c;
  c.validate();
  const std::vector<std::string> header = {
      "The flight software's own configuration: its nominal values (what it believes about the",
      "vehicle, the camera, the target and the world). Not the simulator's truth: the scenario's",
      "plant keys (vehicle.model, camera, cart.platform_height_m, sensors, world) describe the",
      "world as it is, and a scenario overrides these beliefs only in its `flight:` section or by",
      "naming another file with `flight.file`. Layout: flight/include/lander/flight/flight_config.h.",
      "The target geometry is models/target.yaml unless `target:` names another file (relative to",
      "this file's folder).",
      "",
      "GENERATED from the in-class defaults: `build/lander flight-config --defaults >",
      "models/flight.yaml` (tests/flight fails when this file differs). Each key's comment is what",
      "its visit_fields says of it: description (unit; allowed range).",
  };
  return annotated_params_yaml(c, header, {"file", "target", "plugin", "python", "plugin_config"});
}

}  // namespace lander::flight
