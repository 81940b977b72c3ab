// The plant: the MuJoCo world as it really is (vehicle mass and inertia, rotors with their
// lag, saturation and per-rotor deviations, ground effect per rotor, wind, the cart driven
// along its path, the camera where it is really mounted, the platform at its real height, the
// light). It takes rotor speed commands and gives the truth; it never sees the flight
// software's configuration (docs/design/architecture.md, "The loop").
#pragma once

#include <string>

#include "lander/sim/plant/deck_motion.h"
#include "lander/sim/plant/rotor.h"
#include "lander/sim/scenario.h"
#include "lander/sim/plant/truth.h"
#include "lander/sim/plant/wind.h"
#include "lander/sim/plant/world.h"

namespace lander::sim {

// Writes the scenario's plant truths into the loaded model: vehicle mass and inertia, camera
// mount error, platform height, lights. Call once after loading the world, before any render
// or step (closed-loop and scripted runs alike).
void apply_plant_truth(const Scenario& s, World& world);

// Lights the model as `light` says: the sun's direction and intensity (the light named "sun"),
// the headlight's ambient and diffuse. Throws ConfigError if the model has no "sun".
void apply_light(mjModel* m, const LightParams& light);

class Plant {
 public:
  // Puts the cart at its path's start and the vehicle at the start pose, hovering (rotors at
  // the true hover speed). apply_plant_truth() must have run on `world`.
  Plant(const Scenario& s, World& world);

  // Physics step k, from k dt to (k + 1) dt, with rotor speed command w_cmd: motor lag, ground
  // effect, wind drag, cart drive, mj_step. Returns false when the simulation diverged
  // (MuJoCo's instability warning, a non-finite state or a runaway vehicle): `detail` says
  // how; the state is then unusable.
  bool step(int k, const RotorArray& w_cmd, std::string* detail);

  // The deck's sinusoids of this run (empty without cart.deck_motion).
  const DeckWaves& deck_waves() const { return deck_waves_; }

  // Truth after the last step (or at the start).
  const VehicleTruth& truth() const { return truth_; }
  const RotorArray& rotor_speeds_radps() const { return motors_.speeds_radps(); }
  double hover_speed_radps() const { return w_hover_; }
  World& world() { return world_; }
  const World& world() const { return world_; }

 private:
  void update_truth(double t_s);
  // Joint forces that make the cart follow its path and the deck its motion at t_s.
  void drive_cart(double t_s);
  void drive_deck(double t_s);

  const Scenario& s_;
  World& world_;
  MotorBank motors_;
  WindModel wind_;
  RotorArray thrust_scale_{}, torque_scale_{};
  double cart_mass_kg_{0.0}, cart_yaw_inertia_{0.0};
  DeckWaves deck_waves_;
  double w_hover_{0.0};
  bool diverge_injected_{false};
  Eigen::Vector3d v_prev_{Eigen::Vector3d::Zero()};
  VehicleTruth truth_;
};

}  // namespace lander::sim
