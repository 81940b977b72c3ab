// The Python package's compiled part, lander._lander (pybind11): runs, our detector, and the
// types a Python flight software receives. The package's Python modules (python/lander/)
// build the user-facing API on it.
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "convert.h"
#include "lander/estimator/target.h"
#include "lander/estimator/vision_detector.h"
#include "lander/flight/flight_plugin.h"
#include "lander/sim/run.h"
#include "lander/sim/scenario.h"
#include "lander/sim/util/output_files.h"

#include <opencv2/imgcodecs.hpp>
#include "py_flight.h"
#include "py_sim.h"

namespace pyb = pybind11;
using namespace pybind11::literals;

namespace lander::py {
namespace {

// The flight software a run flies: the `flight` object, else the scenario's flight.python,
// else nothing set (the scenario's own: ours or its plugin).
void choose_flight(const sim::Scenario& s, const pyb::object& flight_obj, sim::RunOptions& o) {
  pyb::object obj = flight_obj;
  if (obj.is_none() && !s.flight.python.empty()) obj = load_python_flight(s);
  if (obj.is_none()) return;
  auto holder = std::make_shared<pyb::object>(obj);
  o.flight_factory = [holder](const sim::Scenario& sc) {
    std::unique_ptr<flight::FlightSoftware> fs = make_python_flight(sc, *holder);
    pyb::gil_scoped_acquire gil;
    *holder = pyb::object();
    return fs;
  };
}

pyb::object run(const pyb::object& scenario, const pyb::object& seed, const pyb::object& out, bool video,
                const pyb::object& overrides, const pyb::object& flight_obj, const std::string& vision_schedule) {
  sim::Scenario s = scenario_from(scenario, overrides, seed);
  sim::RunOptions o;
  std::string tmp;
  if (out.is_none()) {
    tmp = pyb::str(pyb::module_::import("tempfile").attr("mkdtemp")("prefix"_a = "lander_run_"));
    o.out_dir = tmp;
  } else {
    o.out_dir = pyb::str(pyb::module_::import("os").attr("fspath")(out));
  }
  o.video = video;
  o.vision_schedule = vision_schedule;
  choose_flight(s, flight_obj, o);
  nlohmann::ordered_json summary;
  {
    pyb::gil_scoped_release nogil;
    summary = sim::run_scenario(s, o);
  }
  if (!tmp.empty()) pyb::module_::import("shutil").attr("rmtree")(tmp, "ignore_errors"_a = true);
  return from_json_text(summary.dump());
}

// Our ring and code-map detector on single images (stateful: tracking and keyframes follow
// the frames given in order).
class Detector {
 public:
  Detector(const pyb::object& camera, const pyb::object& target, const pyb::object& flight_file) {
    flight::FlightConfig c = flight_file.is_none() ? flight::FlightConfig::load(flight::default_flight_file())
                                                   : flight::FlightConfig::load(pyb::str(flight_file));
    if (!camera.is_none()) {
      if (pyb::isinstance<pyb::dict>(camera)) {
        read_params(to_yaml(camera), "camera", c.camera);
      } else {
        const std::string path = pyb::str(camera);
        const YAML::Node n = load_yaml_file(path);
        read_params(n["intrinsics"] ? n["intrinsics"] : n, path, c.camera);
      }
    }
    if (!target.is_none()) c.target_path = pyb::str(target);
    c.validate();
    detector_ = std::make_unique<RingTargetDetector>(c.camera, TargetGeometry::load(c.target_path), c.estimator.vision);
  }
  pyb::object detect(pyb::array_t<std::uint8_t, pyb::array::c_style | pyb::array::forcecast> image,
                     const Eigen::Vector2d& blur_px) {
    if (image.ndim() != 3 || image.shape(2) != 3) {
      if (image.ndim() != 2) throw ConfigError("detect: expected an H x W x 3 BGR (or H x W grey) uint8 image");
    }
    const int type = image.ndim() == 3 ? CV_8UC3 : CV_8UC1;
    const cv::Mat m(static_cast<int>(image.shape(0)), static_cast<int>(image.shape(1)), type,
                    const_cast<std::uint8_t*>(image.data()));  // no copy: the detector only reads
    RingDetection d;
    {
      pyb::gil_scoped_release nogil;
      d = detector_->detect(m, blur_px);
    }
    pyb::dict r = from_json_text(to_json(d)).cast<pyb::dict>();
    r["X_CP"] = Eigen::Matrix4d(d.X_CP.matrix());
    r["cov"] = d.cov;
    return std::move(r);
  }
  void reset() { detector_->reset(); }

 private:
  std::unique_ptr<RingTargetDetector> detector_;
};

}  // namespace
}  // namespace lander::py

PYBIND11_MODULE(_lander, m) {
  using namespace lander::py;
  m.doc() = "The lander simulator's compiled core (use the lander package)";
  m.attr("__version__") = LANDER_VERSION;
  m.attr("FLIGHT_SOFTWARE_API_VERSION") = lander::flight::kFlightSoftwareApiVersion;
  static pyb::exception<lander::ConfigError> config_error(m, "ConfigError", PyExc_ValueError);
  static pyb::exception<lander::flight::FlightSoftwareError> fs_error(m, "FlightSoftwareError", PyExc_RuntimeError);
  pyb::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const lander::ConfigError& e) {
      config_error(e.what());
    } catch (const lander::flight::FlightSoftwareError& e) {
      fs_error(e.what());
    }
  });
  bind_flight_types(m);
  m.def("run", &run, "scenario"_a, "seed"_a = pyb::none(), "out"_a = pyb::none(), "video"_a = false,
        "overrides"_a = pyb::none(), "flight"_a = pyb::none(), "vision_schedule"_a = "auto",
        "Runs one scenario (a path or a dict); returns summary.json as a dict (see lander.run).");
  pyb::class_<Detector>(m, "Detector", "our ring and code-map detector (see lander.Detector)")
      .def(pyb::init<pyb::object, pyb::object, pyb::object>(), "camera"_a = pyb::none(), "target"_a = pyb::none(),
           "flight_file"_a = pyb::none())
      .def("detect", &Detector::detect, "image"_a, "blur_px"_a = Eigen::Vector2d::Zero())
      .def("reset", &Detector::reset);
  bind_sim(m);
  m.def(
      "target_geometry",
      [](const pyb::object& path) {
        const std::string p = path.is_none() ? lander::models_dir() + "/target.yaml" : std::string(pyb::str(path));
        return from_yaml(params_to_yaml(lander::TargetGeometry::load(p)));
      },
      "path"_a = pyb::none(), "The target's geometry (models/target.yaml by default) as a dict.");
  m.def(
      "write_image",
      [](const std::string& path, pyb::array_t<std::uint8_t, pyb::array::c_style | pyb::array::forcecast> image) {
        const int type = image.ndim() == 3 ? CV_8UC3 : CV_8UC1;
        const cv::Mat mat(static_cast<int>(image.shape(0)), static_cast<int>(image.shape(1)), type,
                          const_cast<std::uint8_t*>(image.data()));
        if (!cv::imwrite(path, mat)) throw lander::ConfigError(path + ": cannot write the image");
      },
      "path"_a, "image"_a, "Writes an H x W x 3 BGR (or H x W) uint8 image (PNG, JPEG, ... by the name).");
}
