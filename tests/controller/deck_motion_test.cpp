// DeckMotionPredictor: a heaving, rolling deck measured at 30 Hz with noise is predicted a
// few seconds ahead (checked against the analytic motion), its quiescent periods are found
// where the analytic motion has them, a still deck counts as still, and the bookkeeping
// (history, rejected samples, parameter checks, datum) holds.
#include "lander/controller/deck_motion.h"
#include "lander/core/params_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>

namespace lander::ctl {
namespace {

constexpr double kDegToRad = M_PI / 180.0;
constexpr double kSampleRate_hz = 30.0;  // deck measurements at the camera's frame rate
constexpr double kT0_s = 500.0;          // start of the samples: not 0, times are relative
constexpr double kNoiseZ_m = 0.01;       // the brief's measurement noise (1 sigma)
constexpr double kNoiseAngle_rad = 0.3 * kDegToRad;
constexpr unsigned kSeed = 42;

// The accuracy asked of the prediction 2 s ahead after 12 s of samples. The fit reaches
// < 1 cm, < 0.2 deg and < 1 cm/s over seeds 1-30, so these fail only on a real regression
// (without the frequency refinement the roll is 4.7 deg off).
constexpr double kPredZTol_m = 0.03;
constexpr double kPredAngleTol_rad = 1.0 * kDegToRad;
constexpr double kPredVzTol_mps = 0.05;
// The brief's tolerance on the edges of a quiescent window. A vz error of 5 mm/s (what the
// fit reaches) moves an edge where vz crosses its limit at 0.5 m/s^2 by 10 ms; the scan step
// is 10 ms.
constexpr double kWindowEdgeTol_s = 0.1;
// The fitted heave amplitude against the analytic half peak-to-peak: 1 cm noise over 360
// samples leaves a few mm on each amplitude.
constexpr double kAmplitudeTol_m = 0.01;
// Datum step: the fit is linear in the samples once the frequencies are chosen, and their
// choice sees the detrended residual only, so an offset changes vz by rounding alone (a 25 m
// offset in doubles: ~1e-14 relative).
constexpr double kDatumTol_mps = 1e-9;
constexpr double kDatumZTol_m = 1e-9;
constexpr double kDatumOffset_m = 25.0;

// The brief's deck: heave 0.3 m at 6 s plus 0.1 m at 3.7 s, roll 6 deg at 7 s, no pitch
// (u = t - kT0_s). The phases are chosen so that the quiescent windows of the tests are
// limited once by tilt, once by vz.
struct DeckTruth {
  static constexpr double kW1 = 2.0 * M_PI / 6.0, kW2 = 2.0 * M_PI / 3.7;
  static constexpr double kWr = 2.0 * M_PI / 7.0, kPhase2 = 1.0, kPhaseR = 0.5;
  double z_m(double t) const {
    const double u = t - kT0_s;
    return 0.3 * std::sin(kW1 * u) + 0.1 * std::sin(kW2 * u + kPhase2);
  }
  double vz_mps(double t) const {
    const double u = t - kT0_s;
    return 0.3 * kW1 * std::cos(kW1 * u) + 0.1 * kW2 * std::cos(kW2 * u + kPhase2);
  }
  double roll_rad(double t) const {
    return 6.0 * kDegToRad * std::sin(kWr * (t - kT0_s) + kPhaseR);
  }
  double pitch_rad(double) const { return 0.0; }
  double tilt_rad(double t) const { return std::abs(roll_rad(t)); }  // pitch 0
};

// Samples of `truth` at 30 Hz for u in [u_from_s, u_to_s] (u = t - kT0_s) with the brief's
// Gaussian noise, `z_offset_m` added to z (a datum).
template <class Truth>
void feed(DeckMotionPredictor* p, const Truth& truth, double u_from_s, double u_to_s,
          unsigned seed = kSeed, double z_offset_m = 0.0) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  const int i_from = static_cast<int>(std::lround(u_from_s * kSampleRate_hz));
  const int i_to = static_cast<int>(std::lround(u_to_s * kSampleRate_hz));
  for (int i = i_from; i <= i_to; ++i) {
    const double t = kT0_s + i / kSampleRate_hz;
    p->add({t, truth.z_m(t) + z_offset_m + kNoiseZ_m * n01(rng),
            truth.roll_rad(t) + kNoiseAngle_rad * n01(rng),
            truth.pitch_rad(t) + kNoiseAngle_rad * n01(rng)});
  }
}

// The first quiescent window of the analytic motion, by the definition of next_quiescent
// scanned at 1 ms.
std::optional<QuiescentWindow> truth_quiescent(const DeckTruth& truth, double t_now_s,
                                               double horizon_s, double max_vz_mps,
                                               double max_tilt_rad, double min_duration_s) {
  constexpr double kStep_s = 0.001;
  std::optional<QuiescentWindow> run;
  for (int i = 0; i * kStep_s <= horizon_s + 1e-9; ++i) {
    const double t = t_now_s + i * kStep_s;
    if (std::abs(truth.vz_mps(t)) <= max_vz_mps && truth.tilt_rad(t) <= max_tilt_rad) {
      if (!run) run = QuiescentWindow{t, t};
      run->end_s = t;
    } else if (run) {
      if (run->end_s - run->start_s >= min_duration_s) return run;
      run.reset();
    }
  }
  if (run && run->end_s - run->start_s >= min_duration_s) return run;
  return std::nullopt;
}

// A predictor that has seen the first `u_end_s` seconds of the brief's deck.
DeckMotionPredictor deck_after(double u_end_s) {
  DeckMotionPredictor p;
  feed(&p, DeckTruth{}, 0.0, u_end_s);
  return p;
}

TEST(DeckMotionPredictor, PredictsTwoSecondsAheadAfterTwelveSeconds) {
  // Given 12 s of the two-sinusoid heave and the 7 s roll, noisy, at 30 Hz
  const DeckTruth truth;
  const DeckMotionPredictor p = deck_after(12.0);
  ASSERT_TRUE(p.ready());
  EXPECT_TRUE(p.moving());
  // When the deck is predicted 2 s past the newest sample
  const double t = kT0_s + 14.0;
  const DeckState d = p.predict(t);
  // Then height, vertical speed and attitude match the analytic motion
  EXPECT_NEAR(d.z_m, truth.z_m(t), kPredZTol_m);
  EXPECT_NEAR(d.vz_mps, truth.vz_mps(t), kPredVzTol_mps);
  EXPECT_NEAR(d.roll_rad, truth.roll_rad(t), kPredAngleTol_rad);
  EXPECT_NEAR(d.pitch_rad, truth.pitch_rad(t), kPredAngleTol_rad);
  EXPECT_NEAR(d.tilt_rad, truth.tilt_rad(t), kPredAngleTol_rad);
  // and the fit found the two heave periods and the roll period within 1 % (the refinement
  // reaches ~0.1 %; the grid alone is off by up to half its step, 2 % on the 6 s period)
  const DeckChannelFit& z = p.channel_fit(DeckChannel::kHeave);
  ASSERT_EQ(z.components.size(), 2u);
  EXPECT_NEAR(1.0 / z.components[0].freq_hz, 6.0, 0.06);
  EXPECT_NEAR(1.0 / z.components[1].freq_hz, 3.7, 0.037);
  const DeckChannelFit& roll = p.channel_fit(DeckChannel::kRoll);
  ASSERT_EQ(roll.components.size(), 1u);
  EXPECT_NEAR(1.0 / roll.components[0].freq_hz, 7.0, 0.07);
  EXPECT_TRUE(p.channel_fit(DeckChannel::kPitch).components.empty()) << "pitch is noise only";
}

TEST(DeckMotionPredictor, HeaveAmplitudeIsHalfThePeakToPeakOfTheMotion) {
  // Given the fitted deck, its heave over one 6 s period from the newest sample
  const DeckTruth truth;
  const DeckMotionPredictor p = deck_after(12.0);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (double u = 12.0; u <= 18.0; u += 0.001) {
    lo = std::min(lo, truth.z_m(kT0_s + u));
    hi = std::max(hi, truth.z_m(kT0_s + u));
  }
  // Then heave_amplitude_m is its half peak-to-peak
  EXPECT_NEAR(p.heave_amplitude_m(), 0.5 * (hi - lo), kAmplitudeTol_m);
  EXPECT_GT(p.fit_r2_heave(), 0.99) << "1 cm noise on a 0.3 m heave leaves r2 ~ 0.998";
}

// Checks a predicted window against the analytic one.
void expect_window_matches(const std::optional<QuiescentWindow>& got,
                           const std::optional<QuiescentWindow>& want, double min_duration_s) {
  ASSERT_TRUE(want.has_value()) << "test setup: the analytic motion has no window";
  ASSERT_TRUE(got.has_value()) << "expected a window at " << want->start_s - kT0_s;
  EXPECT_NEAR(got->start_s, want->start_s, kWindowEdgeTol_s);
  EXPECT_NEAR(got->end_s, want->end_s, kWindowEdgeTol_s);
  EXPECT_GE(got->end_s - got->start_s, min_duration_s);
}

TEST(DeckMotionPredictor, QuiescentWindowStartsWhereTiltFallsBelowItsLimit) {
  // Given 12 s of the deck; vz 0.1 m/s and tilt 3 deg for 0.3 s
  const DeckTruth truth;
  const DeckMotionPredictor p = deck_after(12.0);
  const double t_now = kT0_s + 12.0, horizon = 4.0, vz = 0.1, tilt = 3.0 * kDegToRad;
  const double min_duration = 0.3;
  // When the next window is sought
  const auto got = p.next_quiescent(t_now, horizon, vz, tilt, min_duration);
  // Then it is the analytic one: from the roll passing 3 deg (u = 12.86 s) to vz passing
  // 0.1 m/s (u = 14.03 s)
  const auto want = truth_quiescent(truth, t_now, horizon, vz, tilt, min_duration);
  expect_window_matches(got, want, min_duration);
  ASSERT_TRUE(want.has_value());
  EXPECT_NEAR(want->start_s - kT0_s, 12.86, 0.01) << "test setup: the tilt-limited start";
}

TEST(DeckMotionPredictor, QuiescentWindowSkipsARunShorterThanMinDuration) {
  // Given 14 s of the deck (the window has slid by 2 s); vz 0.1 m/s and tilt 4 deg for 0.3 s
  const DeckTruth truth;
  const DeckMotionPredictor p = deck_after(14.0);
  const double t_now = kT0_s + 14.0, horizon = 4.0, vz = 0.1, tilt = 4.0 * kDegToRad;
  const double min_duration = 0.3;
  // When the next window is sought
  const auto got = p.next_quiescent(t_now, horizon, vz, tilt, min_duration);
  // Then the run at t_now (0.26 s, vz rising through 0.1 m/s) is passed over for the one
  // where vz falls below 0.1 m/s (u = 16.55 s, 0.35 s long)
  const auto want = truth_quiescent(truth, t_now, horizon, vz, tilt, min_duration);
  expect_window_matches(got, want, min_duration);
  ASSERT_TRUE(want.has_value());
  EXPECT_NEAR(want->start_s - kT0_s, 16.547, 0.01) << "test setup: the vz-limited start";
  // and a window longer than both runs is not found
  EXPECT_FALSE(p.next_quiescent(t_now, horizon, vz, tilt, 0.6).has_value());
}

// Noise only: the deck at 2 m, level.
struct StillDeck {
  double z_m(double) const { return 2.0; }
  double roll_rad(double) const { return 0.0; }
  double pitch_rad(double) const { return 0.0; }
};

TEST(DeckMotionPredictor, StillDeckIsReadyNotMovingAndQuiescentNow) {
  // Given 12 s of a still deck measured with the brief's noise
  DeckMotionPredictor p;
  feed(&p, StillDeck{}, 0.0, 12.0);
  // Then it is still, and its fit (nothing but noise to explain) is trusted
  EXPECT_FALSE(p.moving());
  EXPECT_TRUE(p.ready());
  EXPECT_LT(p.heave_amplitude_m(), 0.01) << "no heave beyond the noise";
  // and the next quiescent window starts now and lasts the whole horizon
  const double t_now = kT0_s + 12.0, horizon = 5.0;
  const auto w = p.next_quiescent(t_now, horizon, 0.05, 2.0 * kDegToRad, 1.0);
  ASSERT_TRUE(w.has_value());
  EXPECT_DOUBLE_EQ(w->start_s, t_now);
  EXPECT_DOUBLE_EQ(w->end_s, t_now + horizon);
}

TEST(DeckMotionPredictor, NotReadyWithLessThanMinHistory) {
  // Given 5 s of samples (min_history_s 6 s)
  DeckMotionPredictor p;
  feed(&p, DeckTruth{}, 0.0, 5.0);
  // Then there is no fit: not ready, no prediction, no window
  EXPECT_FALSE(p.has_fit());
  EXPECT_FALSE(p.ready());
  EXPECT_FALSE(p.moving());
  EXPECT_THROW(p.predict(kT0_s + 5.0), std::logic_error);
  EXPECT_FALSE(p.next_quiescent(kT0_s + 5.0, 5.0, 1.0, 1.0, 0.0).has_value());
  // When the history reaches 6.5 s, it fits
  feed(&p, DeckTruth{}, 5.0 + 1.0 / kSampleRate_hz, 6.5);
  EXPECT_TRUE(p.has_fit());
}

TEST(DeckMotionPredictor, AFitThatOnlyInterpolatesIsNotReady) {
  // Given 8 s of the deck: the fit of a partial roll cycle and 1.3 heave cycles interpolates
  // the samples well (r2 > 0.99) but predicts them badly
  const DeckTruth truth;
  const DeckMotionPredictor p = deck_after(8.0);
  ASSERT_TRUE(p.has_fit());
  EXPECT_GT(p.fit_r2_heave(), 0.99);
  EXPECT_GT(std::abs(p.predict(kT0_s + 10.0).z_m - truth.z_m(kT0_s + 10.0)), kPredZTol_m)
      << "test setup: the fit at 8 s should not extrapolate";
  // Then the backtest (the last 2 s predicted from the 6 s before) says so: not ready
  EXPECT_GT(p.backtest_error(DeckChannel::kHeave), DeckMotionParams{}.max_backtest_error_m);
  EXPECT_FALSE(p.ready());
  EXPECT_FALSE(p.next_quiescent(kT0_s + 8.0, 5.0, 1.0, 1.0, 0.0).has_value());
  // and without the backtest (backtest_s 0: r2 alone) the same samples are taken as ready
  DeckMotionParams r2_only;
  r2_only.backtest_s = 0.0;
  DeckMotionPredictor q(r2_only);
  feed(&q, truth, 0.0, 8.0);
  EXPECT_TRUE(q.ready());
  EXPECT_TRUE(std::isnan(q.backtest_error(DeckChannel::kHeave)));
}

TEST(DeckMotionPredictor, BacktestPassesOnceTheHistoryResolvesTheMotion) {
  // Given 12 s of the deck, the backtest predicts the last 2 s from 10 s of samples
  const DeckMotionPredictor p = deck_after(12.0);
  // Then its errors, noise removed, are well inside the limits (a few mm, a few 0.1 deg)
  EXPECT_LT(p.backtest_error(DeckChannel::kHeave), 0.5 * DeckMotionParams{}.max_backtest_error_m);
  EXPECT_LT(p.backtest_error(DeckChannel::kRoll), 0.5 * DeckMotionParams{}.max_backtest_error_rad);
  EXPECT_LT(p.backtest_error(DeckChannel::kPitch), 0.5 * DeckMotionParams{}.max_backtest_error_rad);
}

TEST(DeckMotionPredictor, KeepsOnlyTheWindow) {
  // Given 20 s of samples and a 12 s window
  const DeckMotionPredictor p = deck_after(20.0);
  // Then 12 s of them are held (one sample per 1/30 s, both ends included)
  EXPECT_NEAR(p.history_s(), 12.0, 1e-9);
  EXPECT_EQ(p.num_samples(), 12 * 30 + 1);
}

TEST(DeckMotionPredictor, NonFiniteAndOutOfOrderSamplesAreIgnoredAndCounted) {
  // Given 6 s of the deck with bad samples after it, and the same 6 s alone
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  DeckMotionPredictor p;
  feed(&p, DeckTruth{}, 0.0, 6.0);
  p.add({kT0_s + 6.01, nan, 0.0, 0.0});
  p.add({kT0_s + 6.01, 0.0, inf, 0.0});
  p.add({kT0_s + 6.01, 0.0, 0.0, -inf});
  p.add({nan, 0.0, 0.0, 0.0});
  p.add({kT0_s + 5.0, 0.0, 0.0, 0.0});  // older than the newest sample
  const DeckMotionPredictor clean = deck_after(6.0);
  // Then the bad ones are counted and not held
  EXPECT_EQ(p.rejected_samples(), 5);
  EXPECT_EQ(clean.rejected_samples(), 0);
  EXPECT_EQ(p.num_samples(), clean.num_samples());
  // and the predictions are those of the clean samples, to the last bit
  const DeckState a = p.predict(kT0_s + 8.0), b = clean.predict(kT0_s + 8.0);
  EXPECT_EQ(a.z_m, b.z_m);
  EXPECT_EQ(a.vz_mps, b.vz_mps);
  EXPECT_EQ(a.roll_rad, b.roll_rad);
  EXPECT_EQ(a.pitch_rad, b.pitch_rad);
  // and reset() clears the count
  p.reset();
  EXPECT_EQ(p.rejected_samples(), 0);
  EXPECT_EQ(p.num_samples(), 0);
}

// Expects `p.validate()` to throw ConfigError naming `field`.
void expect_rejects(const DeckMotionParams& p, const std::string& field) {
  try {
    p.validate();
    ADD_FAILURE() << "validate() accepted a bad " << field;
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("'" + field + "'"), std::string::npos) << e.what();
  }
}

TEST(DeckMotionParams, DefaultIsValid) { EXPECT_NO_THROW(DeckMotionParams{}.validate()); }

TEST(DeckMotionParams, BadValuesThrowNamingTheField) {
  DeckMotionParams p;
  p.min_period_s = p.max_period_s;
  expect_rejects(p, "min_period_s");
  p = {};
  p.min_period_s = 20.0;
  expect_rejects(p, "min_period_s");
  p = {};
  p.window_s = p.min_history_s - 0.5;
  expect_rejects(p, "window_s");
  p = {};
  p.window_s = std::numeric_limits<double>::quiet_NaN();
  expect_rejects(p, "window_s");
  p = {};
  p.max_components = 0;
  expect_rejects(p, "max_components");
  p = {};
  p.min_fit_r2 = 1.5;
  expect_rejects(p, "min_fit_r2");
  p = {};
  p.moving_heave_m = 0.0;
  expect_rejects(p, "moving_heave_m");
  p = {};
  p.quiescent_step_s = -0.01;
  expect_rejects(p, "quiescent_step_s");
  p = {};
  p.backtest_s = p.window_s - p.min_history_s + 0.5;  // the backtest's fit could never start
  expect_rejects(p, "backtest_s");
  // and the predictor checks its params
  p = {};
  p.min_period_s = 16.0;
  EXPECT_THROW(DeckMotionPredictor{p}, ConfigError);
}

TEST(DeckMotionPredictor, NextQuiescentRejectsBadArguments) {
  const DeckMotionPredictor p = deck_after(12.0);
  EXPECT_THROW(p.next_quiescent(kT0_s + 12.0, -1.0, 0.1, 0.1, 0.1), std::invalid_argument);
  EXPECT_THROW(p.next_quiescent(kT0_s + 12.0, 4.0, std::nan(""), 0.1, 0.1), std::invalid_argument);
}

TEST(DeckMotionPredictor, DatumStepDoesNotChangeVerticalSpeed) {
  // Given predictions from the deck, then (after reset) from the same samples 25 m higher
  DeckMotionPredictor p;
  feed(&p, DeckTruth{}, 0.0, 12.0);
  const double times[] = {kT0_s + 10.0, kT0_s + 12.0, kT0_s + 13.0, kT0_s + 14.5};
  DeckState before[4];
  for (int i = 0; i < 4; ++i) before[i] = p.predict(times[i]);
  p.reset();
  feed(&p, DeckTruth{}, 0.0, 12.0, kSeed, kDatumOffset_m);
  // Then vz is the same and z moved by the offset
  for (int i = 0; i < 4; ++i) {
    const DeckState after = p.predict(times[i]);
    EXPECT_NEAR(after.vz_mps, before[i].vz_mps, kDatumTol_mps) << "at u = " << times[i] - kT0_s;
    EXPECT_NEAR(after.z_m - kDatumOffset_m, before[i].z_m, kDatumZTol_m);
  }
}

}  // namespace
}  // namespace lander::ctl
