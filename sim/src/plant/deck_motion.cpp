#include "lander/sim/plant/deck_motion.h"

#include <cmath>
#include <random>

namespace lander::sim {

void HeaveWave::validate() const { check_fields(*this); }
void TiltWave::validate() const { check_fields(*this); }

void DeckSeaParams::validate() const {
  check_fields(*this);
  for (std::size_t i = 0; i < heave.size(); ++i) validate_item("heave", i, heave[i]);
  for (std::size_t i = 0; i < roll.size(); ++i) validate_item("roll", i, roll[i]);
  for (std::size_t i = 0; i < pitch.size(); ++i) validate_item("pitch", i, pitch[i]);
}

namespace {

double sum_of(const std::vector<DeckWaves::Wave>& waves) {
  double s = 0.0;
  for (const DeckWaves::Wave& w : waves) s += w.amplitude;
  return s;
}

}  // namespace

// The amplitudes do not depend on the seed (only the periods and phases do).
double DeckSeaParams::peak_heave_m() const { return sum_of(deck_waves(*this, 0).heave); }

double DeckSeaParams::peak_tilt_rad() const {
  const DeckWaves w = deck_waves(*this, 0);
  return sum_of(w.roll) + sum_of(w.pitch);
}

namespace {

// A small boat's deck (a 6-10 m workboat or USV) by sea state on the Douglas scale: the
// significant wave height's middle (m) scaled by a heave response of about one half for such
// a hull in waves longer than itself, the roll and pitch amplitudes and the modal period of
// the encounter. The "significant" amplitude below is the RMS of the sum's components times
// sqrt(2) (one sinusoid of that amplitude has the same RMS); the peaks of a three-component
// sum reach about 1.6 times it. Sea state 3 (slight, waves 0.5-1.25 m): 0.30 m, 5 deg, 3 deg,
// 6 s.
struct SeaStateRow {
  double heave_m, roll_deg, pitch_deg, period_s;
};
constexpr SeaStateRow kSeaStates[6] = {
    {0.0, 0.0, 0.0, 4.0},    // 0: calm (glassy)
    {0.03, 1.0, 0.5, 4.0},   // 1: calm (rippled), waves 0-0.1 m
    {0.12, 2.5, 1.5, 5.0},   // 2: smooth, 0.1-0.5 m
    {0.30, 5.0, 3.0, 6.0},   // 3: slight, 0.5-1.25 m
    {0.60, 9.0, 5.0, 7.0},   // 4: moderate, 1.25-2.5 m
    {1.00, 14.0, 8.0, 8.0},  // 5: rough, 2.5-4 m
};

// Three components about the modal period (0.75, 1, 1.35 of it, each moved by up to +-10 %),
// amplitudes in the ratio 0.6 : 0.8 : 0.45 (the spectrum's peak in the middle) scaled to the
// significant amplitude, random phases.
void draw_components(double significant, double modal_period_s, std::mt19937_64& rng,
                     std::vector<DeckWaves::Wave>* out) {
  if (significant <= 0.0) return;
  const double period_factor[3] = {0.75, 1.0, 1.35}, share[3] = {0.6, 0.8, 0.45};
  const double norm = std::sqrt(share[0] * share[0] + share[1] * share[1] + share[2] * share[2]);
  std::uniform_real_distribution<double> jitter(0.9, 1.1), phase(0.0, 2.0 * M_PI);
  for (int i = 0; i < 3; ++i) {
    const double period = modal_period_s * period_factor[i] * jitter(rng);
    out->push_back({significant * share[i] / norm, 2.0 * M_PI / period, phase(rng)});
  }
}

template <class W>
void append(const std::vector<W>& listed, double W::*amplitude, std::vector<DeckWaves::Wave>* out) {
  for (const W& w : listed) out->push_back({w.*amplitude, 2.0 * M_PI / w.period_s, w.phase_rad});
}

// Sum of the sinusoids and its first two derivatives.
void sum_waves(const std::vector<DeckWaves::Wave>& waves, double t, double& q, double& qd, double& qdd) {
  q = qd = qdd = 0.0;
  for (const DeckWaves::Wave& w : waves) {
    const double a = w.omega_radps * t + w.phase_rad, s = std::sin(a), c = std::cos(a);
    q += w.amplitude * s;
    qd += w.amplitude * w.omega_radps * c;
    qdd -= w.amplitude * w.omega_radps * w.omega_radps * s;
  }
}

}  // namespace

DeckWaves deck_waves(const DeckSeaParams& p, std::uint64_t seed) {
  DeckWaves w;
  if (p.sea_state > 0) {
    const SeaStateRow& row = kSeaStates[p.sea_state];
    std::mt19937_64 rng(seed);
    const double deg = M_PI / 180.0;
    draw_components(row.heave_m, row.period_s, rng, &w.heave);
    draw_components(row.roll_deg * deg, row.period_s * 1.1, rng, &w.roll);  // roll a little slower
    draw_components(row.pitch_deg * deg, row.period_s * 0.8, rng, &w.pitch);
  }
  append(p.heave, &HeaveWave::amplitude_m, &w.heave);
  append(p.roll, &TiltWave::amplitude_rad, &w.roll);
  append(p.pitch, &TiltWave::amplitude_rad, &w.pitch);
  return w;
}

DeckReference deck_reference(const DeckWaves& w, double t_s) {
  DeckReference r;
  const std::vector<DeckWaves::Wave>* axes[3] = {&w.heave, &w.roll, &w.pitch};
  for (int i = 0; i < 3; ++i) sum_waves(*axes[i], t_s, r.q[i], r.qd[i], r.qdd[i]);
  return r;
}

}  // namespace lander::sim
