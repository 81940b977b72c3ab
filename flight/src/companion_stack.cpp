// A companion computer's landing logic on our estimator and autopilot (components.h).
#include <cmath>
#include <limits>
#include <utility>

#include "internal.h"
#include "lander/controller/cascade.h"
#include "lander/estimator/altitude_vision.h"
#include "lander/flight/components.h"

namespace lander::flight {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// One frame through the stack's detector (on whichever thread runs process).
class CompanionFrameJob final : public FrameJob {
 public:
  CompanionFrameJob(VisionDetector& detector, const CameraFrameIn& frame, const Eigen::Isometry3d& X_BC)
      : detector_(detector), frame_(frame), X_BC_(X_BC) {}
  void process() override {
    d_ = detector_.detect(frame_.image, frame_, Eigen::Vector2d::Zero());
    d_.obs.t_s = frame_.exposure.mid();
  }
  FrameReport report() const override { return d_.report; }
  bool inject(const VisionFault& f) override {
    apply_vision_fault(d_.obs, f);
    if (f.kind == VisionFault::Kind::kOffsetAlongAxis && d_.report.detected) {
      d_.report.vision_height_m = height_above_target_m(d_.obs.X_CP, X_BC_);
    }
    return true;
  }
  const PlatformObservation& obs() const { return d_.obs; }

 private:
  VisionDetector& detector_;
  CameraFrameIn frame_;
  Eigen::Isometry3d X_BC_;
  Detection d_;
};

double yaw_of(const Eigen::Quaterniond& q) {
  const Eigen::Vector3d x = q * Eigen::Vector3d::UnitX();
  return std::atan2(x.y(), x.x());
}

}  // namespace

CompanionStack::CompanionStack(const FlightConfig& config, std::unique_ptr<LandingLogic> logic, FlightSoftwareInfo info,
                               std::unique_ptr<VisionDetector> detector)
    : config_(validated(config)),
      info_(std::move(info)),
      est_(config_.estimator),
      detector_(detector ? std::move(detector) : make_ring_detector(config_)),
      logic_(std::move(logic)),
      autopilot_(std::make_unique<ctl::CascadeController>(config_.controller.vehicle, config_.controller.cascade)) {
  if (!logic_) throw ConfigError("CompanionStack: no landing logic");
  autopilot_->reset();
}

CompanionStack::~CompanionStack() = default;

std::optional<RotorSpeeds> CompanionStack::on_imu(const ImuSample& raw) {
  const std::optional<ImuSample> s = est_.on_imu(raw);
  if (!s) return std::nullopt;
  const NavState nav = est_.nav_state();
  if (!nav.valid) return std::nullopt;
  RotorSpeeds out;
  out.t_s = s->t_s;
  if (!motors_cut_ && autopilot_->outer_due(s->t_s)) {
    const LandingInputs in{s->t_s, nav, est_.altitude_started(), est_.altitude(), config_.mount};
    sp_ = logic_->update(in);
    ctl::Setpoint sp;
    sp.p_W_m = sp_.kind == AutopilotSetpoint::Kind::kVelocity ? nav.p_W_m : sp_.p_W_m;
    sp.v_W_mps = sp_.v_W_mps;
    sp.a_W_mps2 = sp_.a_W_mps2;
    sp.yaw_rad = sp_.yaw_rad;
    switch (sp_.kind) {
      case AutopilotSetpoint::Kind::kMotorsCut:
        motors_cut_ = true;
        break;
      case AutopilotSetpoint::Kind::kAttitudeThrust:
        autopilot_->hold_thrust(s->t_s, sp_.q_WB * Eigen::Vector3d(0, 0, sp_.thrust_N), yaw_of(sp_.q_WB));
        break;
      default:
        autopilot_->update_outer(s->t_s, sp, nav);
    }
  }
  out.motors_cut = motors_cut_;
  if (motors_cut_) return out;  // every rotor at 0 rad/s
  const ctl::MixerOutput m = autopilot_->update_inner(s->t_s, nav, *s);
  for (int r = 0; r < kRotorCount; ++r) out.w_radps[r] = m.w_radps[r];
  return out;
}

std::unique_ptr<FrameJob> CompanionStack::begin_frame(const CameraFrameIn& frame) {
  return std::make_unique<CompanionFrameJob>(*detector_, frame, config_.mount.X_BC());
}

void CompanionStack::deliver_frame(std::unique_ptr<FrameJob> job) {
  const PlatformObservation& obs = static_cast<const CompanionFrameJob&>(*job).obs();
  const double h = obs.detected && obs.keyframe ? height_above_target_m(obs.X_CP, config_.mount.X_BC()) : kNaN;
  if (est_.on_vision(obs, h)) logic_->on_vision(obs);
}

FlightStatus CompanionStack::status() const {
  FlightStatus st;
  st.mode = logic_->mode();
  st.motors_cut = motors_cut_;
  st.aborted = logic_->aborted();
  st.altitude_valid = est_.altitude_started();
  st.altitude = est_.altitude();
  return st;
}

FlightTelemetry CompanionStack::telemetry() const {
  FlightTelemetry t;
  t.nav = est_.nav_state();
  if (const std::optional<Eigen::Vector3d> p = logic_->platform_W_m()) {
    t.platform_W_m = *p;
    if (t.nav.valid) t.horizontal_error_m = (*p - t.nav.p_W_m).head<2>().norm();
  }
  t.setpoint_W_m = autopilot_->diagnostics().setpoint.p_W_m;
  return t;
}

FlightReport CompanionStack::report() const {
  FlightReport r;
  logic_->fill_report(r);
  if (r.final_mode.empty()) r.final_mode = logic_->mode();
  r.rejected = est_.rejected();
  r.altitude_height_resets = est_.height_resets();
  r.altitude_baro_fallback_updates = est_.baro_fallback_updates();
  return r;
}

}  // namespace lander::flight
