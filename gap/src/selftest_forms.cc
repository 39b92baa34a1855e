// The selftest's forms beyond the library's names (class beyond_library): each is a form of one
// library effect, or of none, and is judged by the verdicts that name it right (LogForm).
// Sizes: a few µT at the flight's typical drive, far above the 0.3 µT compass noise and inside what
// real internal compasses show (3–7 mG/A at 10–20 A: 3–14 µT).
#include <algorithm>
#include <cmath>

#include "selftest_real.h"

namespace hexsim::gap::internal {
namespace {

// The value below which a share q of the finite entries of v lie (0 when none is finite).
double Quantile(const std::vector<double>& v, double q) {
  std::vector<double> s;
  for (double x : v) {
    if (std::isfinite(x)) s.push_back(x);
  }
  if (s.empty()) return 0.0;
  std::sort(s.begin(), s.end());
  return s[static_cast<size_t>(q * static_cast<double>(s.size() - 1))];
}

double Finite(double x) { return std::isfinite(x) ? x : 0.0; }

// x through a first-order lag of time constant tau_s (x finite or held).
std::vector<double> Lagged(const std::vector<double>& t, const std::vector<double>& x, double tau_s) {
  std::vector<double> y(x.size(), 0.0);
  double s = Finite(x.empty() ? 0.0 : x.front());
  for (size_t i = 0; i < x.size(); ++i) {
    const double dt = i > 0 ? t[i] - t[i - 1] : 0.0;
    s += (Finite(x[i]) - s) * std::min(1.0, dt / tau_s);
    y[i] = s;
  }
  return y;
}

// Current-driven names: a field in proportion to the battery current, per motor or lagged.
const std::vector<Effect> kCurrentDriven = {Effect::kCurrentHardIron, Effect::kPerMotorCurrentHardIron, Effect::kCurrentLag};
const std::vector<Effect> kCurrentOrThrottle = {Effect::kCurrentHardIron, Effect::kPerMotorCurrentHardIron, Effect::kCurrentLag,
                                                Effect::kThrottleHardIron};

// The current sensor reads 0 over spans of 1–3 s that cover 15 % of the flight (a loose connector).
void DropOut(const std::vector<double>& t, std::vector<double>* I, RngStream* rng) {
  const double t0 = t.front(), span = t.back() - t.front();
  double covered = 0;
  while (covered < 0.15 * span) {
    const double start = t0 + span * rng->Uniform();
    const double len = 1.0 + 2.0 * rng->Uniform();
    for (size_t i = 0; i < t.size(); ++i) {
      if (t[i] >= start && t[i] < start + len) (*I)[i] = 0.0;
    }
    covered += len;
  }
}

}  // namespace

const std::vector<LogForm>& BeyondLibraryForms() {
  // named_right: the library effect each is a form of (CONTRACTS.md: the verdict names the effect).
  //   current_power_lag: B = a·(I_τ/Ī)^p, I_τ the current through a lag τ (eddy currents in a frame
  //     plate, a slow sensor): current-driven, its lag under the lag candidate;
  //   battery_sag_field: B ∝ V_full − V; the sag is R·I plus the slow discharge, so current-driven;
  //   throttle_power_field: B ∝ (u/ū)^r, r in 1.2..2.6: the throttle, not the current (a signal lead
  //     beside the compass); the throttle form is the only right name;
  //   current_dropout / current_clipped: a current field k·I read through a current sensor that drops
  //     to 0 / clips at its 60th percentile: current-driven, or the throttle form, which is what
  //     compensates a current field whose sensor misreads it (ArduPilot's COMPASS_MOTCT 1);
  //   lagged_temperature: an offset d·(T_c − T₀), the compass warming through a 30–60 s lag behind
  //     the logged IMU temperature: temperature_drift;
  //   vertical_axis_scale: the sensor's z axis reads 5–15 % large (scripts/withheld_sim: "one axis
  //     a few per cent large" on z). A static gain, never current-driven; in near-level flight a z
  //     gain is mostly the down field times the gain, a calibration offset, and the per-axis family's
  //     vertical member reads it only through the tilt (verdict.cc AxisScale). Right: scale_error,
  //     or hard_iron_offset (the same remedy, recalibration); a current name is wrong.
  static const std::vector<LogForm> kForms = {
      {"current_power_lag", kCurrentDriven},    {"battery_sag_field", kCurrentDriven},
      {"throttle_power_field", {Effect::kThrottleHardIron}}, {"current_dropout", kCurrentOrThrottle},
      {"current_clipped", kCurrentOrThrottle},  {"lagged_temperature", {Effect::kTemperatureDrift}},
      {"vertical_axis_scale", {Effect::kScaleError, Effect::kHardIronOffset}},
  };
  return kForms;
}

const LogForm* FindForm(const std::string& name) {
  for (const auto* list : {&OutOfLibraryFamilies(), &BeyondLibraryForms()}) {
    for (const LogForm& f : *list) {
      if (name == f.name) return &f;
    }
  }
  return nullptr;
}

Result<FormTruth> InjectBeyondLibrary(logs::FlightLog* log, size_t compass, const std::string& form, RngStream* rng) {
  const std::string pre = compass == 0 ? "mag" : "mag" + std::to_string(compass + 1);
  if (!log->Has(pre + "_x_uT") || !log->Has("current_A") || !log->Has("control_u") || !log->Has("voltage_V")) {
    return Status::BadInput("selftest: the trial log lacks " + pre + ", current_A, voltage_V or control_u");
  }
  const size_t cx = static_cast<size_t>(log->ColumnIndex(pre + "_x_uT"));
  const std::vector<double> t = log->Column("t_s");
  const std::vector<double> I = log->Column("current_A");
  const std::vector<double> V = log->Column("voltage_V");
  const std::vector<double> u = log->Column("control_u");
  const size_t n = log->rows();
  if (form == "vertical_axis_scale") {
    // The chip's z gain scales all it reads on that axis (the Earth field and nearby parts' fields).
    const double s = 0.05 + 0.10 * rng->Uniform();  // a few per cent to an uncalibrated axis' 15 %
    for (double& m : log->MutableColumn(cx + 2)) m = std::isfinite(m) ? (1.0 + s) * m : m;
    return FormTruth{};
  }
  const Vec3 d = RandomUnit(rng);
  const double a = 3.0 + 3.0 * rng->Uniform();  // µT at the typical drive
  const double I_med = std::max(1.0, Quantile(I, 0.5));
  FormTruth truth;
  std::vector<double> drive(n, 0.0);  // the field along d per row, in units of a
  if (form == "current_power_lag") {
    truth.lag_s = 0.2 + 0.6 * rng->Uniform();
    const double p = 1.3 + 0.5 * rng->Uniform();
    const std::vector<double> Il = Lagged(t, I, truth.lag_s);
    for (size_t i = 0; i < n; ++i) drive[i] = std::pow(std::max(0.0, Il[i]) / I_med, p);
  } else if (form == "battery_sag_field") {
    double v_full = 0;
    for (double v : V) v_full = std::isfinite(v) ? std::max(v_full, v) : v_full;
    std::vector<double> sag(n);
    for (size_t i = 0; i < n; ++i) sag[i] = v_full - Finite(V[i]);
    const double sag_med = std::max(0.05, Quantile(sag, 0.5));
    for (size_t i = 0; i < n; ++i) drive[i] = sag[i] / sag_med;
  } else if (form == "throttle_power_field") {
    const double r = 1.2 + 1.4 * rng->Uniform();  // between the throttle family's grid exponents
    const double u_med = std::max(1e-6, Quantile(u, 0.5));
    for (size_t i = 0; i < n; ++i) drive[i] = std::pow(std::max(0.0, Finite(u[i])) / u_med, r);
  } else if (form == "current_dropout" || form == "current_clipped") {
    for (size_t i = 0; i < n; ++i) drive[i] = Finite(I[i]) / I_med;
    auto& logged = log->MutableColumn(static_cast<size_t>(log->ColumnIndex("current_A")));
    if (form == "current_dropout") {
      DropOut(t, &logged, rng);
    } else {
      const double clip = Quantile(I, 0.6);
      for (double& v : logged) v = std::isfinite(v) ? std::min(v, clip) : v;
    }
  } else if (form == "lagged_temperature") {
    // The logged IMU temperature warms from 25 °C towards 45 °C (40 s); the compass follows it late.
    truth.lag_s = 30.0 + 30.0 * rng->Uniform();
    const size_t ct = log->AddColumn("imu_temp_C");
    std::vector<double> temp(n);
    for (size_t i = 0; i < n; ++i) {
      temp[i] = 25.0 + 20.0 * (1 - std::exp(-(t[i] - t.front()) / 40.0));
      log->MutableColumn(ct)[i] = temp[i] + rng->Normal(0, 0.05);
    }
    const std::vector<double> tc = Lagged(t, temp, truth.lag_s);
    for (size_t i = 0; i < n; ++i) drive[i] = (tc[i] - 25.0) / 10.0;
  } else {
    return Status::BadInput("selftest: unknown form '" + form + "'");
  }
  for (size_t i = 0; i < n; ++i) {
    for (size_t k = 0; k < 3; ++k) {
      double& m = log->MutableColumn(cx + k)[i];
      if (std::isfinite(m)) m += d[static_cast<Eigen::Index>(k)] * a * drive[i];
    }
  }
  return truth;
}

}  // namespace hexsim::gap::internal
