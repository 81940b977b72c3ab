// Motion of a boat's deck under the platform (issue 56): heave, roll and pitch as sums of
// sinusoids, on top of the cart's path (the deck moves with the cart, the path is the boat's
// track). Given as a sea state (components drawn per run from the scenario's seed) or as the
// components themselves. Closed form in time, so the reference and its derivatives are exact
// at any instant; the plant drives models/cart_deck.xml's three deck joints along it.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "lander/core/params_io.h"

namespace lander::sim {

// One sinusoid of the heave: amplitude_m sin(2 pi t / period_s + phase).
struct HeaveWave {
  double amplitude_m{0.0};
  double period_s{6.0};
  double phase_rad{0.0};  ///< YAML phase_deg
  void validate() const;
};

template <class V>
void visit_fields(V& v, HeaveWave& p) {
  v("amplitude_m", p.amplitude_m, range::closed(0, 3).because("a small boat's deck"), "m", "heave amplitude");
  v("period_s", p.period_s, range::closed(1, 30), "s", "period");
  v("phase_deg", p.phase_rad, range::any, "deg", "phase at t = 0", M_PI / 180.0);
}

// One sinusoid of a tilt (roll about the deck's x, pitch about its y).
struct TiltWave {
  double amplitude_rad{0.0};  ///< YAML amplitude_deg
  double period_s{6.0};
  double phase_rad{0.0};      ///< YAML phase_deg
  void validate() const;
};

template <class V>
void visit_fields(V& v, TiltWave& p) {
  v("amplitude_deg", p.amplitude_rad, range::closed(0, 25).because("beyond it the deck is no landing place"), "deg",
    "tilt amplitude", M_PI / 180.0);
  v("period_s", p.period_s, range::closed(1, 30), "s", "period");
  v("phase_deg", p.phase_rad, range::any, "deg", "phase at t = 0", M_PI / 180.0);
}

struct DeckSeaParams {
  int sea_state{0};  ///< 0: none; 1-5: a small boat's deck in that sea state (table in
                     ///< deck_motion.cpp), added to the components below
  std::vector<HeaveWave> heave;  ///< extra heave components
  std::vector<TiltWave> roll;    ///< extra roll components
  std::vector<TiltWave> pitch;   ///< extra pitch components
  bool present() const { return sea_state > 0 || !heave.empty() || !roll.empty() || !pitch.empty(); }
  // The largest heave (m) and tilt (rad, roll and pitch together) the components can reach:
  // the sums of their amplitudes (the sea state's are fixed by its table, whatever the seed).
  double peak_heave_m() const;
  double peak_tilt_rad() const;
  void validate() const;
};

template <class V>
void visit_fields(V& v, DeckSeaParams& p) {
  v("sea_state", p.sea_state, range::closed(0, 5), "",
    "0 none; 1-5 a small boat's deck in that sea state (Douglas scale)");
  v.list("heave", p.heave);
  v.list("roll", p.roll);
  v.list("pitch", p.pitch);
}

// The deck's sinusoids of one run: amplitude (m or rad), angular frequency (rad/s), phase.
struct DeckWaves {
  struct Wave {
    double amplitude{0.0};
    double omega_radps{0.0};
    double phase_rad{0.0};
  };
  std::vector<Wave> heave, roll, pitch;
  bool empty() const { return heave.empty() && roll.empty() && pitch.empty(); }
};

// The components of one run: the sea state's, drawn from `seed`, then the listed ones.
DeckWaves deck_waves(const DeckSeaParams& p, std::uint64_t seed);

// Deck reference: (heave m, roll rad, pitch rad) and their first two derivatives.
struct DeckReference {
  Eigen::Vector3d q{Eigen::Vector3d::Zero()};
  Eigen::Vector3d qd{Eigen::Vector3d::Zero()};
  Eigen::Vector3d qdd{Eigen::Vector3d::Zero()};
};

DeckReference deck_reference(const DeckWaves& w, double t_s);

// The platform's half side (m), models/cart_top.xml: how far its edge dips when it tilts.
constexpr double kPlatformHalfSide_m = 0.9;
// The lowest the platform's edge may come to the ground at the deck's peaks (m): a deck that
// reaches the road would hit it (the cart's "ground" is no water).
constexpr double kDeckGroundClearance_m = 0.05;

}  // namespace lander::sim
