#include "py_flight.h"

#include <cstring>
#include <utility>

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "convert.h"
#include "lander/flight/components.h"
#include "lander/flight/flight_plugin.h"

namespace lander::py {

namespace pyb = pybind11;
using namespace pybind11::literals;

namespace {

// "TypeName: message" of a Python exception (no traceback: the message is for summary.json).
std::string error_text(pyb::error_already_set& e) {
  return std::string(pyb::str(e.type().attr("__name__"))) + ": " + std::string(pyb::str(e.value()));
}

// Calls obj.name(args...) with the GIL; a Python exception becomes a FlightSoftwareError
// naming the software and the method.
template <class... A>
pyb::object call(const pyb::object& obj, const std::string& who, const char* name, A&&... args) {
  try {
    return obj.attr(name)(std::forward<A>(args)...);
  } catch (pyb::error_already_set& e) {
    throw flight::FlightSoftwareError("python flight software '" + who + "' threw in " + name + ": " + error_text(e));
  } catch (const pyb::cast_error& e) {
    throw flight::FlightSoftwareError("python flight software '" + who + "': " + name + ": " + e.what());
  }
}

bool has(const pyb::object& obj, const char* name) { return pyb::hasattr(obj, name); }

template <class T>
T get_or(const pyb::dict& d, const char* key, T fallback) {
  return d.contains(key) && !d[key].is_none() ? d[key].cast<T>() : fallback;
}

Eigen::Vector3d vec3_or_nan(const pyb::dict& d, const char* key) {
  if (!d.contains(key) || d[key].is_none()) return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  return d[key].cast<Eigen::Vector3d>();
}

std::string class_name(const pyb::object& obj) { return pyb::str(obj.get_type().attr("__name__")); }

flight::FlightSoftwareInfo info_of(const pyb::object& obj) {
  if (has(obj, "info")) {
    const pyb::object i = obj.attr("info")();
    if (pyb::isinstance<pyb::dict>(i)) {
      const pyb::dict d = i;
      return {get_or<std::string>(d, "name", class_name(obj)), get_or<std::string>(d, "version", "")};
    }
    const auto t = i.cast<std::pair<std::string, std::string>>();
    return {t.first, t.second};
  }
  return {class_name(obj), "python"};
}

// A copy of the frame's pixels as a read-only H x W x 3 uint8 array (the simulator's buffer
// is reused; a copy of 1280 x 720 x 3 bytes is ~0.3 ms).
pyb::array_t<std::uint8_t> image_copy(const flight::ImageView& v) {
  pyb::array_t<std::uint8_t> a({v.height_px, v.width_px, 3});
  auto* dst = static_cast<std::uint8_t*>(a.mutable_data());
  for (int r = 0; r < v.height_px; ++r) std::memcpy(dst + static_cast<size_t>(r) * v.width_px * 3, v.bgr + static_cast<size_t>(r) * v.stride_bytes, static_cast<size_t>(v.width_px) * 3);
  a.attr("setflags")("write"_a = false);
  return a;
}

flight::FrameReport report_from(const pyb::handle& h) {
  flight::FrameReport r;
  if (h.is_none()) return r;
  const pyb::dict d = h.cast<pyb::dict>();
  r.detected = get_or<bool>(d, "detected", false);
  r.reason = get_or<std::string>(d, "reason", r.detected ? "detected" : "not_detected");
  r.keyframe = get_or<bool>(d, "keyframe", false);
  r.vision_height_m = get_or<double>(d, "vision_height_m", std::numeric_limits<double>::quiet_NaN());
  r.rings = get_or<int>(d, "rings", 0);
  r.reproj_err_px = get_or<double>(d, "reproj_err_px", 0.0);
  r.overlay_text = get_or<std::string>(d, "overlay_text", r.detected ? "detected" : "no target: " + r.reason);
  return r;
}

// --------------------------------------------------------------- a whole flight software

class PyFrameJob final : public flight::FrameJob {
 public:
  PyFrameJob(pyb::object job, std::string who) : job_(std::move(job)), who_(std::move(who)) {}
  ~PyFrameJob() override {
    pyb::gil_scoped_acquire gil;
    job_ = pyb::object();
  }
  void process() override {
    pyb::gil_scoped_acquire gil;
    if (!job_.is_none() && has(job_, "process")) call(job_, who_, "process");
  }
  flight::FrameReport report() const override {
    pyb::gil_scoped_acquire gil;
    if (job_.is_none() || !has(job_, "report")) return flight::FrameReport{};
    return report_from(call(job_, who_, "report"));
  }
  pyb::object job_;
  std::string who_;
};

class PyFlightSoftware final : public flight::FlightSoftware {
 public:
  explicit PyFlightSoftware(pyb::object obj) : obj_(std::move(obj)), info_(info_of(obj_)) {}
  ~PyFlightSoftware() override {
    pyb::gil_scoped_acquire gil;
    obj_ = pyb::object();
  }
  flight::FlightSoftwareInfo info() const override { return info_; }
  void on_baro(const BaroSample& b) override { send("on_baro", b); }
  void on_gps(const GpsSample& g) override { send("on_gps", g); }
  void on_ultrasonic(const UltrasonicSample& u) override { send("on_ultrasonic", u); }
  void on_mag(const MagSample& m) override { send("on_mag", m); }
  void on_platform_telemetry(const GpsSample& g) override { send("on_platform_telemetry", g); }
  std::optional<flight::RotorSpeeds> on_imu(const ImuSample& s) override {
    pyb::gil_scoped_acquire gil;
    const pyb::object r = call(obj_, info_.name, "on_imu", s);
    if (r.is_none()) return std::nullopt;
    flight::RotorSpeeds out;
    out.t_s = s.t_s;
    if (pyb::isinstance<pyb::dict>(r)) {
      const pyb::dict d = r;
      out.motors_cut = get_or<bool>(d, "motors_cut", false);
      if (!out.motors_cut) out.w_radps = d["w_radps"].cast<std::array<double, flight::kRotorCount>>();
    } else {
      out.w_radps = r.cast<std::array<double, flight::kRotorCount>>();
    }
    return out;
  }
  std::unique_ptr<flight::FrameJob> begin_frame(const flight::CameraFrameIn& f) override {
    pyb::gil_scoped_acquire gil;
    pyb::object frame = pyb::module_::import("types").attr("SimpleNamespace")(
        "index"_a = f.index, "t_start_s"_a = f.exposure.t_start_s, "t_end_s"_a = f.exposure.t_end_s,
        "readout_s"_a = f.exposure.readout_s, "stamp_s"_a = f.stamp_s, "image"_a = image_copy(f.image));
    return std::make_unique<PyFrameJob>(has(obj_, "begin_frame") ? call(obj_, info_.name, "begin_frame", frame) : pyb::none(),
                                        info_.name);
  }
  void deliver_frame(std::unique_ptr<flight::FrameJob> job) override {
    pyb::gil_scoped_acquire gil;
    auto& pj = static_cast<PyFrameJob&>(*job);
    if (has(obj_, "deliver_frame")) call(obj_, info_.name, "deliver_frame", pj.job_);
  }
  flight::FlightStatus status() const override {
    pyb::gil_scoped_acquire gil;
    flight::FlightStatus st;
    if (!has(obj_, "status")) return st;
    const pyb::dict d = call(obj_, info_.name, "status").cast<pyb::dict>();
    st.mode = get_or<std::string>(d, "mode", "");
    st.motors_cut = get_or<bool>(d, "motors_cut", false);
    st.aborted = get_or<bool>(d, "aborted", false);
    return st;
  }
  flight::FlightTelemetry telemetry() const override {
    pyb::gil_scoped_acquire gil;
    flight::FlightTelemetry t;
    if (!has(obj_, "telemetry")) return t;
    const pyb::dict d = call(obj_, info_.name, "telemetry").cast<pyb::dict>();
    if (d.contains("p_W_m")) {
      t.nav.valid = true;
      t.nav.p_W_m = d["p_W_m"].cast<Eigen::Vector3d>();
      if (d.contains("v_W_mps")) t.nav.v_W_mps = d["v_W_mps"].cast<Eigen::Vector3d>();
    }
    t.platform_W_m = vec3_or_nan(d, "platform_W_m");
    t.setpoint_W_m = vec3_or_nan(d, "setpoint_W_m");
    return t;
  }
  flight::FlightReport report() const override {
    pyb::gil_scoped_acquire gil;
    flight::FlightReport r;
    if (!has(obj_, "report")) return r;
    const pyb::dict d = call(obj_, info_.name, "report").cast<pyb::dict>();
    r.final_mode = get_or<std::string>(d, "final_mode", "");
    return r;
  }

 private:
  template <class S>
  void send(const char* name, const S& s) {
    pyb::gil_scoped_acquire gil;
    if (has(obj_, name)) call(obj_, info_.name, name, s);
  }
  pyb::object obj_;
  flight::FlightSoftwareInfo info_;
};

// ---------------------------------------------------- a landing logic on our autopilot

class PyLandingLogic final : public flight::LandingLogic {
 public:
  PyLandingLogic(pyb::object obj, std::string who) : obj_(std::move(obj)), who_(std::move(who)) {}
  ~PyLandingLogic() override {
    pyb::gil_scoped_acquire gil;
    obj_ = pyb::object();
  }
  void on_vision(const PlatformObservation& obs) override {
    pyb::gil_scoped_acquire gil;
    call(obj_, who_, "on_vision", obs);
  }
  void on_platform_telemetry(const GpsSample& g) override {
    pyb::gil_scoped_acquire gil;
    if (has(obj_, "on_platform_telemetry")) call(obj_, who_, "on_platform_telemetry", g);
  }
  flight::AutopilotSetpoint update(const flight::LandingInputs& in) override {
    pyb::gil_scoped_acquire gil;
    const pyb::object r = call(obj_, who_, "update", in);
    return setpoint_from(r);
  }
  std::string mode() const override {
    pyb::gil_scoped_acquire gil;
    if (!has(obj_, "mode")) return "python";
    const pyb::object m = obj_.attr("mode");
    return pyb::str(PyCallable_Check(m.ptr()) ? m() : m);
  }
  bool aborted() const override {
    pyb::gil_scoped_acquire gil;
    return has(obj_, "aborted") && pyb::bool_(obj_.attr("aborted"));
  }
  std::optional<Eigen::Vector3d> platform_W_m() const override {
    pyb::gil_scoped_acquire gil;
    if (!has(obj_, "platform_W_m")) return std::nullopt;
    const pyb::object p = obj_.attr("platform_W_m");
    if (p.is_none()) return std::nullopt;
    return p.cast<Eigen::Vector3d>();
  }
  void fill_report(flight::FlightReport& r) const override {
    pyb::gil_scoped_acquire gil;
    if (!has(obj_, "transitions")) return;
    for (const auto& t : obj_.attr("transitions")) {
      const auto tup = t.cast<std::tuple<double, std::string, std::string, std::string>>();
      r.transitions.push_back({std::get<0>(tup), std::get<1>(tup), std::get<2>(tup), std::get<3>(tup)});
    }
  }

 private:
  flight::AutopilotSetpoint setpoint_from(const pyb::object& r) const {
    using K = flight::AutopilotSetpoint::Kind;
    flight::AutopilotSetpoint sp;
    const pyb::dict d = r.cast<pyb::dict>();
    const std::string kind = get_or<std::string>(d, "kind", "velocity");
    if (kind == "position") sp.kind = K::kPosition;
    else if (kind == "velocity") sp.kind = K::kVelocity;
    else if (kind == "attitude_thrust") sp.kind = K::kAttitudeThrust;
    else if (kind == "motors_cut") sp.kind = K::kMotorsCut;
    else throw flight::FlightSoftwareError("python landing logic '" + who_ + "': unknown setpoint kind '" + kind + "'");
    if (d.contains("p_W_m")) sp.p_W_m = d["p_W_m"].cast<Eigen::Vector3d>();
    if (d.contains("v_W_mps")) sp.v_W_mps = d["v_W_mps"].cast<Eigen::Vector3d>();
    if (d.contains("a_W_mps2")) sp.a_W_mps2 = d["a_W_mps2"].cast<Eigen::Vector3d>();
    sp.yaw_rad = get_or<double>(d, "yaw_rad", 0.0);
    if (d.contains("q_WB")) {
      const Eigen::Vector4d q = d["q_WB"].cast<Eigen::Vector4d>();  // w, x, y, z
      sp.q_WB = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
    }
    sp.thrust_N = get_or<double>(d, "thrust_N", 0.0);
    return sp;
  }
  pyb::object obj_;
  std::string who_;
};

}  // namespace

std::unique_ptr<flight::FlightSoftware> make_python_flight(const sim::Scenario& s, pyb::object obj) {
  pyb::gil_scoped_acquire gil;
  if (has(obj, "on_imu")) return std::make_unique<PyFlightSoftware>(std::move(obj));
  if (has(obj, "update") && has(obj, "on_vision")) {
    const flight::FlightSoftwareInfo who = info_of(obj);
    auto logic = std::make_unique<PyLandingLogic>(obj, who.name);
    return std::make_unique<flight::CompanionStack>(s.flight, std::move(logic), who);
  }
  throw ConfigError("a Python flight software has the seam's methods (on_imu, begin_frame, ...) or a landing "
                    "logic's (update, on_vision); " + class_name(obj) + " has neither");
}

pyb::object load_python_flight(const sim::Scenario& s) {
  pyb::gil_scoped_acquire gil;
  const YAML::Node flight_tree = params_to_yaml(s.flight);
  try {
    return pyb::module_::import("lander._flight").attr("load")(s.flight.python, from_yaml(flight_tree),
                                                                from_yaml(s.flight.plugin_config));
  } catch (pyb::error_already_set& e) {
    throw ConfigError("flight.python: " + s.flight.python + ": " + error_text(e));
  }
}

void bind_flight_types(pyb::module_& m) {
  pyb::class_<ImuSample>(m, "ImuSample", "IMU sample: body rates (rad/s) and specific force (m/s^2), in B")
      .def(pyb::init<>())
      .def_readwrite("t_s", &ImuSample::t_s)
      .def_readwrite("gyro_B_radps", &ImuSample::gyro_B_radps)
      .def_readwrite("accel_B_mps2", &ImuSample::accel_B_mps2);
  pyb::class_<BaroSample>(m, "BaroSample", "barometer: static pressure (Pa)")
      .def(pyb::init<>())
      .def_readwrite("t_s", &BaroSample::t_s)
      .def_readwrite("pressure_pa", &BaroSample::pressure_pa);
  pyb::class_<GpsSample>(m, "GpsSample", "GPS fix in W (m, m/s); valid false during a drop-out")
      .def(pyb::init<>())
      .def_readwrite("t_s", &GpsSample::t_s)
      .def_readwrite("valid", &GpsSample::valid)
      .def_readwrite("p_W_m", &GpsSample::p_W_m)
      .def_readwrite("v_W_mps", &GpsSample::v_W_mps);
  pyb::class_<MagSample>(m, "MagSample", "magnetometer: field in B (uT)")
      .def(pyb::init<>())
      .def_readwrite("t_s", &MagSample::t_s)
      .def_readwrite("field_B_uT", &MagSample::field_B_uT);
  pyb::class_<UltrasonicSample>(m, "UltrasonicSample", "ultrasonic range along -z of B (m)")
      .def(pyb::init<>())
      .def_readwrite("t_s", &UltrasonicSample::t_s)
      .def_readwrite("range_m", &UltrasonicSample::range_m);
  pyb::class_<PlatformObservation>(m, "PlatformObservation",
                                   "a vision result: the platform's pose in the camera frame (X_CP, 4x4)")
      .def_readonly("t_s", &PlatformObservation::t_s)
      .def_readonly("detected", &PlatformObservation::detected)
      .def_readonly("keyframe", &PlatformObservation::keyframe)
      .def_property_readonly("X_CP", [](const PlatformObservation& o) { return Eigen::Matrix4d(o.X_CP.matrix()); })
      .def_readonly("cov", &PlatformObservation::cov)
      .def_readonly("rings_identified", &PlatformObservation::rings_identified)
      .def_readonly("reproj_err_px", &PlatformObservation::reproj_err_px);
  pyb::class_<NavState>(m, "NavState", "the navigation's state: attitude q_WB (w, x, y, z), position, velocity in W")
      .def_readonly("t_s", &NavState::t_s)
      .def_readonly("valid", &NavState::valid)
      .def_property_readonly("q_WB", [](const NavState& n) { return Eigen::Vector4d(n.q_WB.w(), n.q_WB.x(), n.q_WB.y(), n.q_WB.z()); })
      .def_property_readonly("R_WB", [](const NavState& n) { return Eigen::Matrix3d(n.q_WB.toRotationMatrix()); })
      .def_readonly("p_W_m", &NavState::p_W_m)
      .def_readonly("v_W_mps", &NavState::v_W_mps)
      .def_readonly("omega_B_radps", &NavState::omega_B_radps);
  pyb::class_<AltitudeEstimate>(m, "AltitudeEstimate", "the fused height (seed 004)")
      .def_readonly("t_s", &AltitudeEstimate::t_s)
      .def_readonly("valid", &AltitudeEstimate::valid)
      .def_readonly("z_W_m", &AltitudeEstimate::z_W_m)
      .def_readonly("vz_W_mps", &AltitudeEstimate::vz_W_mps)
      .def_readonly("h_surface_m", &AltitudeEstimate::h_surface_m);
  pyb::class_<flight::LandingInputs>(m, "LandingInputs", "what a landing logic knows at an outer-loop step")
      .def_readonly("t_s", &flight::LandingInputs::t_s)
      .def_readonly("nav", &flight::LandingInputs::nav)
      .def_readonly("altitude_valid", &flight::LandingInputs::altitude_valid)
      .def_readonly("altitude", &flight::LandingInputs::altitude)
      .def_property_readonly("X_BC", [](const flight::LandingInputs& in) { return Eigen::Matrix4d(in.mount.X_BC().matrix()); });
}

}  // namespace lander::py
