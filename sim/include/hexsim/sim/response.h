// Loop-response analysis for controller development: step metrics, excitation signals, and
// frequency-response estimation (H1 from Welch-averaged cross/auto spectra) with bandwidth and
// stability margins. Pure numerics on sampled signals: no simulation inside.
#pragma once

#include <complex>
#include <cstdint>
#include <vector>

#include "hexsim/common/status.h"

namespace hexsim::sim {

// --- Step response ------------------------------------------------------------------------------

struct StepOptions {
  double settle_band_fraction = 0.02;  // settling: |y − y_ref| ≤ band·|step| from then on
  double rise_lo_fraction = 0.1;       // rise time from 10 % ...
  double rise_hi_fraction = 0.9;       // ... to 90 % of the step
  // The final value is the mean over this trailing fraction of the record.
  double final_window_fraction = 0.1;
};

struct StepMetrics {
  double step_size = 0.0;            // commanded change (output units)
  double final_value = 0.0;          // measured final value (mean over the trailing window)
  double rise_time_s = -1.0;         // 10–90 % of the commanded step; −1: never reached
  double overshoot_fraction = 0.0;   // (peak − target)/|step| beyond the target, ≥ 0
  double peak_time_s = 0.0;          // time of the peak after the step
  double settling_time_s = -1.0;     // last exit from the ±2 % band of the target; −1: not settled
  double steady_state_error = 0.0;   // target − final value (output units)
};

// t_s and y are samples of the output; the step of size `step_size` from `y_initial` happens at
// t_step_s. Percentages refer to the commanded step (target = y_initial + step_size).
Result<StepMetrics> AnalyzeStep(const std::vector<double>& t_s, const std::vector<double>& y, double t_step_s,
                                double y_initial, double step_size, const StepOptions& options = {});

// --- Excitation ---------------------------------------------------------------------------------

// A periodic multisine: period = n_period samples at fs_hz, lines on the DFT grid k·fs/n_period
// between f_lo_hz and f_hi_hz (every line up to `lines_per_decade` per decade, log-spaced above),
// Schroeder phases (low crest factor), peak amplitude scaled to `amplitude`.
struct Multisine {
  double fs_hz = 100.0;
  int n_period = 1024;
  std::vector<int> lines;            // DFT bin indices excited
  std::vector<double> phases_rad;    // one per line
  double scale = 1.0;                // signal = scale·Σ cos(2π f_k t + φ_k)
  std::vector<double> signal;        // one period, n_period samples
  double period_s() const { return n_period / fs_hz; }
  // The continuous-time signal at any t (periodic).
  double At(double t_s) const;
};
Result<Multisine> MakeMultisine(double fs_hz, int n_period, double f_lo_hz, double f_hi_hz, double amplitude,
                                int lines_per_decade = 40);

// Logarithmic chirp f(t) = f0·(f1/f0)^(t/T), amplitude·sin(phase).
double LogChirp(double t_s, double f0_hz, double f1_hz, double duration_s, double amplitude);

// --- Frequency response -------------------------------------------------------------------------

enum class Window { kRectangular, kHann };

struct WelchOptions {
  int segment = 1024;       // samples per segment (a power of two)
  int overlap = 0;          // samples shared by consecutive segments
  Window window = Window::kRectangular;  // rectangular for a periodic multisine of period `segment`
  bool detrend = true;      // remove each segment's mean
};

struct FrequencyResponse {
  std::vector<double> f_hz;
  std::vector<std::complex<double>> H;  // output/input
  std::vector<double> coherence;        // |S_uy|²/(S_uu·S_yy), 0..1
  int segments = 0;
  double GainDb(size_t i) const;
  double PhaseDeg(size_t i) const;  // unwrapped along the frequency axis
};

// H1 = S_uy/S_uu from Welch-averaged spectra. `bins` (optional) restricts the result to these DFT
// bins (the excited lines); otherwise every bin from 1 to segment/2.
Result<FrequencyResponse> EstimateFrequencyResponse(const std::vector<double>& u, const std::vector<double>& y,
                                                    double fs_hz, const WelchOptions& options,
                                                    const std::vector<int>& bins = {});

struct LoopMetrics {
  // Closed loop T of a tracking loop (DC gain 1): the first frequency where |T| falls below
  // −3 dB (log-interpolated); −1 if it never does within the measured band.
  double bandwidth_hz = -1.0;
  double low_frequency_gain_db = 0.0;  // |T| at the lowest usable line (should be near 0 dB)
  double peak_gain_db = 0.0;  // resonance peak of T
  // Open loop L = T/(1 − T) (unity feedback, no prefilter): gain margin at the −180° crossing of
  // L, phase margin at |L| = 1. −1 / +inf where there is no crossing in the band.
  double gain_crossover_hz = -1.0;
  double phase_margin_deg = -1.0;
  double phase_crossover_hz = -1.0;
  double gain_margin_db = -1.0;
  double min_coherence = 0.0;  // over the points used
};

// From the measured closed-loop response T (setpoint → output); points whose coherence is below
// min_coherence are skipped.
LoopMetrics AnalyzeClosedLoop(const FrequencyResponse& T, double min_coherence = 0.8);

// Radix-2 FFT in place (size a power of two).
void Fft(std::vector<std::complex<double>>* x);

}  // namespace hexsim::sim
