// The run goes on its own thread; after every physics step the loop's step observer decides
// whether to hand control back to Python (a frame arrived, or the requested time passed) and
// then waits until Python asks for the next step. Python reads a snapshot taken while the loop
// waits; the flight software's calls are recorded by a tap that forwards everything to the
// real flight software unchanged, so a stepped run's files equal `lander run`'s.
#include "py_sim.h"

#include <condition_variable>
#include <exception>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "convert.h"
#include "lander/flight/components.h"
#include "lander/sim/loop/flight_factory.h"
#include "lander/sim/plant/rotor.h"
#include "lander/sim/plant/truth.h"
#include "lander/sim/plant/world.h"
#include "lander/sim/run.h"
#include "lander/sim/sensors/camera.h"
#include "py_flight.h"

namespace lander::py {

namespace pyb = pybind11;
using namespace pybind11::literals;

namespace {

// What the flight software was given since the last step.
struct Samples {
  std::vector<ImuSample> imu;
  std::vector<BaroSample> baro;
  std::vector<GpsSample> gps;
  std::vector<UltrasonicSample> ultrasonic;
  std::vector<MagSample> mag;
  std::vector<GpsSample> telemetry;
  std::vector<std::array<double, flight::kRotorCount>> commands;  ///< rotor commands returned
};

// The flight software's calls, recorded and forwarded.
class Tap final : public flight::FlightSoftware {
 public:
  Tap(std::unique_ptr<flight::FlightSoftware> inner, std::mutex& m, Samples& into)
      : inner_(std::move(inner)), m_(m), into_(into) {}
  flight::FlightSoftwareInfo info() const override { return inner_->info(); }
  void on_baro(const BaroSample& b) override { rec(into_.baro, b); inner_->on_baro(b); }
  void on_gps(const GpsSample& g) override { rec(into_.gps, g); inner_->on_gps(g); }
  void on_ultrasonic(const UltrasonicSample& u) override { rec(into_.ultrasonic, u); inner_->on_ultrasonic(u); }
  void on_mag(const MagSample& s) override { rec(into_.mag, s); inner_->on_mag(s); }
  void on_platform_telemetry(const GpsSample& g) override { rec(into_.telemetry, g); inner_->on_platform_telemetry(g); }
  std::optional<flight::RotorSpeeds> on_imu(const ImuSample& s) override {
    rec(into_.imu, s);
    std::optional<flight::RotorSpeeds> c = inner_->on_imu(s);
    if (c) rec(into_.commands, c->w_radps);
    return c;
  }
  std::unique_ptr<flight::FrameJob> begin_frame(const flight::CameraFrameIn& f) override { return inner_->begin_frame(f); }
  void deliver_frame(std::unique_ptr<flight::FrameJob> j) override { inner_->deliver_frame(std::move(j)); }
  flight::FlightStatus status() const override { return inner_->status(); }
  flight::FlightTelemetry telemetry() const override { return inner_->telemetry(); }
  flight::FlightReport report() const override { return inner_->report(); }

 private:
  template <class V, class S>
  void rec(V& v, const S& s) {
    std::lock_guard<std::mutex> lock(m_);
    v.push_back(s);
  }
  std::unique_ptr<flight::FlightSoftware> inner_;
  std::mutex& m_;
  Samples& into_;
};

// Rotor speeds straight from the caller (lander.env's "rotor_speeds" actions): no estimator,
// no controller; the command is held between steps.
class ActionFlightSoftware final : public flight::FlightSoftware {
 public:
  explicit ActionFlightSoftware(std::array<double, flight::kRotorCount> hover) : w_(hover) {}
  void set(const std::array<double, flight::kRotorCount>& w) { w_ = w; }
  flight::FlightSoftwareInfo info() const override { return {"lander.env rotor speeds", "1"}; }
  void on_baro(const BaroSample&) override {}
  void on_gps(const GpsSample&) override {}
  void on_ultrasonic(const UltrasonicSample&) override {}
  void on_mag(const MagSample&) override {}
  void on_platform_telemetry(const GpsSample&) override {}
  std::optional<flight::RotorSpeeds> on_imu(const ImuSample& s) override {
    flight::RotorSpeeds r;
    r.t_s = s.t_s;
    r.w_radps = w_;
    bool all_zero = true;
    for (double w : w_) all_zero &= w == 0.0;
    r.motors_cut = all_zero;
    cut_ = all_zero;
    return r;
  }
  std::unique_ptr<flight::FrameJob> begin_frame(const flight::CameraFrameIn&) override;
  void deliver_frame(std::unique_ptr<flight::FrameJob>) override {}
  flight::FlightStatus status() const override {
    flight::FlightStatus st;
    st.mode = "external";
    st.motors_cut = cut_;
    return st;
  }
  flight::FlightTelemetry telemetry() const override { return {}; }
  flight::FlightReport report() const override {
    flight::FlightReport r;
    r.final_mode = "external";
    return r;
  }

 private:
  std::array<double, flight::kRotorCount> w_;
  bool cut_{false};
};

class NoVision final : public flight::FrameJob {
 public:
  void process() override {}
  flight::FrameReport report() const override {
    flight::FrameReport r;
    r.reason = "no_vision";
    return r;
  }
};
std::unique_ptr<flight::FrameJob> ActionFlightSoftware::begin_frame(const flight::CameraFrameIn&) {
  return std::make_unique<NoVision>();
}

// Setpoints from the caller (lander.env's "attitude_thrust" and "velocity" actions) for our
// autopilot, on our estimator and detector.
class ActionLogic final : public flight::LandingLogic {
 public:
  void set(const flight::AutopilotSetpoint& sp) { sp_ = sp; }
  void on_vision(const PlatformObservation&) override {}
  flight::AutopilotSetpoint update(const flight::LandingInputs&) override { return sp_; }
  std::string mode() const override { return "external"; }

 private:
  flight::AutopilotSetpoint sp_;
};

// What Python gets at a step: copied while the loop waits.
struct Snapshot {
  double t_s{0.0};
  Samples samples;
  std::optional<sim::CameraFrame> frame;
  Eigen::Isometry3d X_WB, X_WP, X_WC;
  Eigen::Vector3d v_WB, omega_B, cart_qd;
  double h_surface_m{0.0};
};

pyb::array image_array(const cv::Mat& m) {
  // No copy: the array's base keeps a header of the frame's Mat (and so its pixels) alive.
  auto* keep = new cv::Mat(m);
  pyb::capsule base(keep, [](void* p) { delete static_cast<cv::Mat*>(p); });
  pyb::array a(pyb::dtype::of<std::uint8_t>(), {m.rows, m.cols, 3},
               {static_cast<ssize_t>(m.step[0]), static_cast<ssize_t>(3), static_cast<ssize_t>(1)}, m.data, base);
  a.attr("setflags")("write"_a = false);
  return a;
}

template <class S, class F>
pyb::dict table(const std::vector<S>& v, std::initializer_list<std::pair<const char*, F>> cols) {
  pyb::dict d;
  for (const auto& [name, f] : cols) {
    std::vector<std::vector<double>> rows;
    for (const S& s : v) rows.push_back(f(s));
    const size_t w = f(S{}).size();  // the column's width, also with no rows
    pyb::array_t<double> a({rows.size(), w});
    auto r = a.mutable_unchecked<2>();
    for (size_t i = 0; i < rows.size(); ++i)
      for (size_t j = 0; j < w; ++j) r(i, j) = rows[i][j];
    d[name] = w == 1 ? a.attr("reshape")(rows.size()) : a;
  }
  return d;
}

using Row = std::vector<double>;
Row v3(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

pyb::dict samples_to_py(const Samples& s) {
  using F = std::function<Row(const ImuSample&)>;
  pyb::dict d;
  d["imu"] = table<ImuSample, F>(s.imu, {{"t_s", [](const ImuSample& x) { return Row{x.t_s}; }},
                                         {"gyro_B_radps", [](const ImuSample& x) { return v3(x.gyro_B_radps); }},
                                         {"accel_B_mps2", [](const ImuSample& x) { return v3(x.accel_B_mps2); }}});
  using FB = std::function<Row(const BaroSample&)>;
  d["baro"] = table<BaroSample, FB>(s.baro, {{"t_s", [](const BaroSample& x) { return Row{x.t_s}; }},
                                             {"pressure_pa", [](const BaroSample& x) { return Row{x.pressure_pa}; }}});
  using FG = std::function<Row(const GpsSample&)>;
  for (const auto& [key, v] : {std::make_pair("gps", &s.gps), std::make_pair("platform_telemetry", &s.telemetry)}) {
    d[key] = table<GpsSample, FG>(*v, {{"t_s", [](const GpsSample& x) { return Row{x.t_s}; }},
                                       {"valid", [](const GpsSample& x) { return Row{x.valid ? 1.0 : 0.0}; }},
                                       {"p_W_m", [](const GpsSample& x) { return v3(x.p_W_m); }},
                                       {"v_W_mps", [](const GpsSample& x) { return v3(x.v_W_mps); }}});
  }
  using FU = std::function<Row(const UltrasonicSample&)>;
  d["ultrasonic"] = table<UltrasonicSample, FU>(s.ultrasonic, {{"t_s", [](const UltrasonicSample& x) { return Row{x.t_s}; }},
                                                              {"range_m", [](const UltrasonicSample& x) { return Row{x.range_m}; }}});
  using FM = std::function<Row(const MagSample&)>;
  d["magnetometer"] = table<MagSample, FM>(s.mag, {{"t_s", [](const MagSample& x) { return Row{x.t_s}; }},
                                                   {"field_B_uT", [](const MagSample& x) { return v3(x.field_B_uT); }}});
  using FC = std::function<Row(const std::array<double, 6>&)>;
  d["rotor_commands"] = table<std::array<double, 6>, FC>(
      s.commands, {{"w_radps", [](const std::array<double, 6>& w) { return Row(w.begin(), w.end()); }}});
  return d;
}

class Sim {
 public:
  Sim(pyb::object scenario, pyb::object seed, pyb::object overrides, pyb::object out, pyb::object flight,
      std::string action, bool frames)
      : scenario_(std::move(scenario)), overrides_(std::move(overrides)), out_(std::move(out)),
        flight_(std::move(flight)), action_(std::move(action)), frames_(frames), seed_(std::move(seed)) {
    if (action_ != "none" && action_ != "rotor_speeds" && action_ != "attitude_thrust" && action_ != "velocity") {
      throw ConfigError("action: must be none, rotor_speeds, attitude_thrust or velocity (got '" + action_ + "')");
    }
    if (action_ != "none" && !flight_.is_none()) throw ConfigError("flight and action exclude each other");
  }
  ~Sim() { stop(); }

  // Starts a new run (ends a running one) and returns the first step's observation.
  pyb::object reset(pyb::object seed) {
    stop();
    if (!seed.is_none()) seed_ = seed;
    scenario_s_ = std::make_shared<sim::Scenario>(scenario_from(scenario_, overrides_, seed_));
    if (scenario_s_->vehicle.control != "closed_loop") throw ConfigError("lander.Sim steps closed-loop scenarios only");
    sim::RunOptions o;
    o.out_dir = out_.is_none() ? std::string(pyb::str(pyb::module_::import("tempfile").attr("mkdtemp")("prefix"_a = "lander_sim_")))
                               : std::string(pyb::str(pyb::module_::import("os").attr("fspath")(out_)));
    out_dir_ = o.out_dir;
    make_factory(o);
    o.step_observer = [this](const sim::StepView& v) { observe(v); };
    done_ = false;
    paused_ = false;
    stop_requested_ = false;
    error_ = nullptr;
    until_t_ = -1.0;
    samples_ = Samples{};
    auto s = scenario_s_;
    thread_ = std::thread([this, s, o] {
      try {
        const nlohmann::ordered_json summary = sim::run_scenario(*s, o);
        std::lock_guard<std::mutex> lock(m_);
        summary_ = summary.dump();
      } catch (...) {
        std::lock_guard<std::mutex> lock(m_);
        error_ = std::current_exception();
      }
      std::lock_guard<std::mutex> lock(m_);
      done_ = true;
      cv_.notify_all();
    });
    return wait_step();
  }

  // Lets the run go on to its next camera frame (until_t_s < 0) or to the first step at or
  // after until_t_s; returns (obs, done, info).
  pyb::object step(double until_t_s, pyb::object action) {
    if (!thread_.joinable()) throw ConfigError("lander.Sim.step before reset()");
    if (!action.is_none()) set_action(action);
    {
      std::lock_guard<std::mutex> lock(m_);
      if (done_) throw ConfigError("lander.Sim.step after the run ended: reset() starts another");
      until_t_ = until_t_s;
      paused_ = false;
    }
    cv_.notify_all();
    return wait_step();
  }

  void close() { stop(); }
  std::string out_dir() const { return out_dir_; }

 private:
  void make_factory(sim::RunOptions& o) {
    pyb::object obj = flight_;
    std::shared_ptr<pyb::object> holder = obj.is_none() ? nullptr : std::make_shared<pyb::object>(obj);
    const std::string action = action_;
    o.flight_factory = [this, holder, action](const sim::Scenario& sc) -> std::unique_ptr<flight::FlightSoftware> {
      std::unique_ptr<flight::FlightSoftware> inner;
      if (action == "rotor_speeds") {
        std::array<double, flight::kRotorCount> hover;
        hover.fill(sim::hover_speed_radps(sc.vehicle.model.rotor, sc.vehicle.model.mass_kg));
        auto a = std::make_unique<ActionFlightSoftware>(hover);
        rotor_action_ = a.get();
        inner = std::move(a);
      } else if (action == "attitude_thrust" || action == "velocity") {
        auto logic = std::make_unique<ActionLogic>();
        flight::AutopilotSetpoint hold;
        hold.kind = flight::AutopilotSetpoint::Kind::kVelocity;
        logic->set(hold);
        setpoint_action_ = logic.get();
        inner = std::make_unique<flight::CompanionStack>(sc.flight, std::move(logic),
                                                         flight::FlightSoftwareInfo{"lander.env " + action, "1"});
      } else if (holder) {
        inner = make_python_flight(sc, *holder);
      } else if (!sc.flight.python.empty()) {
        inner = make_python_flight(sc, load_python_flight(sc));
      } else {
        inner = sim::make_flight_software(sc);
      }
      return std::make_unique<Tap>(std::move(inner), m_, samples_);
    };
  }

  void set_action(const pyb::object& a) {
    if (action_ == "rotor_speeds") {
      rotor_action_->set(a.cast<std::array<double, flight::kRotorCount>>());
    } else if (action_ == "attitude_thrust" || action_ == "velocity") {
      flight::AutopilotSetpoint sp;
      const Eigen::VectorXd v = a.cast<Eigen::VectorXd>();
      if (action_ == "velocity") {
        if (v.size() != 4) throw ConfigError("a velocity action is [vx, vy, vz, yaw] (m/s, rad)");
        sp.kind = flight::AutopilotSetpoint::Kind::kVelocity;
        sp.v_W_mps = v.head<3>();
        sp.yaw_rad = v[3];
      } else {
        if (v.size() != 4) throw ConfigError("an attitude_thrust action is [roll, pitch, yaw, thrust] (rad, N)");
        sp.kind = flight::AutopilotSetpoint::Kind::kAttitudeThrust;
        sp.q_WB = Eigen::AngleAxisd(v[2], Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(v[1], Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(v[0], Eigen::Vector3d::UnitX());
        sp.thrust_N = v[3];
      }
      setpoint_action_->set(sp);
    } else {
      throw ConfigError("this Sim takes no actions (made with action='none')");
    }
  }

  // On the loop's thread after each physics step.
  void observe(const sim::StepView& v) {
    std::unique_lock<std::mutex> lock(m_);
    if (stop_requested_) throw std::runtime_error("lander.Sim closed before the run ended");
    const bool frame_due = v.frame != nullptr && until_t_ < 0;
    const bool time_due = until_t_ >= 0 && v.t_s + 1e-9 >= until_t_;
    if (!first_ && !frame_due && !time_due) return;
    first_ = false;
    snap_.t_s = v.t_s;
    snap_.samples = std::move(samples_);
    samples_ = Samples{};
    snap_.frame.reset();
    if (v.frame && frames_) snap_.frame = *v.frame;
    snap_.X_WB = v.world->X_WB();
    snap_.X_WP = v.world->X_WP();
    snap_.X_WC = v.world->X_WC();
    snap_.v_WB = v.world->v_WB();
    snap_.omega_B = v.world->omega_B();
    snap_.cart_qd = v.world->cart_qd();
    snap_.h_surface_m = v.truth->h_surface_m;
    paused_ = true;
    cv_.notify_all();
    cv_.wait(lock, [this] { return !paused_ || stop_requested_; });
    if (stop_requested_) throw std::runtime_error("lander.Sim closed before the run ended");
  }

  // On Python's thread: waits for the next pause or the run's end; the observation.
  pyb::object wait_step() {
    {
      pyb::gil_scoped_release nogil;
      std::unique_lock<std::mutex> lock(m_);
      cv_.wait(lock, [this] { return paused_ || done_; });
    }
    std::lock_guard<std::mutex> lock(m_);
    if (done_) {
      thread_.join();
      if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
      pyb::dict info;
      info["summary"] = from_json_text(summary_);
      info["out_dir"] = out_dir_;
      return pyb::make_tuple(pyb::none(), true, info);
    }
    pyb::dict obs;
    obs["t_s"] = snap_.t_s;
    obs["samples"] = samples_to_py(snap_.samples);
    if (snap_.frame) {
      pyb::dict f;
      f["index"] = snap_.frame->index;
      f["t_start_s"] = snap_.frame->exposure.t_start_s;
      f["t_end_s"] = snap_.frame->exposure.t_end_s;
      f["readout_s"] = snap_.frame->exposure.readout_s;
      f["image"] = image_array(snap_.frame->bgr);
      obs["frame"] = f;
    } else {
      obs["frame"] = pyb::none();
    }
    pyb::dict truth;  // kept apart: never given to a flight software
    truth["X_WB"] = Eigen::Matrix4d(snap_.X_WB.matrix());
    truth["X_WP"] = Eigen::Matrix4d(snap_.X_WP.matrix());
    truth["X_WC"] = Eigen::Matrix4d(snap_.X_WC.matrix());
    truth["X_CP"] = Eigen::Matrix4d((snap_.X_WC.inverse() * snap_.X_WP).matrix());
    if (snap_.frame) {
      // The frame's truth at its exposure's middle (the label of its pixels).
      truth["X_WC_mid_exposure"] = Eigen::Matrix4d(snap_.frame->X_WC_true.matrix());
      truth["X_WP_mid_exposure"] = Eigen::Matrix4d(snap_.frame->X_WP_true.matrix());
      truth["X_CP_mid_exposure"] = Eigen::Matrix4d((snap_.frame->X_WC_true.inverse() * snap_.frame->X_WP_true).matrix());
    }
    truth["v_WB_mps"] = snap_.v_WB;
    truth["omega_B_radps"] = snap_.omega_B;
    truth["cart_qd"] = snap_.cart_qd;
    truth["h_surface_m"] = snap_.h_surface_m;
    pyb::dict info;
    info["truth"] = truth;
    return pyb::make_tuple(obs, false, info);
  }

  void stop() {
    if (!thread_.joinable()) return;
    {
      std::lock_guard<std::mutex> lock(m_);
      stop_requested_ = true;
    }
    cv_.notify_all();
    {
      pyb::gil_scoped_release nogil;
      thread_.join();
    }
    first_ = true;
  }

  pyb::object scenario_, overrides_, out_, flight_;
  std::string action_;
  bool frames_;
  pyb::object seed_;
  std::shared_ptr<sim::Scenario> scenario_s_;
  std::string out_dir_;
  std::thread thread_;
  std::mutex m_;
  std::condition_variable cv_;
  bool paused_{false}, done_{false}, stop_requested_{false}, first_{true};
  double until_t_{-1.0};
  Samples samples_;
  Snapshot snap_;
  std::string summary_;
  std::exception_ptr error_;
  ActionFlightSoftware* rotor_action_{nullptr};
  ActionLogic* setpoint_action_{nullptr};
};

}  // namespace

void bind_sim(pyb::module_& m) {
  pyb::class_<Sim>(m, "Sim")
      .def(pyb::init<pyb::object, pyb::object, pyb::object, pyb::object, pyb::object, std::string, bool>(),
           "scenario"_a, "seed"_a = pyb::none(), "overrides"_a = pyb::none(), "out"_a = pyb::none(),
           "flight"_a = pyb::none(), "action"_a = "none", "frames"_a = true)
      .def("reset", &Sim::reset, "seed"_a = pyb::none())
      .def("step", &Sim::step, "until_t_s"_a = -1.0, "action"_a = pyb::none())
      .def("close", &Sim::close)
      .def_property_readonly("out_dir", &Sim::out_dir);
}

}  // namespace lander::py
