// The flight software's own configuration: everything the estimator and the controller know,
// like an autopilot's parameter file. Nominal values live in models/flight.yaml; a scenario
// points at another file (`flight.file`) or overrides keys in its `flight:` section. The
// simulator's plant keys (vehicle mass, camera as imaged, platform height, magnetic field,
// gravity, ...) describe the truth and never flow in here: a mismatch between the two is
// what a software-in-the-loop run is for (docs/design/architecture.md, "Configuration").
#pragma once

#include <string>

#include "lander/controller/params.h"
#include "lander/estimator/altitude_fusion.h"
#include "lander/estimator/navigation.h"
#include "lander/estimator/path_extractor.h"
#include "lander/core/params_io.h"
#include "lander/core/sample_screen.h"
#include "lander/core/types.h"
#include "lander/estimator/vision_params.h"

namespace lander::flight {

// The flight software's camera: its calibration and what it believes about its frames' timing
// (issue 54). The driver reports each frame's exposure and stamp (CameraFrameIn); these say how
// the flight software reads them, and may differ from the camera's truth (the scenario's
// camera.rolling_shutter_readout_ms, camera.stamp_at_arrival): a miscalibrated belief is a
// plant/flight mismatch like any other.
struct FlightCamera : CameraModel {
  double readout_s{-1e-3};     ///< rolling-shutter readout it assumes, first row to last (s);
                               ///< negative: the readout the driver reports with each frame.
                               ///< YAML readout_ms
  double stamp_delay_s{0.0};   ///< time from the last row's exposure end to the driver's stamp
                               ///< it assumes (s): the exposure is placed that much before the
                               ///< stamp (0: stamped at the exposure end). YAML stamp_delay_ms
  void validate() const {
    CameraModel::validate();
    check_fields(*this);
  }
  // The exposure the flight software works with: the driver's, moved to end stamp_delay before
  // the stamp and given the believed readout (the rows' own exposure kept). With the defaults
  // the driver's interval unchanged.
  ExposureInterval believed_exposure(const ExposureInterval& reported, double stamp_s) const;
};

template <class V>
void visit_fields(V& v, FlightCamera& p) {
  visit_fields(v, static_cast<CameraModel&>(p));
  v("readout_ms", p.readout_s, range::at_most(100), "ms",
    "rolling-shutter readout it assumes (negative: the driver's per-frame value)", 1e-3);
  v("stamp_delay_ms", p.stamp_delay_s, range::closed(0, 1000), "ms",
    "time from the exposure end to the driver's stamp it assumes", 1e-3);
}

// The estimator's stages.
struct EstimatorParams {
  VisionParams vision;
  AltitudeFusionParams altitude;   ///< holds the platform-height prior (platform_height_m)
  NavigationParams navigation;     ///< holds gravity and the magnetic reference field
  SampleLimits sample_limits;      ///< plausibility limits of sensor samples and vision results
  PathExtractorParams path;        ///< the route's centre points (seed 003 eq. 6-9)
  void validate() const {
    validate_nested("path", path);
    validate_nested("vision", vision);
    validate_nested("altitude", altitude);
    validate_nested("navigation", navigation);
    validate_nested("sample_limits", sample_limits);
  }
};

template <class V>
void visit_fields(V& v, EstimatorParams& p) {
  v.nested("vision", p.vision);
  v.nested("altitude", p.altitude);
  v.nested("navigation", p.navigation);
  v.nested("sample_limits", p.sample_limits);
  v.nested("path", p.path);
}

struct FlightConfig {
  // The parameter file these values start from (an absolute path once loaded; the resolved
  // scenario names it). Empty: the in-class defaults, which equal models/flight.yaml.
  std::string file;
  std::string target_path{models_dir() + "/target.yaml"};  ///< target YAML
  FlightCamera camera;             ///< camera calibration (intrinsics, distortion) and timing
  CameraMount mount;               ///< calibrated camera mount X_BC
  EstimatorParams estimator;
  ctl::ControllerParams controller;  ///< holds the nominal vehicle model (controller.vehicle)
  // Which flight software flies (flight_plugin.h): empty for ours, built in; else a plugin
  // file (a relative path is taken from the file that names it: the scenario, or this
  // parameter file). Not parameters of our stack: `lander flight-config --defaults` omits them.
  std::string plugin;
  // Or a flight software written in Python: "FILE.py:CLASS" (the Python package, python/;
  // `lander run` hands such a run to `python3 -m lander run`). A relative FILE is taken from
  // the file that names it.
  std::string python;
  // The plugin's (or the Python class's) own configuration, a free-form mapping it parses
  // itself.
  YAML::Node plugin_config{YAML::NodeType::Map};

  // Throws ConfigError naming the key. Checks that the estimator's and the vehicle model's
  // gravity agree (one belief about g).
  void validate() const;

  // Loads a flight parameter file (every key optional, on top of the in-class defaults).
  static FlightConfig load(const std::string& path);
};

template <class V>
void visit_fields(V& v, FlightConfig& p) {
  v("file", p.file, range::any, "", "The parameter file these values start from");
  v("target", p.target_path, range::any, "", "target YAML");
  v.nested("camera", p.camera);
  v.nested("mount", p.mount);
  v.nested("estimator", p.estimator);
  v.nested("controller", p.controller);
  v("plugin", p.plugin, range::any, "", "Which flight software flies (flight_plugin.h)");
  v("python", p.python, range::any, "", "Or a flight software written in Python");
  v("plugin_config", p.plugin_config, range::any, "",
    "The plugin's (or the Python class's) own configuration");
}

// The default flight parameter file, models/flight.yaml.
std::string default_flight_file();

// The in-class defaults as the text of models/flight.yaml: every key of the flight
// configuration (not which software flies, nor the file names) with its description, unit
// and range as a comment. `lander flight-config --defaults` prints it; regenerate the file
// with `build/lander flight-config --defaults > models/flight.yaml` (tests/flight checks
// that the file is this text).
std::string flight_defaults_yaml();

// The flight parameter file a scenario's `flight.file` value names: empty -> models/flight.yaml;
// a relative path is taken from the scenario file's folder. Returns an absolute path.
std::string resolve_flight_file(const std::string& file_value, const std::string& scenario_file);

// A relative flight.plugin path taken from the folder of `naming_file` (absolute result);
// empty stays empty (ours) and an absolute path stays as it is.
std::string resolve_plugin_path(const std::string& plugin, const std::string& naming_file);
// The same for flight.python's "FILE.py:CLASS" (the FILE part).
std::string resolve_python_path(const std::string& python, const std::string& naming_file);

}  // namespace lander::flight
