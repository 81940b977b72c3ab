#include "lander/sim/scenario.h"

#include <cmath>

namespace lander::sim {

void VehicleSetup::validate() const {
  require(control == "closed_loop" || control == "kinematic", "control",
          "must be closed_loop or kinematic (got '" + control + "')");
  if (control == "kinematic") {
    require(!waypoints.empty(), "waypoints", "a kinematic vehicle needs waypoints");
  }
  for (std::size_t i = 0; i < waypoints.size(); ++i) {
    validate_item("waypoints", i, waypoints[i]);
    require(i == 0 || waypoints[i].t_s > waypoints[i - 1].t_s,
            "waypoints[" + std::to_string(i) + "].t_s", "times must increase");
  }
  require(start_p_W_m.z() > 0.3, "start_m", "start height must be > 0.3 m");
  validate_nested("model", model);
}

void Scenario::validate() const {
  check_fields(*this);
  require(expect_outcome == "landed" || expect_outcome == "route_end", "expect_outcome",
          "must be landed or route_end (got '" + expect_outcome + "')");
  validate_nested("world", world);
  validate_nested("camera", camera);
  validate_nested("render", render);
  validate_nested("cart", cart);
  validate_nested("vehicle", vehicle);
  validate_nested("sensors", sensors);
  validate_nested("wind", wind);
  validate_nested("computer", computer);
  validate_nested("flight", flight);
  validate_nested("faults", faults);
  validate_nested("video", video);
  require(cart.path != "route" || world.route.present(), "cart.path",
          "'route' needs a route: world.route.waypoints is empty");
  if (cart.path == "route") {
    const RouteGeometry route(world.route);
    require(cart.route_start_m < route.length(), "cart.route_start_m",
            "must be less than the route's length " + std::to_string(route.length()) + " m");
  }
  // camera.mp4 is the camera image divided by video.camera_scale_div, rounded down to even
  // sizes for H.264; too small a frame makes ffmpeg fail at run time.
  const int video_w = camera.intrinsics.width_px / video.camera_scale_div / 2 * 2;
  const int video_h = camera.intrinsics.height_px / video.camera_scale_div / 2 * 2;
  require(video_w >= kMinVideoSidePx && video_h >= kMinVideoSidePx, "video.camera_scale_div",
          "camera.mp4 would be " + std::to_string(video_w) + "x" + std::to_string(video_h) +
              " px; both sides must be >= " + std::to_string(kMinVideoSidePx) + " px");
}

Scenario Scenario::defaults() {
  Scenario s;
  const std::string vehicle_yaml = models_dir() + "/vehicle.yaml";
  read_params(load_yaml_file(vehicle_yaml), vehicle_yaml, s.vehicle.model);
  s.flight = flight::FlightConfig::load(flight::default_flight_file());
  return s;
}

Scenario Scenario::load(const std::string& path) { return load_node(load_yaml_file(path), path); }

Scenario Scenario::load_node(const YAML::Node& root, const std::string& path) {
  Scenario s = defaults();
  // The flight parameter file first (flight.file), then the scenario's keys on top of it.
  std::string flight_file = flight::resolve_flight_file("", path);
  if (root.IsMap() && root["flight"] && root["flight"].IsMap() && root["flight"]["file"]) {
    const YAML::Node f = root["flight"]["file"];
    if (!f.IsScalar()) {
      throw ConfigError(yaml_where(f, path) + ": invalid value for 'flight.file': expected a path");
    }
    flight_file = flight::resolve_flight_file(f.Scalar(), path);
    try {
      s.flight = flight::FlightConfig::load(flight_file);
    } catch (const ConfigError& e) {
      throw ConfigError(yaml_where(f, path) + ": flight.file: " + e.what());
    }
  }
  if (root.IsMap()) {
    for (const auto& kv : root) {
      const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : "";
      if (key == "estimator" || key == "controller") {
        throw ConfigError(yaml_where(kv.first, path) + ": the key '" + key + "' moved to 'flight." + key +
                          "' (the flight software's own configuration, models/flight.yaml); "
                          "estimator.vision_latency_ms and measured_latency are now under "
                          "'computer:'");
      }
    }
  }
  const std::string plugin_before = s.flight.plugin, python_before = s.flight.python;  // from flight.file
  read_params(root, path, s);
  s.flight.file = flight_file;
  if (s.flight.plugin != plugin_before) s.flight.plugin = flight::resolve_plugin_path(s.flight.plugin, path);
  if (s.flight.python != python_before) s.flight.python = flight::resolve_python_path(s.flight.python, path);
  return s;
}

void scripted_vehicle_state(const VehicleSetup& v, double t, Eigen::Isometry3d& X_WB,
                            Eigen::Vector3d& v_W, Eigen::Vector3d& omega_B) {
  const auto& w = v.waypoints;
  std::size_t i = 0;
  while (i + 1 < w.size() && w[i + 1].t_s <= t) ++i;
  Eigen::Vector3d p = w[i].p_W_m, rpy = w[i].rpy_rad;
  v_W.setZero();
  omega_B.setZero();
  if (i + 1 < w.size() && t > w[i].t_s) {
    const double dt = w[i + 1].t_s - w[i].t_s, a = (t - w[i].t_s) / dt;
    p = (1 - a) * w[i].p_W_m + a * w[i + 1].p_W_m;
    rpy = (1 - a) * w[i].rpy_rad + a * w[i + 1].rpy_rad;
    v_W = (w[i + 1].p_W_m - w[i].p_W_m) / dt;
    // Body rates from the finite rotation over a short interval.
    const double h = 1e-4;
    const Eigen::Vector3d rpy2 = rpy + h * (w[i + 1].rpy_rad - w[i].rpy_rad) / dt;
    const Eigen::AngleAxisd d(R_from_rpy(rpy).transpose() * R_from_rpy(rpy2));
    omega_B = d.axis() * d.angle() / h;
  }
  X_WB = Eigen::Isometry3d::Identity();
  X_WB.linear() = R_from_rpy(rpy);
  X_WB.translation() = p;
}

}  // namespace lander::sim
