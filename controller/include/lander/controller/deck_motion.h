// Deck motion prediction for a touchdown on a heaving, rolling boat deck: a sum-of-sinusoids
// fit per channel (heave, roll, pitch) of the recent deck measurements, its analytic
// prediction a few seconds ahead, and the next "quiescent period" (small vertical speed and
// small tilt for long enough) by that prediction. Depends on Eigen and the standard library
// only.
//
// Model of one channel y (heave z in m, roll or pitch in rad), tau = t - t_ref with t_ref the
// newest sample at the fit:
//   y(tau)  = c0 + c1 tau [+ c2 tau^2] + sum_k [a_k cos(w_k tau) + b_k sin(w_k tau)],  w_k = 2 pi f_k
//   y'(tau) = c1 + 2 c2 tau + sum_k w_k [b_k cos(w_k tau) - a_k sin(w_k tau)]            (1)
// with f_k in [1/max_period_s, 1/min_period_s] and at most max_components terms.
//
// Fit of one channel over the samples of the last window_s (DeckMotionPredictor::fit):
//  1. Least squares of c0 + c1 tau (+ c2 tau^2 with quadratic_trend: a datum drifting with
//     an acceleration, as an inertial height does); its residual r is what the sinusoids
//     must explain.
//  2. Noise: sigma from the three-point residuals e_i = y_i - (w- y_{i-1} + w+ y_{i+1}) (linear
//     interpolation of the neighbours; a smooth deck motion cancels to O(dt^2 y'')):
//       sigma = 1.4826 median(|e_i| / sqrt(1 + w-^2 + w+^2))                               (2)
//  3. Greedy search: on the grid f_j = 1/max_period_s ... 1/min_period_s, step at most
//     1/(4 window_s), the 2x2 least squares of r against (cos, sin)(w_j tau) removes
//       dSS_j = [a b] [sum r cos, sum r sin]^T                                              (3)
//     the frequency with the largest dSS_j joins the model. Stops at max_components, when
//     the best dSS_j is below 2 % of the detrended sum of squares, or when the residual
//     variance is within kNoiseVarianceMargin of sigma^2 (nothing but noise left).
//  4. After each addition, c0, c1, c2, a_k, b_k of all terms are refitted jointly (linear least
//     squares: LDLT of the column-scaled normal equations, ColPivHouseholderQR if they are
//     near singular) and the frequencies refined by Gauss-Newton with variable
//     projection (the Jacobian of (1) in w_k, the linear coefficients re-solved at each trial,
//     a step kept only if it lowers the residual), each w_k within half a Rayleigh cell
//     (1 / (2 window_s)) of where the grid found it. r becomes the residual of the joint fit.
// The fit runs lazily, at the first query after new samples (one fit per sample at most).
//
// Trust (ready()). A good r2 says the fit interpolates the window, not that it extrapolates:
// with 6-8 s of history a 6-7 s period plus the trend fits a partial cycle with r2 > 0.99 and
// predicts 0.4 m and 13 deg wrong 2 s ahead. So ready() also asks for a backtest: the samples
// of the last backtest_s are predicted by a fit (steps 1-4) of the samples before them, and
// the prediction error, RMS with the measurement noise removed,
//   err = sqrt(max(0, mean_i (y_i - y_past(t_i))^2 - sigma^2))                              (4)
// must stay within max_backtest_error_m (heave) and max_backtest_error_rad (roll, pitch).
// It needs min_history_s + backtest_s of samples and a second fit, lazily at ready().
#pragma once

#include <array>
#include <cstddef>
#include <deque>
#include <optional>
#include <vector>

namespace lander::ctl {

struct DeckMotionParams {
  double window_s{12.0};           ///< history used for the fit (s); older samples are dropped
  double min_history_s{6.0};       ///< fit only once the samples span this long (s)
  int max_components{3};           ///< sinusoids per channel, in [1, 8]
  double min_period_s{2.0};        ///< shortest period searched (s), > 0
  double max_period_s{15.0};       ///< longest period searched (s), > min_period_s
  double min_fit_r2{0.6};          ///< a channel's fit with a smaller coefficient of
                                   ///< determination is trusted only if the channel is still
  double moving_heave_m{0.05};     ///< the deck counts as still below this heave amplitude (m)
  double moving_tilt_rad{0.0175};  ///< ... and below this tilt amplitude (rad)
  double quiescent_step_s{0.01};   ///< time step of next_quiescent's scan of the prediction (s)
  /// A quadratic trend c2 tau^2 besides c0 + c1 tau (a datum drifting with an acceleration,
  /// as an inertial height on a biased accelerometer does); it costs extrapolation: 2 s ahead
  /// of a 12 s fit of a clean deck errs ~3 cm and ~0.7 deg with it, a few mm without.
  bool quadratic_trend{false};
  /// The heave's trend (c1 + 2 c2 tau) is the samples' datum drifting, not the deck:
  /// predict()'s vz_mps (and so next_quiescent) leaves it out.
  bool heave_trend_is_drift{true};
  /// The newest backtest_s of samples are predicted from those before them for ready(), eq. (4)
  /// (s), in [0, window_s - min_history_s]; 0 turns the backtest off (ready() on r2 alone).
  double backtest_s{2.0};
  double max_backtest_error_m{0.05};      ///< largest heave backtest error, eq. (4) (m)
  double max_backtest_error_rad{0.0175};  ///< largest roll or pitch backtest error, eq. (4) (rad)
  /// Throws std::invalid_argument("invalid value for '<field>': <problem>") on a bad value.
  void validate() const;
};

/// One deck measurement.
struct DeckSample {
  double t_s{0.0};        ///< measurement time (s)
  double z_m{0.0};        ///< deck height in a world frame, any datum (m), up positive
  double roll_rad{0.0};   ///< deck roll about its x axis (rad); R = Rz(yaw) Ry(pitch) Rx(roll)
  double pitch_rad{0.0};  ///< deck pitch about its y axis (rad)
};

/// The deck at one time, by the fit.
struct DeckState {
  double z_m{0.0};               ///< deck height, same datum as the samples (m)
  double vz_mps{0.0};            ///< vertical speed (m/s), up positive
  double roll_rad{0.0};          ///< roll (rad)
  double pitch_rad{0.0};         ///< pitch (rad)
  double tilt_rad{0.0};          ///< angle of the deck normal from vertical (rad), >= 0:
                                 ///< cos(tilt) = cos(roll) cos(pitch)
  double roll_rate_radps{0.0};   ///< d roll / dt (rad/s)
  double pitch_rate_radps{0.0};  ///< d pitch / dt (rad/s)
};

/// A time interval [start_s, end_s] (s).
struct QuiescentWindow {
  double start_s{0.0};  ///< first time the conditions hold (s)
  double end_s{0.0};    ///< last time they hold, at most the end of the horizon (s)
};

enum class DeckChannel { kHeave = 0, kRoll = 1, kPitch = 2 };

/// One sinusoid of a channel's fit: a cos(2 pi f tau) + b sin(2 pi f tau), tau = t - t_ref.
/// Units of a and b: m for heave, rad for roll and pitch.
struct DeckComponent {
  double freq_hz{0.0};       ///< frequency f (Hz)
  double cos_coef{0.0};      ///< a (m or rad)
  double sin_coef{0.0};      ///< b (m or rad)
  double amplitude() const;  ///< hypot(a, b) (m or rad)
};

/// The fit of one channel, model (1). Units: m for heave, rad for roll and pitch ("u").
struct DeckChannelFit {
  double t_ref_s{0.0};                    ///< time origin of tau (s): newest sample at the fit
  double c0{0.0};                         ///< constant (u): the non-oscillating part at t_ref
  double c1_per_s{0.0};                   ///< linear trend (u/s)
  double c2_per_s2{0.0};                  ///< quadratic trend (u/s^2)
  std::vector<DeckComponent> components;  ///< the sinusoids, in the order the search found them
  double r2{1.0};            ///< 1 - SS_res / SS_tot (SS_tot about the mean); 1 if SS_tot is 0
  double residual_rms{0.0};  ///< sqrt(SS_res / N) (u): noise plus motion the model misses
  double noise_rms{0.0};     ///< measurement noise, eq. (2) (u)
  /// Half the peak-to-peak of the sinusoids' sum (no c0, c1) over one longest fitted period
  /// from t_ref (u); 0 without components.
  double amplitude{0.0};
  double value(double t_s) const;  ///< y at t_s, eq. (1) (u)
  double rate(double t_s) const;   ///< y' at t_s, eq. (1) (u/s)
};

// Call order: add() samples in time order; query (ready(), predict(), ...) at any time. The
// queries refit lazily (mutable cache), so one object must not be shared between threads
// without a lock. Cost: one fit per new sample at most; see deck_motion.cpp for figures.
class DeckMotionPredictor {
 public:
  /// Throws std::invalid_argument if `p` does not validate().
  explicit DeckMotionPredictor(const DeckMotionParams& p = {});

  /// Adds one sample. Samples older than window_s before it are dropped. A sample with a
  /// non-finite field, or earlier than the newest one held, is ignored and counted in
  /// rejected_samples(). A step of the z datum within the window would be fitted as deck
  /// motion: reset() on a datum change.
  void add(const DeckSample& s);
  /// Forgets all samples and the fit (rejected_samples() too).
  void reset();

  /// The fit exists (has_fit()) and every channel is trusted: r2 >= min_fit_r2, or the
  /// channel is still (amplitude and residual_rms below moving_heave_m for heave,
  /// moving_tilt_rad for roll and pitch: a still channel has nothing to explain); and, unless
  /// backtest_s is 0, every channel's backtest_error() is within max_backtest_error_m (heave)
  /// or max_backtest_error_rad (roll, pitch), which takes min_history_s + backtest_s of
  /// samples (8 s by default).
  bool ready() const;
  /// The deck moves: heave_amplitude_m() >= moving_heave_m, tilt_amplitude_rad() >=
  /// moving_tilt_rad, or motion the fit does not explain as large (heave residual_rms >=
  /// moving_heave_m, hypot of the roll and pitch residual_rms >= moving_tilt_rad). False
  /// without a fit.
  bool moving() const;
  /// A fit exists: the samples span min_history_s and there are enough of them.
  bool has_fit() const;

  /// The deck at t_s by the last fit, eq. (1), and the tilt from roll and pitch. Valid for
  /// any t_s; best within a few seconds after the newest sample (the trend is extrapolated
  /// linearly). Throws std::logic_error without a fit (has_fit() false).
  DeckState predict(double t_s) const;

  /// First interval in [t_now_s, t_now_s + horizon_s] during which the prediction has |vz| <=
  /// max_vz_mps and tilt <= max_tilt_rad for at least min_duration_s (end_s - start_s), the
  /// prediction scanned every quiescent_step_s; end_s is the last scanned time the conditions
  /// hold (the horizon's end at most). nullopt if there is none or !ready(). Throws
  /// std::invalid_argument on negative or non-finite arguments.
  std::optional<QuiescentWindow> next_quiescent(double t_now_s, double horizon_s, double max_vz_mps,
                                                double max_tilt_rad, double min_duration_s) const;

  /// Heave amplitude (m): DeckChannelFit::amplitude of heave; 0 without a fit.
  double heave_amplitude_m() const;
  /// Tilt amplitude (rad): hypot of the roll and pitch DeckChannelFit::amplitude (for small
  /// angles a bound on the swing of the deck normal, reached when the two are in phase); 0
  /// without a fit.
  double tilt_amplitude_rad() const;
  double fit_r2_heave() const;  ///< r2 of the heave fit; 0 without a fit
  /// The fit of one channel. Throws std::logic_error without a fit.
  const DeckChannelFit& channel_fit(DeckChannel c) const;
  /// Backtest error of one channel, eq. (4) (m or rad); NaN while there is none (backtest_s
  /// 0, no fit, the samples before the last backtest_s span less than min_history_s, or fewer
  /// than 5 samples in the last backtest_s).
  double backtest_error(DeckChannel c) const;
  /// Samples ignored since the last reset(): non-finite or out of time order.
  int rejected_samples() const { return rejected_; }
  /// Time spanned by the samples held (s): newest minus oldest; 0 when empty.
  double history_s() const;
  int num_samples() const { return static_cast<int>(samples_.size()); }

  // The fit of all three channels over the first `count` of `samples` (time order, spanning
  // at most window_s), steps 1-4 above, t_ref the newest of them. False (fits untouched) with
  // too few samples for a fit.
  static bool fit(const std::deque<DeckSample>& samples, std::size_t count,
                  const DeckMotionParams& p, std::array<DeckChannelFit, 3>* fits);

 private:
  void refit_if_needed() const;
  void backtest_if_needed() const;
  bool channel_still(DeckChannel c) const;

  DeckMotionParams p_;
  std::deque<DeckSample> samples_;
  int rejected_{0};
  mutable bool dirty_{false};   ///< samples changed since the last fit
  mutable bool fitted_{false};  ///< fits_ holds a fit of enough history
  mutable std::array<DeckChannelFit, 3> fits_;
  mutable bool backtest_dirty_{false};  ///< samples changed since the last backtest
  mutable bool backtested_{false};      ///< backtest_error_ holds a backtest of the samples
  mutable std::array<double, 3> backtest_error_{};  ///< eq. (4) per channel (m or rad)
};

}  // namespace lander::ctl
