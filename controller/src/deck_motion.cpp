// Deck motion prediction: sum-of-sinusoids fit per channel and quiescent periods (see
// deck_motion.h for the model, eq. 1-3, and the fit's steps).
//
// Cost (g++ 12 -O2, one core of a shared 2-core development VM under load, 30 Hz samples,
// 12 s window = 361 samples, the two-sinusoid heave and 7 s roll of deck_motion_test): the
// fit of the three channels 0.3-0.5 ms (0.05-0.08 ms for a still deck: nothing to search
// past the trend), the backtest's second fit about the same, so 0.6-1 ms per sample when
// ready() is asked every sample; predict() ~0.2 us; next_quiescent over 5 s ~0.1 ms. Most of
// the fit is the sin/cos of the design matrices and the grid.
#include "lander/controller/deck_motion.h"

#include "lander/controller/params.h"  // visit_fields of DeckMotionParams
#include "lander/core/params_io.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/Dense>

namespace lander::ctl {
namespace {
constexpr double kTwoPi = 2.0 * M_PI;
// A component joins only if it removes at least this share of the detrended sum of squares
// (the brief's 2 %): weaker lines are leakage or noise, not deck motion worth predicting.
constexpr double kMinExplainedShare = 0.02;
// The residual is taken as noise once its variance is within this factor of sigma^2 (eq. 2).
// The median estimate of sigma scatters by 10 % at 180 samples, 7 % at 360; with this margin
// 5 of 900 noise-only channels (12 s at 30 Hz) got a component, of 2 mm at most.
constexpr double kNoiseVarianceMargin = 1.25;
// Gauss-Newton refinement of the frequencies: iterations, step halvings per iteration, and
// the frequency change (Hz) below which it stops: 1e-5 Hz moves the phase 15 s from the
// window's start (3 s ahead) by 1e-3 rad, 0.3 mm on a 0.3 m heave. Bounds the cost: per
// channel at most max_components refinements of kGaussNewtonIterations steps, each one
// least-squares solve with the Jacobian and up to kStepHalvings + 1 linear solves.
constexpr int kGaussNewtonIterations = 6;
constexpr int kStepHalvings = 4;
constexpr double kFreqTolerance_hz = 1e-5;
// A fit needs this many samples; each model parameter needs kSamplesPerParameter of them.
constexpr int kMinSamples = 10;
constexpr int kSamplesPerParameter = 3;
// The backtest needs this many predicted samples (its RMS error of fewer is mostly noise).
constexpr std::size_t kMinBacktestSamples = 5;
// Bounds of the parameters that set the fit's cost.
constexpr int kMaxComponents = 8;
constexpr int kMaxGridFrequencies = 512;
// The amplitude (half peak-to-peak) is sampled this many times per shortest fitted period.
constexpr int kAmplitudeSamplesPerPeriod = 32;
// Smallest pivot of the unit-diagonal normal matrix the LDLT solve accepts (1 / its condition).
constexpr double kMinNormalPivot = 1e-10;
// Median absolute deviation to standard deviation for Gaussian noise.
constexpr double kMadToSigma = 1.4826;
// Slack of time comparisons (s): sample times from sums of 1/30 s.
constexpr double kTimeEpsilon_s = 1e-9;

// Params errors are the project's ConfigError ("invalid value for '<key>': ..."), keys as
// the YAML spells them (controller.deck.predictor.*).
using lander::require;

// Frequencies on the search grid: 1/max_period_s ... 1/min_period_s, both included, step at
// most 1/(4 window_s) (a quarter of the window's Rayleigh resolution).
int grid_size(const DeckMotionParams& p) {
  const double band_hz = 1.0 / p.min_period_s - 1.0 / p.max_period_s;
  return static_cast<int>(std::ceil(band_hz * 4.0 * p.window_s - 1e-9)) + 1;
}

// The samples as columns: tau = t - t_ref (s), t_ref the newest; y per channel.
struct Series {
  double t_ref_s{0.0};
  Eigen::VectorXd tau_s;
  std::array<Eigen::VectorXd, 3> y;
};

// The value of channel ch (0 heave, 1 roll, 2 pitch) of a sample.
double channel_value(const DeckSample& d, int ch) {
  return ch == 0 ? d.z_m : ch == 1 ? d.roll_rad : d.pitch_rad;
}

// The first n samples.
Series series_of(const std::deque<DeckSample>& samples, int n) {
  Series s;
  s.t_ref_s = samples[n - 1].t_s;
  s.tau_s.resize(n);
  for (auto& y : s.y) y.resize(n);
  for (int i = 0; i < n; ++i) {
    const DeckSample& d = samples[i];
    s.tau_s(i) = d.t_s - s.t_ref_s;
    for (int ch = 0; ch < 3; ++ch) s.y[ch](i) = channel_value(d, ch);
  }
  return s;
}

// Measurement noise, eq. (2): each interior sample against the linear interpolation of its
// neighbours; e_i = y_i - (w- y_{i-1} + w+ y_{i+1}) has variance sigma^2 (1 + w-^2 + w+^2).
double noise_rms(const Eigen::VectorXd& tau, const Eigen::VectorXd& y) {
  std::vector<double> e;
  e.reserve(tau.size());
  for (int i = 1; i + 1 < tau.size(); ++i) {
    const double span = tau(i + 1) - tau(i - 1);
    if (span <= 0.0) continue;  // repeated times: no interpolation
    const double w_next = (tau(i) - tau(i - 1)) / span;
    const double w_prev = 1.0 - w_next;
    const double ei = y(i) - (w_prev * y(i - 1) + w_next * y(i + 1));
    e.push_back(std::abs(ei) / std::sqrt(1.0 + w_prev * w_prev + w_next * w_next));
  }
  if (e.empty()) return 0.0;
  auto mid = e.begin() + e.size() / 2;
  std::nth_element(e.begin(), mid, e.end());
  return kMadToSigma * *mid;
}

// cos and sin of every grid frequency at every sample (rows: frequencies), built by the
// recurrence exp(i w_j tau) = exp(i w_0 tau) exp(i dw tau)^j (two sin/cos pairs per sample),
// and the 2x2 Gram matrix of each frequency (the same for the three channels).
struct Grid {
  Eigen::VectorXd f_hz;
  Eigen::MatrixXd C, S;           // nf x N
  Eigen::VectorXd scc, sss, scs;  // sum cos^2, sum sin^2, sum cos sin, per frequency
};

Grid make_grid(const Eigen::VectorXd& tau, const DeckMotionParams& p) {
  const int nf = grid_size(p);
  const int n = static_cast<int>(tau.size());
  const double f0 = 1.0 / p.max_period_s;
  const double df = (1.0 / p.min_period_s - f0) / (nf - 1);
  Grid g;
  g.f_hz = Eigen::VectorXd::LinSpaced(nf, f0, 1.0 / p.min_period_s);
  g.C.resize(nf, n);
  g.S.resize(nf, n);
  for (int i = 0; i < n; ++i) {
    std::complex<double> z = std::polar(1.0, kTwoPi * f0 * tau(i));
    const std::complex<double> dz = std::polar(1.0, kTwoPi * df * tau(i));
    for (int j = 0; j < nf; ++j, z *= dz) {
      g.C(j, i) = z.real();
      g.S(j, i) = z.imag();
    }
  }
  g.scc = g.C.cwiseAbs2().rowwise().sum();
  g.sss = g.S.cwiseAbs2().rowwise().sum();
  g.scs = g.C.cwiseProduct(g.S).rowwise().sum();
  return g;
}

// The grid frequency whose (cos, sin) pair removes most of r, eq. (3).
struct Pick {
  int j{-1};
  double dss{0.0};  // reduction of the sum of squares
};

Pick best_on_grid(const Grid& g, const Eigen::VectorXd& r) {
  const Eigen::VectorXd cr = g.C * r;
  const Eigen::VectorXd sr = g.S * r;
  Pick best;
  for (int j = 0; j < g.f_hz.size(); ++j) {
    const double det = g.scc(j) * g.sss(j) - g.scs(j) * g.scs(j);
    if (det <= 1e-12 * g.scc(j) * g.sss(j)) continue;  // too few cycles to tell cos from sin
    const double a = (g.sss(j) * cr(j) - g.scs(j) * sr(j)) / det;
    const double b = (g.scc(j) * sr(j) - g.scs(j) * cr(j)) / det;
    const double dss = a * cr(j) + b * sr(j);
    if (dss > best.dss) best = {j, dss};
  }
  return best;
}

// Model (1) with angular frequencies; w_start_radps is where the grid found each one.
// Model (1): `trend` columns before the sinusoids': 1, tau and, with quadratic_trend, tau^2
// (the samples' datum drifting with a velocity and an acceleration: an inertial height's
// accelerometer bias).
struct Model {
  int trend{2};
  double c0{0.0}, c1{0.0}, c2{0.0};
  Eigen::VectorXd w_radps, w_start_radps, a, b;
  int size() const { return static_cast<int>(w_radps.size()); }
};

// Columns 1, tau, tau^2, cos(w_k tau), sin(w_k tau) of the linear part of (1), plus `extra` zero
// columns. (cos and sin of one argument in one loop: the compiler makes one sincos of them.)
Eigen::MatrixXd design(const Eigen::VectorXd& tau, const Eigen::VectorXd& w, int trend, int extra = 0) {
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(tau.size(), trend + 2 * w.size() + extra);
  A.col(0).setOnes();
  A.col(1) = tau;
  if (trend > 2) A.col(2) = tau.array().square().matrix();
  for (int k = 0; k < w.size(); ++k) {
    for (int i = 0; i < tau.size(); ++i) {
      const double ph = w(k) * tau(i);
      A(i, trend + 2 * k) = std::cos(ph);
      A(i, trend + 1 + 2 * k) = std::sin(ph);
    }
  }
  return A;
}

// min |A x - y|: normal equations with the columns scaled to unit norm, solved by LDLT (a few
// times cheaper than a QR of A at N ~ 360 rows). The scaled A has cond < 1e2 for the linear
// columns and < 1e4 with the Jacobian's, even for 15 s and 11.5 s periods plus a trend, so
// cond(A^T A) < 1e8 costs < 1e-8 relative in double. ColPivHouseholderQR when a column is
// zero or the scaled normal matrix is near singular (two frequencies run together).
Eigen::VectorXd least_squares(const Eigen::Ref<const Eigen::MatrixXd>& A,
                              const Eigen::VectorXd& y) {
  const Eigen::VectorXd norms = A.colwise().norm().transpose();
  if (norms.minCoeff() > 0.0) {
    const Eigen::VectorXd d = norms.cwiseInverse();
    const Eigen::MatrixXd AtA = d.asDiagonal() * (A.transpose() * A) * d.asDiagonal();
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(AtA);
    if (ldlt.info() == Eigen::Success && ldlt.vectorD().minCoeff() > kMinNormalPivot) {
      return d.asDiagonal() * ldlt.solve(d.asDiagonal() * (A.transpose() * y));
    }
  }
  return A.colPivHouseholderQr().solve(y);
}

// A model with its design matrix and residual at the samples. A's columns: 1, tau,
// cos(w_k tau), sin(w_k tau) (the linear part of (1)), then d y / d w_k (frequency_step).
struct Solved {
  Model m;
  Eigen::MatrixXd A;
  Eigen::VectorXd r;  // y - model
  double ss{0.0};     // |r|^2
};

// Joint linear least squares of c0, c1, c2, a_k, b_k at the frequencies of `m` (step 4).
Solved solve_linear(const Eigen::VectorXd& tau, const Eigen::VectorXd& y, const Model& m) {
  const int k_n = m.size();
  const int n0 = m.trend;
  Solved s{m, design(tau, m.w_radps, n0, k_n), {}, 0.0};
  const auto A_lin = s.A.leftCols(n0 + 2 * k_n);
  const Eigen::VectorXd x = least_squares(A_lin, y);
  s.m.c0 = x(0);
  s.m.c1 = x(1);
  s.m.c2 = n0 > 2 ? x(2) : 0.0;
  for (int k = 0; k < k_n; ++k) {
    s.m.a(k) = x(n0 + 2 * k);
    s.m.b(k) = x(n0 + 1 + 2 * k);
  }
  s.r = y - A_lin * x;
  s.ss = s.r.squaredNorm();
  return s;
}

// Gauss-Newton step of the frequencies: the least-squares step of all parameters of (1)
// against the residual r, with d y / d w_k = tau (b_k cos(w_k tau) - a_k sin(w_k tau)); only
// its frequency part is kept (the linear part is re-solved at the new frequencies).
Eigen::VectorXd frequency_step(const Eigen::VectorXd& tau, Solved* s) {
  const int k_n = s->m.size();
  Eigen::MatrixXd& J = s->A;
  for (int k = 0; k < k_n; ++k) {
    const int n0 = s->m.trend;
    J.col(n0 + 2 * k_n + k) =
        tau.array() * (s->m.b(k) * J.col(n0 + 2 * k).array() - s->m.a(k) * J.col(n0 + 1 + 2 * k).array());
  }
  const Eigen::VectorXd dx = least_squares(J, s->r);
  return dx.tail(k_n);
}

// Step 4's refinement: Gauss-Newton with variable projection, each w_k kept in the search
// band and within max_shift of w_start_k; a step is halved until it lowers the residual.
void refine_frequencies(const Eigen::VectorXd& tau, const Eigen::VectorXd& y, double w_lo,
                        double w_hi, double max_shift, Solved* s) {
  for (int it = 0; it < kGaussNewtonIterations; ++it) {
    Eigen::VectorXd dw = frequency_step(tau, s);
    if (!dw.allFinite()) return;
    double moved_radps = -1.0;  // largest frequency change of the step taken; < 0: none
    for (int h = 0; h <= kStepHalvings && moved_radps < 0.0; ++h, dw *= 0.5) {
      Model trial = s->m;
      for (int k = 0; k < trial.size(); ++k) {
        const double lo = std::max(w_lo, trial.w_start_radps(k) - max_shift);
        const double hi = std::min(w_hi, trial.w_start_radps(k) + max_shift);
        trial.w_radps(k) = std::clamp(trial.w_radps(k) + dw(k), lo, hi);
      }
      Solved next = solve_linear(tau, y, trial);
      if (next.ss < s->ss) {
        moved_radps = (next.m.w_radps - s->m.w_radps).cwiseAbs().maxCoeff();
        *s = std::move(next);
      }
    }
    if (moved_radps < kTwoPi * kFreqTolerance_hz) return;  // no gain, or converged
  }
}

// Appends the grid frequency w to m with zero coefficients.
void append_component(double w, Model* m) {
  const int k = m->size();
  for (Eigen::VectorXd* v : {&m->w_radps, &m->w_start_radps, &m->a, &m->b}) {
    v->conservativeResize(k + 1);
  }
  m->w_radps(k) = w;
  m->w_start_radps(k) = w;
  m->a(k) = 0.0;
  m->b(k) = 0.0;
}

// Steps 1, 3 and 4 for one channel: trend, then greedy components, each followed by the
// joint refit and the frequency refinement. sigma is eq. (2)'s noise.
Solved fit_model(const Eigen::VectorXd& tau, const Eigen::VectorXd& y, const Grid& g,
                 const DeckMotionParams& p, int max_components, double sigma) {
  Model trend_only;
  trend_only.trend = p.quadratic_trend ? 3 : 2;
  Solved s = solve_linear(tau, y, trend_only);  // step 1: c0 + c1 tau (+ c2 tau^2)
  const double ss_detrended = s.ss;
  const double ss_noise = kNoiseVarianceMargin * sigma * sigma * tau.size();
  const double w_lo = kTwoPi / p.max_period_s;
  const double w_hi = kTwoPi / p.min_period_s;
  const double max_shift = kTwoPi / (2.0 * p.window_s);  // half a Rayleigh cell
  while (s.m.size() < max_components) {
    if (s.ss <= ss_noise) break;  // nothing but noise left
    const Pick pick = best_on_grid(g, s.r);
    if (pick.j < 0 || pick.dss < kMinExplainedShare * ss_detrended) break;
    Model m = s.m;
    append_component(kTwoPi * g.f_hz(pick.j), &m);
    s = solve_linear(tau, y, m);
    refine_frequencies(tau, y, w_lo, w_hi, max_shift, &s);
  }
  return s;
}

// Half the peak-to-peak of the sinusoids' sum over one longest fitted period from t_ref.
double half_peak_to_peak(const DeckChannelFit& f) {
  if (f.components.empty()) return 0.0;
  double f_lo = std::numeric_limits<double>::infinity(), f_hi = 0.0;
  for (const DeckComponent& c : f.components) {
    f_lo = std::min(f_lo, c.freq_hz);
    f_hi = std::max(f_hi, c.freq_hz);
  }
  const double step_s = 1.0 / (f_hi * kAmplitudeSamplesPerPeriod);
  const int n = static_cast<int>(std::ceil(1.0 / (f_lo * step_s))) + 1;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (int i = 0; i < n; ++i) {
    double y = 0.0;
    for (const DeckComponent& c : f.components) {
      const double ph = kTwoPi * c.freq_hz * i * step_s;
      y += c.cos_coef * std::cos(ph) + c.sin_coef * std::sin(ph);
    }
    lo = std::min(lo, y);
    hi = std::max(hi, y);
  }
  return 0.5 * (hi - lo);
}

// The whole fit of one channel (steps 1-4) and its figures of merit.
DeckChannelFit fit_channel(const Series& s, int ch, const Grid& g, const DeckMotionParams& p,
                           int max_components) {
  const Eigen::VectorXd& y = s.y[ch];
  DeckChannelFit f;
  f.t_ref_s = s.t_ref_s;
  f.noise_rms = noise_rms(s.tau_s, y);
  const Solved solved = fit_model(s.tau_s, y, g, p, max_components, f.noise_rms);
  const Model& m = solved.m;
  f.c0 = m.c0;
  f.c1_per_s = m.c1;
  f.c2_per_s2 = m.c2;
  for (int k = 0; k < m.size(); ++k) {
    f.components.push_back({m.w_radps(k) / kTwoPi, m.a(k), m.b(k)});
  }
  const double ss_tot = (y.array() - y.mean()).square().sum();
  f.r2 = ss_tot > 0.0 ? 1.0 - solved.ss / ss_tot : 1.0;
  f.residual_rms = std::sqrt(solved.ss / s.tau_s.size());
  f.amplitude = half_peak_to_peak(f);
  return f;
}

// Angle of the deck normal R e_z from vertical, R = Rz Ry(pitch) Rx(roll):
// R e_z = (sin(pitch) cos(roll), -sin(roll), cos(pitch) cos(roll)).
double tilt_of(double roll_rad, double pitch_rad) {
  const double horizontal =
      std::hypot(std::sin(pitch_rad) * std::cos(roll_rad), std::sin(roll_rad));
  return std::atan2(horizontal, std::cos(pitch_rad) * std::cos(roll_rad));
}
}  // namespace

void DeckMotionParams::validate() const {
  check_fields(*this);  // each field's range (params.h); the rules across fields below
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  require(positive(window_s), "window_s", "must be finite and > 0");
  require(positive(min_history_s), "min_history_s", "must be finite and > 0");
  require(window_s >= min_history_s, "window_s", "must be >= min_history_s");
  require(max_components >= 1 && max_components <= kMaxComponents, "max_components",
          "must be in [1, " + std::to_string(kMaxComponents) + "]");
  require(positive(min_period_s), "min_period_s", "must be finite and > 0");
  require(positive(max_period_s), "max_period_s", "must be finite and > 0");
  require(min_period_s < max_period_s, "min_period_s", "must be < max_period_s");
  require(grid_size(*this) <= kMaxGridFrequencies, "window_s",
          "4 window_s (1/min_period_s - 1/max_period_s) + 1 frequencies exceed " +
              std::to_string(kMaxGridFrequencies) + " (bounded fit cost)");
  require(min_fit_r2 >= 0.0 && min_fit_r2 <= 1.0, "min_fit_r2", "must be in [0, 1]");
  require(positive(moving_heave_m), "moving_heave_m", "must be finite and > 0");
  require(positive(moving_tilt_rad) && moving_tilt_rad < M_PI / 2, "moving_tilt_deg",
          "must be in (0, 90)");
  require(positive(quiescent_step_s), "quiescent_step_s", "must be finite and > 0");
  require(std::isfinite(backtest_s) && backtest_s >= 0.0 && backtest_s <= window_s - min_history_s,
          "backtest_s", "must be in [0, window_s - min_history_s]");
  require(positive(max_backtest_error_m), "max_backtest_error_m", "must be finite and > 0");
  require(positive(max_backtest_error_rad), "max_backtest_error_rad", "must be finite and > 0");
}

double DeckComponent::amplitude() const { return std::hypot(cos_coef, sin_coef); }

double DeckChannelFit::value(double t_s) const {
  const double tau = t_s - t_ref_s;
  double y = c0 + c1_per_s * tau + c2_per_s2 * tau * tau;
  for (const DeckComponent& c : components) {
    const double ph = kTwoPi * c.freq_hz * tau;
    y += c.cos_coef * std::cos(ph) + c.sin_coef * std::sin(ph);
  }
  return y;
}

double DeckChannelFit::rate(double t_s) const {
  const double tau = t_s - t_ref_s;
  double dy = c1_per_s + 2.0 * c2_per_s2 * tau;
  for (const DeckComponent& c : components) {
    const double w = kTwoPi * c.freq_hz;
    dy += w * (c.sin_coef * std::cos(w * tau) - c.cos_coef * std::sin(w * tau));
  }
  return dy;
}

DeckMotionPredictor::DeckMotionPredictor(const DeckMotionParams& p) : p_(p) { p_.validate(); }

void DeckMotionPredictor::add(const DeckSample& s) {
  const bool finite = std::isfinite(s.t_s) && std::isfinite(s.z_m) && std::isfinite(s.roll_rad) &&
                      std::isfinite(s.pitch_rad);
  if (!finite || (!samples_.empty() && s.t_s < samples_.back().t_s)) {
    ++rejected_;
    return;
  }
  samples_.push_back(s);
  while (samples_.front().t_s < s.t_s - p_.window_s) samples_.pop_front();
  dirty_ = true;
  backtest_dirty_ = true;
}

void DeckMotionPredictor::reset() {
  samples_.clear();
  rejected_ = 0;
  dirty_ = false;
  fitted_ = false;
  backtest_dirty_ = false;
  backtested_ = false;
}

double DeckMotionPredictor::history_s() const {
  return samples_.empty() ? 0.0 : samples_.back().t_s - samples_.front().t_s;
}

bool DeckMotionPredictor::fit(const std::deque<DeckSample>& samples, std::size_t count,
                              const DeckMotionParams& p, std::array<DeckChannelFit, 3>* fits) {
  const int n = static_cast<int>(std::min(count, samples.size()));
  if (n < kMinSamples) return false;
  // Each component has three parameters (w, a, b), the trend three.
  const int k_max = std::min(p.max_components, std::max(0, (n / kSamplesPerParameter - 2) / 3));
  const Series s = series_of(samples, n);
  const Grid g = make_grid(s.tau_s, p);
  for (int ch = 0; ch < 3; ++ch) (*fits)[ch] = fit_channel(s, ch, g, p, k_max);
  return true;
}

void DeckMotionPredictor::refit_if_needed() const {
  if (!dirty_) return;
  dirty_ = false;
  fitted_ = history_s() >= p_.min_history_s - kTimeEpsilon_s &&
            fit(samples_, samples_.size(), p_, &fits_);
}

void DeckMotionPredictor::backtest_if_needed() const {
  if (!backtest_dirty_) return;
  backtest_dirty_ = false;
  backtested_ = false;
  if (p_.backtest_s <= 0.0 || !has_fit()) return;
  // The samples up to t_cut are fitted, those after it predicted.
  const double t_cut = samples_.back().t_s - p_.backtest_s;
  const auto after = std::upper_bound(samples_.begin(), samples_.end(), t_cut,
                                      [](double t, const DeckSample& d) { return t < d.t_s; });
  const std::size_t n_fit = after - samples_.begin();
  if (n_fit == 0 || samples_.size() - n_fit < kMinBacktestSamples) return;
  if (samples_[n_fit - 1].t_s - samples_.front().t_s < p_.min_history_s - kTimeEpsilon_s) return;
  std::array<DeckChannelFit, 3> past;
  if (!fit(samples_, n_fit, p_, &past)) return;
  // Eq. (4), sigma from the fit of all samples.
  for (int ch = 0; ch < 3; ++ch) {
    double ss = 0.0;
    for (auto it = after; it != samples_.end(); ++it) {
      const double e = channel_value(*it, ch) - past[ch].value(it->t_s);
      ss += e * e;
    }
    const double mean_sq = ss / static_cast<double>(samples_.end() - after);
    const double sigma = fits_[ch].noise_rms;
    backtest_error_[ch] = std::sqrt(std::max(0.0, mean_sq - sigma * sigma));
  }
  backtested_ = true;
}

double DeckMotionPredictor::backtest_error(DeckChannel c) const {
  backtest_if_needed();
  return backtested_ ? backtest_error_[static_cast<int>(c)]
                     : std::numeric_limits<double>::quiet_NaN();
}

bool DeckMotionPredictor::has_fit() const {
  refit_if_needed();
  return fitted_;
}

bool DeckMotionPredictor::channel_still(DeckChannel c) const {
  const DeckChannelFit& f = fits_[static_cast<int>(c)];
  const double limit = c == DeckChannel::kHeave ? p_.moving_heave_m : p_.moving_tilt_rad;
  return f.amplitude < limit && f.residual_rms < limit;
}

bool DeckMotionPredictor::ready() const {
  if (!has_fit()) return false;
  for (DeckChannel c : {DeckChannel::kHeave, DeckChannel::kRoll, DeckChannel::kPitch}) {
    if (fits_[static_cast<int>(c)].r2 < p_.min_fit_r2 && !channel_still(c)) return false;
  }
  if (p_.backtest_s <= 0.0) return true;
  backtest_if_needed();
  return backtested_ && backtest_error_[0] <= p_.max_backtest_error_m &&
         backtest_error_[1] <= p_.max_backtest_error_rad &&
         backtest_error_[2] <= p_.max_backtest_error_rad;
}

bool DeckMotionPredictor::moving() const {
  if (!has_fit()) return false;
  const DeckChannelFit& z = fits_[0];
  const double tilt_residual_rad = std::hypot(fits_[1].residual_rms, fits_[2].residual_rms);
  return z.amplitude >= p_.moving_heave_m || tilt_amplitude_rad() >= p_.moving_tilt_rad ||
         z.residual_rms >= p_.moving_heave_m || tilt_residual_rad >= p_.moving_tilt_rad;
}

const DeckChannelFit& DeckMotionPredictor::channel_fit(DeckChannel c) const {
  if (!has_fit()) throw std::logic_error("DeckMotionPredictor::channel_fit: no fit yet");
  return fits_[static_cast<int>(c)];
}

DeckState DeckMotionPredictor::predict(double t_s) const {
  if (!has_fit()) throw std::logic_error("DeckMotionPredictor::predict: no fit yet");
  DeckState d;
  d.z_m = fits_[0].value(t_s);
  // A deck has no mean vertical velocity: with heave_trend_is_drift the trend is the datum's
  // (the vehicle's inertial height drifts at its accelerometer bias times its leak time).
  const DeckChannelFit& h = fits_[0];
  d.vz_mps = h.rate(t_s) - (p_.heave_trend_is_drift ? h.c1_per_s + 2.0 * h.c2_per_s2 * (t_s - h.t_ref_s) : 0.0);
  d.roll_rad = fits_[1].value(t_s);
  d.roll_rate_radps = fits_[1].rate(t_s);
  d.pitch_rad = fits_[2].value(t_s);
  d.pitch_rate_radps = fits_[2].rate(t_s);
  d.tilt_rad = tilt_of(d.roll_rad, d.pitch_rad);
  return d;
}

std::optional<QuiescentWindow> DeckMotionPredictor::next_quiescent(double t_now_s, double horizon_s,
                                                                   double max_vz_mps,
                                                                   double max_tilt_rad,
                                                                   double min_duration_s) const {
  auto non_negative = [](double v) { return std::isfinite(v) && v >= 0.0; };
  if (!std::isfinite(t_now_s) || !non_negative(horizon_s) || !non_negative(max_vz_mps) ||
      !non_negative(max_tilt_rad) || !non_negative(min_duration_s)) {
    throw std::invalid_argument(
        "DeckMotionPredictor::next_quiescent: arguments must be finite, all but t_now >= 0");
  }
  if (!ready()) return std::nullopt;
  // Scan the prediction; a run of samples meeting both limits is a window once it is
  // min_duration_s long, and extends until they fail or the horizon ends.
  const int n = static_cast<int>(std::ceil(horizon_s / p_.quiescent_step_s - 1e-9));
  std::optional<QuiescentWindow> run;
  for (int i = 0; i <= n; ++i) {
    const double t = t_now_s + std::min(i * p_.quiescent_step_s, horizon_s);
    const DeckState d = predict(t);
    const bool quiet = std::abs(d.vz_mps) <= max_vz_mps && d.tilt_rad <= max_tilt_rad;
    if (quiet) {
      if (!run) run = QuiescentWindow{t, t};
      run->end_s = t;
    } else if (run) {
      if (run->end_s - run->start_s >= min_duration_s - kTimeEpsilon_s) return run;
      run.reset();
    }
  }
  if (run && run->end_s - run->start_s >= min_duration_s - kTimeEpsilon_s) return run;
  return std::nullopt;
}

double DeckMotionPredictor::heave_amplitude_m() const {
  return has_fit() ? fits_[0].amplitude : 0.0;
}

double DeckMotionPredictor::tilt_amplitude_rad() const {
  return has_fit() ? std::hypot(fits_[1].amplitude, fits_[2].amplitude) : 0.0;
}

double DeckMotionPredictor::fit_r2_heave() const { return has_fit() ? fits_[0].r2 : 0.0; }

}  // namespace lander::ctl
