// pd_lander: the template flight plugin a user copies. A deliberately simple landing logic of
// a companion computer, flown on our estimator, our ring detector and our autopilot (the
// component seams of lander/flight/components.h):
//
//   search    no fix of the platform yet (or lost for lost_after_s): hold the start point
//             (or fly to where the platform was predicted), climbing to search_height_m and
//             turning at search_yaw_rate_degps so that the image's wide axis sweeps around
//   pursue    fly over the platform: velocity = the platform's velocity (fed forward) +
//             kp_per_s x the horizontal error + ki_per_s2 x its integral (the lag the
//             autopilot's response and the latency leave); descend only while the error is
//             inside descend_gate_m + descend_gate_per_m x the gear's height
//   descend   the same, descending (slower near the top)
//   cut       the gear within cut_clearance_m of the platform and centred, or on it:
//             motors off
//
// No approach trajectory, no visual-servo recovery, no go-around, no decision log: compare
// it with ours on one campaign (`lander regress`) to see what those buy. Its parameters come
// from the scenario's `flight.plugin_config:` mapping (every key optional):
//
//   flight:
//     plugin: ../build/examples/pd_lander/libpd_lander.so
//     plugin_config: {kp_per_s: 0.8, descent_rate_mps: 0.8}
#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include <yaml-cpp/yaml.h>

#include "lander/core/params_io.h"
#include "lander/flight/components.h"
#include "lander/flight/flight_plugin.h"

namespace pd_lander {

using lander::flight::AutopilotSetpoint;

// The logic's parameters (flight.plugin_config), with the project's params reader, so that an
// unknown key or a bad value is refused naming the key.
struct Params {
  double kp_per_s{0.6};            ///< horizontal error -> velocity (1/s)
  double ki_per_s2{0.25};          ///< its integral -> velocity (1/s^2)
  double max_integral_mps{0.8};    ///< the integral's share of the velocity at most (m/s)
  double max_speed_mps{2.0};       ///< horizontal speed limit (m/s)
  double descent_rate_mps{0.8};    ///< descent speed high up (m/s)
  double descent_per_m{0.35};      ///< descent speed per metre of height near the top (1/s)
  double min_descent_mps{0.15};    ///< slowest descent (m/s)
  double descend_gate_m{0.08};     ///< horizontal error allowed for descending, at the top (m)
  double descend_gate_per_m{0.12}; ///< ... plus this per metre of height (m/m)
  double cut_clearance_m{0.03};    ///< cut when the gear is this close to the top (m)
  double cut_error_m{0.08};        ///< and the horizontal error below this (m)
  double contact_clearance_m{0.02};  ///< the gear this close: on the top, cut whatever the error (m)
  double lost_after_s{1.5};        ///< no fix for this long: the platform is lost (s)
  double search_height_m{10.0};    ///< lowest height while searching (m)
  double climb_rate_mps{0.8};      ///< climb while searching or lost (m/s)
  double search_yaw_rate_degps{30.0};  ///< heading sweep while searching (deg/s)
  double fit_window_s{1.5};        ///< the platform's track: a line fitted to this much (s)
  // Each field's range is in visit_fields (lander/core/field_spec.h); this checks it and the
  // rules across fields.
  void validate() const {
    lander::check_fields(*this);
    lander::require(min_descent_mps <= descent_rate_mps, "min_descent_mps",
                    "must be <= descent_rate_mps");
  }
};

// Key, field, allowed range, unit, description: the plugin's reference in one place.
template <class V>
void visit_fields(V& v, Params& p) {
  namespace range = lander::range;
  v("kp_per_s", p.kp_per_s, range::open(0, 10), "1/s", "horizontal error -> velocity");
  v("ki_per_s2", p.ki_per_s2, range::non_negative, "1/s^2", "its integral -> velocity");
  v("max_integral_mps", p.max_integral_mps, range::non_negative, "m/s",
    "the integral's share of the velocity at most");
  v("max_speed_mps", p.max_speed_mps, range::positive, "m/s", "horizontal speed limit");
  v("descent_rate_mps", p.descent_rate_mps, range::positive, "m/s", "descent speed high up");
  v("descent_per_m", p.descent_per_m, range::non_negative, "1/s",
    "descent speed per metre of height near the top");
  v("min_descent_mps", p.min_descent_mps, range::positive, "m/s", "slowest descent");
  v("descend_gate_m", p.descend_gate_m, range::positive, "m",
    "horizontal error allowed for descending, at the top");
  v("descend_gate_per_m", p.descend_gate_per_m, range::non_negative, "m/m",
    "... plus this per metre of height");
  v("cut_clearance_m", p.cut_clearance_m, range::non_negative, "m",
    "cut when the gear is this close to the top");
  v("cut_error_m", p.cut_error_m, range::positive, "m", "and the horizontal error below this");
  v("contact_clearance_m", p.contact_clearance_m, range::non_negative, "m",
    "the gear this close: on the top, cut whatever the error");
  v("lost_after_s", p.lost_after_s, range::positive, "s",
    "no fix for this long: the platform is lost");
  v("search_height_m", p.search_height_m, range::positive, "m", "lowest height while searching");
  v("climb_rate_mps", p.climb_rate_mps, range::positive, "m/s", "climb while searching or lost");
  v("search_yaw_rate_degps", p.search_yaw_rate_degps, range::non_negative, "deg/s",
    "heading sweep while searching");
  v("fit_window_s", p.fit_window_s, range::greater_than(0.1), "s",
    "the platform's track: a line fitted to this much");
}

// The platform as the logic tracks it: a straight line (position, velocity) fitted by least
// squares to the fixes of the last fit_window_s, in W.
struct PlatformTrack {
  bool known{false};
  double t_s{0.0};  ///< the latest fix (s)
  Eigen::Vector3d p_W_m{Eigen::Vector3d::Zero()};    ///< the line at t_s
  Eigen::Vector3d v_W_mps{Eigen::Vector3d::Zero()};  ///< its slope
  double h_camera_m{std::numeric_limits<double>::quiet_NaN()};  ///< camera above the top
  std::deque<std::pair<double, Eigen::Vector3d>> fixes;
  Eigen::Vector3d predict(double t) const { return p_W_m + v_W_mps * (t - t_s); }

  void add(double t, const Eigen::Vector3d& p, double window_s) {
    fixes.emplace_back(t, p);
    while (!fixes.empty() && fixes.front().first < t - window_s) fixes.pop_front();
    known = true;
    t_s = t;
    fit();
  }

 private:
  void fit() {
    const double n = static_cast<double>(fixes.size());
    double tm = 0;
    Eigen::Vector3d pm = Eigen::Vector3d::Zero();
    for (const auto& [t, p] : fixes) {
      tm += t / n;
      pm += p / n;
    }
    double stt = 0;
    Eigen::Vector3d stp = Eigen::Vector3d::Zero();
    for (const auto& [t, p] : fixes) {
      stt += (t - tm) * (t - tm);
      stp += (t - tm) * (p - pm);
    }
    // Fewer than 3 fixes or under 0.3 s of them: no slope yet.
    const bool slope = fixes.size() >= 3 && fixes.back().first - fixes.front().first > 0.3;
    v_W_mps = slope ? Eigen::Vector3d(stp / stt) : Eigen::Vector3d::Zero();
    p_W_m = pm + v_W_mps * (t_s - tm);
  }
};

// The navigation's attitude and position at the outer-loop steps of the last second, so that
// a fix is placed in W with the attitude of its exposure, not of its delivery ~0.1 s later.
struct NavHistory {
  std::deque<lander::NavState> states;
  void add(const lander::NavState& s) {
    states.push_back(s);
    while (states.size() > 60) states.pop_front();
  }
  const lander::NavState& at(double t) const {
    const lander::NavState* best = &states.back();
    for (const lander::NavState& s : states) {
      if (std::abs(s.t_s - t) < std::abs(best->t_s - t)) best = &s;
    }
    return *best;
  }
};

class PdLandingLogic final : public lander::flight::LandingLogic {
 public:
  PdLandingLogic(const Params& p, double gear_height_m) : p_(p), gear_height_m_(gear_height_m) {}

  // A vision result: the platform in W from the estimate at this step (the latency, ~0.1 s,
  // is left uncorrected: a simple logic).
  void on_vision(const lander::PlatformObservation& obs) override { pending_ = obs; }

  AutopilotSetpoint update(const lander::flight::LandingInputs& in) override {
    if (!started_) start(in);
    history_.add(in.nav);
    if (pending_) take_fix(*pending_, in);
    pending_.reset();
    const double t = in.t_s;
    const bool fresh = track_.known && t - track_.t_s < p_.lost_after_s;
    AutopilotSetpoint sp;
    sp.kind = AutopilotSetpoint::Kind::kVelocity;
    if (!fresh) {
      // The heading sweeps from where it is; with a fix it stays where the fix found it.
      const double dt = last_search_t_ >= 0 ? std::clamp(in.t_s - last_search_t_, 0.0, 0.1) : 0.0;
      yaw_ += p_.search_yaw_rate_degps * M_PI / 180.0 * dt;
      last_search_t_ = in.t_s;
      sp.yaw_rad = yaw_;
      return search(in, sp);
    }
    last_search_t_ = -1.0;
    sp.yaw_rad = yaw_;
    return pursue(in, sp);
  }

  std::string mode() const override { return mode_; }
  std::optional<Eigen::Vector3d> platform_W_m() const override {
    if (!track_.known) return std::nullopt;
    return track_.p_W_m;
  }
  void fill_report(lander::flight::FlightReport& r) const override {
    r.transitions = transitions_;
    r.final_mode = mode_;
  }

 private:
  void start(const lander::flight::LandingInputs& in) {
    started_ = true;
    const Eigen::Vector3d x = in.nav.q_WB * Eigen::Vector3d::UnitX();
    yaw_ = std::atan2(x.y(), x.x());
    hold_W_m_ = in.nav.p_W_m;
  }

  void take_fix(const lander::PlatformObservation& obs, const lander::flight::LandingInputs& in) {
    if (!obs.detected || (track_.known && obs.t_s <= track_.t_s)) return;
    const lander::NavState& then = history_.at(obs.t_s);
    Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
    X_WB.linear() = then.q_WB.toRotationMatrix();
    X_WB.translation() = then.p_W_m + then.v_W_mps * (obs.t_s - then.t_s);
    const Eigen::Isometry3d X_WC = X_WB * in.mount.X_BC();
    const Eigen::Vector3d p = X_WC * obs.X_CP.translation();
    if (!p.allFinite()) return;
    track_.add(obs.t_s, p, p_.fit_window_s);
    // The camera's height above the platform's top along W's vertical.
    track_.h_camera_m = X_WC.translation().z() - p.z();
  }

  AutopilotSetpoint search(const lander::flight::LandingInputs& in, AutopilotSetpoint& sp) {
    switch_to(in.t_s, track_.known ? "lost" : "search", track_.known ? "no fix for lost_after_s" : "no fix yet");
    const Eigen::Vector3d target = track_.known ? track_.predict(in.t_s) : hold_W_m_;
    const Eigen::Vector2d err = target.head<2>() - in.nav.p_W_m.head<2>();
    Eigen::Vector2d v = p_.kp_per_s * err;
    if (v.norm() > p_.max_speed_mps) v *= p_.max_speed_mps / v.norm();
    const double h = height(in);
    sp.v_W_mps = Eigen::Vector3d(v.x(), v.y(), h < p_.search_height_m ? p_.climb_rate_mps : 0.0);
    return sp;
  }

  AutopilotSetpoint pursue(const lander::flight::LandingInputs& in, AutopilotSetpoint& sp) {
    const Eigen::Vector3d pred = track_.predict(in.t_s);
    const Eigen::Vector2d err = pred.head<2>() - in.nav.p_W_m.head<2>();
    const double h = height(in);                // body above the top (m)
    const double clearance = h - gear_height_m_;  // gear above the top (m)
    if ((clearance < p_.cut_clearance_m && err.norm() < p_.cut_error_m) || clearance < p_.contact_clearance_m) {
      switch_to(in.t_s, "cut", clearance < p_.contact_clearance_m ? "gear on the top" : "gear within cut_clearance_m, centred");
      sp.kind = AutopilotSetpoint::Kind::kMotorsCut;
      return sp;
    }
    const double dt = last_t_ > 0 ? std::clamp(in.t_s - last_t_, 0.0, 0.1) : 0.0;
    last_t_ = in.t_s;
    integral_ += p_.ki_per_s2 * err * dt;
    if (integral_.norm() > p_.max_integral_mps) integral_ *= p_.max_integral_mps / integral_.norm();
    Eigen::Vector2d v = track_.v_W_mps.head<2>() + p_.kp_per_s * err + integral_;
    if (v.norm() > p_.max_speed_mps) v *= p_.max_speed_mps / v.norm();
    const bool centred = err.norm() < p_.descend_gate_m + p_.descend_gate_per_m * std::max(0.0, clearance);
    double vz = 0.0;
    if (centred) {
      vz = -std::clamp(p_.descent_per_m * clearance, p_.min_descent_mps, p_.descent_rate_mps);
      switch_to(in.t_s, "descend", "centred within the descent gate");
    } else {
      switch_to(in.t_s, "pursue", "outside the descent gate");
    }
    sp.v_W_mps = Eigen::Vector3d(v.x(), v.y(), vz);
    return sp;
  }

  // Body height above the platform: the vision's while a fix is fresh, else the fusion's
  // height above the surface.
  double height(const lander::flight::LandingInputs& in) const {
    if (track_.known && in.t_s - track_.t_s < 0.5 && std::isfinite(track_.h_camera_m)) {
      return track_.h_camera_m - (in.mount.X_BC().translation().z());  // camera sits below B
    }
    if (in.altitude_valid) return in.altitude.h_surface_m;
    return in.nav.p_W_m.z();
  }

  void switch_to(double t, const std::string& mode, const std::string& reason) {
    if (mode == mode_) return;
    transitions_.push_back({t, mode_, mode, reason});
    mode_ = mode;
  }

  Params p_;
  double gear_height_m_;
  bool started_{false};
  double yaw_{0.0};               // heading setpoint (rad)
  double last_search_t_{-1.0};
  Eigen::Vector3d hold_W_m_{Eigen::Vector3d::Zero()};
  std::optional<lander::PlatformObservation> pending_;
  NavHistory history_;
  PlatformTrack track_;
  Eigen::Vector2d integral_{Eigen::Vector2d::Zero()};
  double last_t_{-1.0};
  std::string mode_{"search"};
  std::vector<lander::flight::FlightReport::Transition> transitions_;
};

// The plugin's factory: the run's flight configuration (our estimator's, detector's and
// autopilot's parameters) and this logic's own from plugin_config.
std::unique_ptr<lander::flight::FlightSoftware> create(const LanderFlightPluginArgs& args) {
  lander::flight::FlightConfig config;
  lander::read_params(YAML::Load(args.flight_yaml), "the run's flight configuration", config);
  Params p;
  lander::read_params(YAML::Load(args.plugin_config_yaml), "flight.plugin_config", p);
  auto logic = std::make_unique<PdLandingLogic>(p, config.controller.landing.gear_height_m);
  return std::make_unique<lander::flight::CompanionStack>(config, std::move(logic),
                                                          lander::flight::FlightSoftwareInfo{"pd_lander", "1.0"});
}

}  // namespace pd_lander

LANDER_FLIGHT_PLUGIN(pd_lander::create)
