// The response tools against cases with a known answer.
#include <cmath>
#include <complex>
#include <vector>

#include <gtest/gtest.h>

#include "hexsim/common/rng.h"
#include "hexsim/common/rotation.h"
#include "hexsim/control/controller.h"
#include "hexsim/sim/hover_tests.h"
#include "hexsim/sim/response.h"
#include "hexsim/sim/run_config.h"

namespace hexsim::sim {
namespace {

using Complex = std::complex<double>;

TEST(FrequencyResponse, GivenFirstOrderPlantWithMeasurementNoise_WhenMultisineExcited_ThenBandwidthIsOneOverTau) {
  const double tau_s = 0.2, fs_hz = 200.0, dt = 1.0 / fs_hz;
  const Multisine ms = MakeMultisine(fs_hz, 2048, 0.1, 20.0, 1.0).value();
  RngStream rng(7, "first_order");
  const double a = std::exp(-dt / tau_s);  // exact ZOH discretisation of τ·y' = u − y
  std::vector<double> u, y;
  double x = 0.0;
  const int periods = 5;
  for (int n = 0; n < periods * ms.n_period; ++n) {
    const double un = ms.signal[static_cast<size_t>(n % ms.n_period)];
    if (n >= ms.n_period) {  // first period discarded (transient)
      u.push_back(un);
      y.push_back(x + 0.01 * rng.Normal());
    }
    x = a * x + (1.0 - a) * un;
  }
  WelchOptions w;
  w.segment = ms.n_period;
  const FrequencyResponse fr = EstimateFrequencyResponse(u, y, fs_hz, w, ms.lines).value();
  EXPECT_EQ(fr.segments, periods - 1);
  const LoopMetrics m = AnalyzeClosedLoop(fr, 0.8);
  const double f_b_hz = 1.0 / (2.0 * kPi * tau_s);
  EXPECT_NEAR(m.bandwidth_hz, f_b_hz, 0.02 * f_b_hz);
  const double w_lo = 2 * kPi * fr.f_hz[0];
  EXPECT_NEAR(m.low_frequency_gain_db, -10 * std::log10(1 + w_lo * w_lo * tau_s * tau_s), 0.05);
  // Phase at the corner is −45° (plus the half-sample delay of the ZOH: −180·f·dt degrees).
  size_t i_c = 0;
  for (size_t i = 0; i < fr.f_hz.size(); ++i) {
    if (std::fabs(fr.f_hz[i] - f_b_hz) < std::fabs(fr.f_hz[i_c] - f_b_hz)) i_c = i;
  }
  const double expected_deg = -std::atan(2 * kPi * fr.f_hz[i_c] * tau_s) * 180 / kPi - 180.0 * fr.f_hz[i_c] * dt;
  EXPECT_NEAR(fr.PhaseDeg(i_c), expected_deg, 1.0);
  EXPECT_GT(m.min_coherence, 0.95);
}

TEST(FrequencyResponse, GivenIntegratorWithLag_WhenMarginsComputedFromClosedLoop_ThenTheyMatchTheAnalyticLoop) {
  // L(s) = K/(s(τs + 1)); T = L/(1 + L). Crossover ω_c: K = ω_c·√(1 + τ²ω_c²); PM = 90° − atan(τω_c).
  const double K = 20.0, tau = 0.1;
  FrequencyResponse T;
  for (double f = 0.05; f < 50.0; f *= 1.02) {
    const Complex s(0.0, 2 * kPi * f);
    const Complex L = K / (s * (tau * s + 1.0));
    T.f_hz.push_back(f);
    T.H.push_back(L / (1.0 + L));
    T.coherence.push_back(1.0);
  }
  const LoopMetrics m = AnalyzeClosedLoop(T, 0.5);
  // Solve τ²ω⁴ + ω² − K² = 0.
  const double w_c = std::sqrt((-1.0 + std::sqrt(1.0 + 4.0 * tau * tau * K * K)) / (2.0 * tau * tau));
  EXPECT_NEAR(m.gain_crossover_hz, w_c / (2 * kPi), 0.01 * w_c / (2 * kPi));
  EXPECT_NEAR(m.phase_margin_deg, 90.0 - std::atan(tau * w_c) * 180 / kPi, 0.5);
  EXPECT_TRUE(std::isinf(m.gain_margin_db));  // second order: phase never reaches −180°
}

TEST(StepResponse, GivenFirstOrderPlant_WhenStepped_ThenRiseIsTauLn9AndSettlingTauLn50) {
  const double tau = 0.5, dt = 1e-3, t_step = 1.0, size = 2.0;
  std::vector<double> t, y;
  for (int n = 0; n <= 6000; ++n) {
    const double tn = n * dt;
    t.push_back(tn);
    y.push_back(3.0 + (tn < t_step ? 0.0 : size * (1.0 - std::exp(-(tn - t_step) / tau))));
  }
  const StepMetrics m = AnalyzeStep(t, y, t_step, 3.0, size).value();
  EXPECT_NEAR(m.rise_time_s, tau * std::log(9.0), 2 * dt);
  EXPECT_NEAR(m.settling_time_s, tau * std::log(50.0), 2 * dt);
  EXPECT_NEAR(m.overshoot_fraction, 0.0, 1e-12);
  EXPECT_NEAR(m.steady_state_error, 0.0, size * std::exp(-4.0 / tau) + 1e-9);
}

TEST(StepResponse, GivenSecondOrderPlantWithKnownDamping_WhenStepped_ThenOvershootIsAnalytic) {
  for (double zeta : {0.2, 0.5, 0.7}) {
    const double wn = 6.0, dt = 1e-3;
    std::vector<double> t, y;
    double x = 0.0, v = 0.0;  // x'' = wn²(1 − x) − 2ζ wn x'  (RK4)
    auto f = [&](double xx, double vv) { return wn * wn * (1.0 - xx) - 2.0 * zeta * wn * vv; };
    for (int n = 0; n <= 8000; ++n) {
      t.push_back(n * dt);
      y.push_back(x);
      const double k1x = v, k1v = f(x, v);
      const double k2x = v + 0.5 * dt * k1v, k2v = f(x + 0.5 * dt * k1x, v + 0.5 * dt * k1v);
      const double k3x = v + 0.5 * dt * k2v, k3v = f(x + 0.5 * dt * k2x, v + 0.5 * dt * k2v);
      const double k4x = v + dt * k3v, k4v = f(x + dt * k3x, v + dt * k3v);
      x += dt / 6 * (k1x + 2 * k2x + 2 * k3x + k4x);
      v += dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
    }
    const StepMetrics m = AnalyzeStep(t, y, 0.0, 0.0, 1.0).value();
    const double wd = wn * std::sqrt(1 - zeta * zeta);
    EXPECT_NEAR(m.overshoot_fraction, std::exp(-kPi * zeta / std::sqrt(1 - zeta * zeta)), 1e-3) << zeta;
    EXPECT_NEAR(m.peak_time_s, kPi / wd, 2 * dt) << zeta;
    // The 2 % settling time is bounded by the envelope e^{−ζωn t}/√(1−ζ²) reaching 0.02.
    EXPECT_LE(m.settling_time_s, -std::log(0.02 * std::sqrt(1 - zeta * zeta)) / (zeta * wn) + dt) << zeta;
  }
}

TEST(StepResponse, GivenTooFewSamples_WhenAnalysed_ThenBadInput) {
  EXPECT_EQ(AnalyzeStep({0, 1}, {0, 1}, 0.5, 0, 1).status().code(), StatusCode::kBadInput);
}

// The roll loop's closed-loop bandwidth predicted from the gains: the rate loop commands angular
// acceleration (τ = J·α), so with a perfect actuator the inner loop is
// ω/ω_sp = (kp + ki/s)/((1 + kd)s + kp + ki/s) (D on the measurement) whatever the inertia, and the
// attitude P closes φ = ω/s with ω_sp = k_att(φ_sp − φ). The rotors add a first-order lag: the motor
// linearised at hover, J_r·dω/dt = K_t(V − ω/K_v)/R − k_Q·ω², has τ_m = J_r/(K_t²/R + 2·k_Q·ω_h),
// ω_h² = m·g/(N·k_T), and α_actual = α_cmd/(τ_m·s + 1).
double MotorLagS(const vehicle::VehicleParams& v) {
  const auto& r = v.rotors.front();
  const double J_r = r.inertia_kgm2 > 0 ? r.inertia_kgm2 : v.motor.inertia_kgm2;
  const double Kt = v.motor.Kt_Nm_per_A();
  const double w_h = std::sqrt(v.mass_kg * kGravity_mps2 / (static_cast<double>(v.rotors.size()) * r.k_T_Nprps2));
  return J_r / (Kt * Kt / v.motor.winding_resistance_ohm + 2.0 * r.k_Q_Nmprps2 * w_h);
}

double PredictedRollBandwidthHz(const control::ControllerParams& p, double motor_lag_s) {
  auto T = [&](double f) {
    const Complex s(0.0, 2 * kPi * f);
    const Complex c = p.rate_roll.kp + p.rate_roll.ki / s;
    const Complex lag = 1.0 / (motor_lag_s * s + 1.0);
    const Complex inner = lag * c / (s + lag * c + lag * p.rate_roll.kd * s);
    const Complex L = p.att_roll_kp * inner / s;
    return std::abs(L / (1.0 + L));
  };
  for (double f = 0.01; f < 100.0; f *= 1.001) {
    if (20 * std::log10(T(f)) < -3.0) return f;
  }
  return -1.0;
}

RunSetup HoverSetup() {
  RunRequest req;
  req.mission = "square";
  req.vehicle = "default_hex";
  req.estimator = "truth";
  req.seed = 3;
  return LoadRunSetup(req).value();
}

TEST(HoverTests, GivenDefaultGains_WhenRollLoopMeasuredByMultisine_ThenBandwidthIsWhereTheGainsPutIt) {
  const RunSetup setup = HoverSetup();
  FreqTestOptions o;
  o.amplitude = 4.0;  // deg peak: linear range
  const FreqTestResult r = RunFrequencyTest(setup, ResponseAxis::kRoll, o).value();
  const double tau_m = MotorLagS(setup.vehicle);
  const double predicted_hz = PredictedRollBandwidthHz(setup.control, tau_m);
  const double ideal_hz = PredictedRollBandwidthHz(setup.control, 0.0);
  ASSERT_GT(predicted_hz, 0);
  // Unmodelled: the IMU sample and controller tick (1 ms each), the derivative filter, battery sag,
  // the motor's nonlinearity over the multisine's ±4°: 10 %.
  EXPECT_NEAR(r.metrics.bandwidth_hz, predicted_hz, 0.1 * predicted_hz)
      << "predicted " << predicted_hz << " Hz, measured " << r.metrics.bandwidth_hz;
  EXPECT_NEAR(r.metrics.low_frequency_gain_db, 0.0, 0.5);
  EXPECT_GT(r.metrics.phase_margin_deg, 30.0);
  RecordProperty("roll_bandwidth_hz", std::to_string(r.metrics.bandwidth_hz));
  std::printf("roll bandwidth: measured %.3f Hz, predicted %.3f Hz (tau_m %.4f s; ideal actuator %.3f Hz), PM %.1f deg at %.2f Hz, GM %.1f dB\n",
              r.metrics.bandwidth_hz, predicted_hz, tau_m, ideal_hz, r.metrics.phase_margin_deg, r.metrics.gain_crossover_hz,
              r.metrics.gain_margin_db);
}

TEST(HoverTests, GivenRollStep_WhenFlown_ThenItSettlesOnTheSetpoint) {
  const RunSetup setup = HoverSetup();
  const StepTestResult r = RunStepTest(setup, ResponseAxis::kRoll, 10.0, 4.0).value();
  EXPECT_GT(r.metrics.rise_time_s, 0.0);
  EXPECT_LT(r.metrics.rise_time_s, 1.0);
  EXPECT_GE(r.metrics.settling_time_s, 0.0);
  EXPECT_NEAR(r.metrics.steady_state_error, 0.0, 0.3);  // deg: the rate integrator removes offsets
  std::printf("roll step 10 deg: rise %.3f s, overshoot %.1f %%, settling %.3f s, sse %.3f deg\n",
              r.metrics.rise_time_s, 100 * r.metrics.overshoot_fraction, r.metrics.settling_time_s,
              r.metrics.steady_state_error);
}

TEST(HoverTests, GivenWindGust_WhenHovering_ThenDeviationPeaksAndRecovers) {
  const RunSetup setup = HoverSetup();
  DisturbanceSpec d;
  d.gust_N_mps = Eigen::Vector3d(5.0, 0.0, 0.0);
  d.after_s = 20.0;
  const DisturbTestResult r = RunDisturbTest(setup, d).value();
  EXPECT_GT(r.peak_deviation_m, 0.1);   // a 5 m/s gust must push the vehicle
  EXPECT_LT(r.peak_deviation_m, 5.0);
  EXPECT_GT(r.recovery_time_s, 0.0);     // the velocity integrator brings it back
  EXPECT_LT(r.recovery_time_s, 20.0);
  std::printf("gust 5 m/s N: peak %.2f m at %.2f s, recovered in %.2f s, tilt %.1f deg\n", r.peak_deviation_m,
              r.peak_time_s, r.recovery_time_s, r.peak_tilt_deg);
}

}  // namespace
}  // namespace hexsim::sim
