#include "hexsim/sim/hover_tests.h"

#include <cmath>
#include <functional>
#include <utility>

#include <fmt/format.h>

#include "hexsim/common/rotation.h"

namespace hexsim::sim {

namespace {

constexpr double kDegPerRad = 180.0 / kPi;

// Flies hover under the built-in cascade until t_start, then injects r(t) into the chosen loop.
class AxisTestController final : public control::Controller {
 public:
  AxisTestController(const control::ControllerParams& params, const control::VehicleModelForControl& model,
                     ResponseAxis axis, const Eigen::Vector3d& hover_p_N_m, double t_start_s,
                     std::function<double(double)> input)
      : inner_(params, model), axis_(axis), hover_p_N_m_(hover_p_N_m), t_start_s_(t_start_s), input_(std::move(input)) {}

  control::ControlOutput Update(const control::NavState& state, const control::Setpoint&, double dt_s) override {
    const bool active = state.t_s >= t_start_s_;
    const double r = active ? input_(state.t_s - t_start_s_) : 0.0;  // axis units (rad for angles)
    if (active && IsAttitudeAxis(axis_)) {
      if (!holding_) {
        const Eigen::Vector3d e = EulerFromQuat(state.q_NB);
        hold_thrust_N_ = last_thrust_N_ * std::cos(e.x()) * std::cos(e.y());
        holding_ = true;
      }
      Eigen::Vector3d euler = Eigen::Vector3d::Zero();
      euler[axis_ == ResponseAxis::kRoll ? 0 : axis_ == ResponseAxis::kPitch ? 1 : 2] = r;
      const double thrust_N = hold_thrust_N_ / (std::cos(euler.x()) * std::cos(euler.y()));
      return inner_.UpdateAttitude(state, QuatFromEuler(euler.x(), euler.y(), euler.z()), thrust_N, 0.0, dt_s);
    }
    control::Setpoint sp;
    sp.p_N_m = hover_p_N_m_;
    if (axis_ == ResponseAxis::kAlt) sp.p_N_m.z() -= r;  // altitude up = −D
    if (axis_ == ResponseAxis::kVelN && active) {
      sp.position_valid = false;
      sp.v_ff_N_mps = Eigen::Vector3d(r, 0.0, 0.0);
    }
    control::ControlOutput out = inner_.Update(state, sp, dt_s);
    last_thrust_N_ = out.thrust_N;
    return out;
  }
  void Reset() override { inner_.Reset(); }

 private:
  control::CascadedController inner_;
  ResponseAxis axis_;
  Eigen::Vector3d hover_p_N_m_;
  double t_start_s_;
  std::function<double(double)> input_;
  double last_thrust_N_ = 0.0;
  double hold_thrust_N_ = 0.0;
  bool holding_ = false;
};

double AxisOutput(ResponseAxis axis, const BodyState& s) {
  const Eigen::Vector3d e = EulerFromQuat(s.q_NB);
  switch (axis) {
    case ResponseAxis::kRoll: return e.x() * kDegPerRad;
    case ResponseAxis::kPitch: return e.y() * kDegPerRad;
    case ResponseAxis::kYaw: return e.z() * kDegPerRad;
    case ResponseAxis::kAlt: return -s.p_N_m.z();
    case ResponseAxis::kVelN: return s.v_N_mps.x();
  }
  return 0.0;
}

// A hover run of `total_s` flown by `controller`: the setpoint hook keeps the vehicle out of the
// mission (armed, hover).
Result<std::unique_ptr<Simulation>> MakeHoverSim(const RunSetup& base, double total_s, const HoverOptions& hover,
                                                 std::unique_ptr<control::Controller> controller) {
  if (!(hover.hover_alt_m > 1.0 && hover.settle_s > 0 && hover.sample_hz > 0)) {
    return Status::BadInput("hover: need hover_alt_m > 1, settle_s > 0, sample_hz > 0");
  }
  RunSetup setup = base;
  setup.options.duration_s = total_s;
  setup.options.write_log = false;
  const Eigen::Vector3d p(0.0, 0.0, -hover.hover_alt_m);
  Plugins plugins;
  plugins.controller = std::move(controller);
  plugins.setpoint_hook = [p](double, const control::NavState&, control::Setpoint* sp) {
    *sp = control::Setpoint{};
    sp->p_N_m = p;
  };
  return Simulation::Create(setup, std::move(plugins));
}

int SampleEvery(const RunSetup& setup, const HoverOptions& hover) {
  return std::max(1, static_cast<int>(std::lround(1.0 / (hover.sample_hz * setup.options.physics_dt_s))));
}

Status CheckRun(const Simulation& sim, const RunOutput& out) {
  if (!out.status.ok()) return out.status;
  (void)sim;
  return Status::Ok();
}

}  // namespace

Result<ResponseAxis> ParseResponseAxis(const std::string& n) {
  if (n == "roll") return ResponseAxis::kRoll;
  if (n == "pitch") return ResponseAxis::kPitch;
  if (n == "yaw") return ResponseAxis::kYaw;
  if (n == "alt") return ResponseAxis::kAlt;
  if (n == "vel_N") return ResponseAxis::kVelN;
  return Status::BadInput("--axis: must be roll, pitch, yaw, alt or vel_N (got '" + n + "')");
}

std::string AxisName(ResponseAxis a) {
  switch (a) {
    case ResponseAxis::kRoll: return "roll";
    case ResponseAxis::kPitch: return "pitch";
    case ResponseAxis::kYaw: return "yaw";
    case ResponseAxis::kAlt: return "alt";
    case ResponseAxis::kVelN: return "vel_N";
  }
  return "";
}

bool IsAttitudeAxis(ResponseAxis a) {
  return a == ResponseAxis::kRoll || a == ResponseAxis::kPitch || a == ResponseAxis::kYaw;
}

std::string AxisUnit(ResponseAxis a) {
  if (IsAttitudeAxis(a)) return "deg";
  return a == ResponseAxis::kAlt ? "m" : "m/s";
}

Result<StepTestResult> RunStepTest(const RunSetup& setup, ResponseAxis axis, double size, double after_s,
                                   const HoverOptions& hover) {
  if (!(std::isfinite(size) && size != 0.0)) return Status::BadInput("--size: must be non-zero");
  if (IsAttitudeAxis(axis) && std::fabs(size) > 45.0) return Status::BadInput("--size: attitude steps up to 45 deg");
  if (!(after_s > 0)) return Status::BadInput("--duration: must be > 0");
  const double t0 = hover.settle_s;
  const double scale = IsAttitudeAxis(axis) ? 1.0 / kDegPerRad : 1.0;
  auto sim_or = MakeHoverSim(setup, t0 + after_s, hover,
                             std::make_unique<AxisTestController>(setup.control, ControlModelFor(setup.vehicle), axis,
                                                                  Eigen::Vector3d(0, 0, -hover.hover_alt_m), t0,
                                                                  [size, scale](double) { return size * scale; }));
  if (!sim_or.ok()) return sim_or.status();
  Simulation& sim = **sim_or;
  StepTestResult res;
  res.t_step_s = t0;
  const int every = SampleEvery(setup, hover);
  int64_t n = 0;
  bool have_initial = false;
  while (sim.Step()) {
    if (++n % every != 0) continue;
    const double t = sim.time_s();
    const double y = AxisOutput(axis, sim.true_state());
    if (!have_initial && t >= t0 - 1e-9) {
      res.initial = res.series.output.empty() ? y : res.series.output.back();
      have_initial = true;
    }
    res.series.t_s.push_back(t);
    res.series.reference.push_back(t >= t0 ? size : 0.0);
    res.series.output.push_back(y);
  }
  RunOutput out = sim.Finish();
  HEXSIM_RETURN_IF_ERROR(CheckRun(sim, out));
  // The reference for hover altitude/angles is the hover setpoint, not the drifted value: initial
  // is what the loop held just before the step.
  auto m = AnalyzeStep(res.series.t_s, res.series.output, t0, res.initial, size);
  if (!m.ok()) return m.status();
  res.metrics = *m;
  return res;
}

Result<FreqTestResult> RunFrequencyTest(const RunSetup& setup, ResponseAxis axis, const FreqTestOptions& o,
                                        const HoverOptions& hover) {
  if (o.periods < 1) return Status::BadInput("--periods: must be >= 1");
  auto ms_or = MakeMultisine(hover.sample_hz, o.period_samples, o.f_lo_hz, o.f_hi_hz, o.amplitude);
  if (!ms_or.ok()) return ms_or.status();
  const Multisine ms = *ms_or;
  const double t0 = hover.settle_s;
  const double total = t0 + (o.periods + 1) * ms.period_s();
  const double scale = IsAttitudeAxis(axis) ? 1.0 / kDegPerRad : 1.0;
  auto sim_or = MakeHoverSim(setup, total, hover,
                             std::make_unique<AxisTestController>(setup.control, ControlModelFor(setup.vehicle), axis,
                                                                  Eigen::Vector3d(0, 0, -hover.hover_alt_m), t0,
                                                                  [&ms, scale](double t) { return scale * ms.At(t); }));
  if (!sim_or.ok()) return sim_or.status();
  Simulation& sim = **sim_or;
  FreqTestResult res;
  const int every = SampleEvery(setup, hover);
  int64_t n = 0;
  std::vector<double> u, y;
  const double t_analyse = t0 + ms.period_s();
  while (sim.Step()) {
    if (++n % every != 0) continue;
    const double t = sim.time_s();
    const double r = t >= t0 ? ms.At(t - t0) : 0.0;
    const double out = AxisOutput(axis, sim.true_state());
    res.series.t_s.push_back(t);
    res.series.reference.push_back(r);
    res.series.output.push_back(out);
    if (t >= t_analyse - 1e-9 && u.size() < static_cast<size_t>(o.periods) * static_cast<size_t>(o.period_samples)) {
      u.push_back(r);
      y.push_back(out);
    }
  }
  RunOutput out = sim.Finish();
  HEXSIM_RETURN_IF_ERROR(CheckRun(sim, out));
  WelchOptions w;
  w.segment = o.period_samples;
  w.window = Window::kRectangular;  // whole periods of a periodic input: no leakage
  auto fr = EstimateFrequencyResponse(u, y, hover.sample_hz, w, ms.lines);
  if (!fr.ok()) return fr.status();
  res.response = *fr;
  res.metrics = AnalyzeClosedLoop(res.response, o.min_coherence);
  return res;
}

Result<DisturbTestResult> RunDisturbTest(const RunSetup& setup, const DisturbanceSpec& spec, const HoverOptions& hover) {
  if (!spec.gust_N_mps.allFinite() || spec.payload_release_kg < 0 || !(spec.after_s > 0) || spec.gust_duration_s < 0) {
    return Status::BadInput("disturb: need a finite gust, payload >= 0 and a positive duration");
  }
  if (spec.gust_N_mps.isZero() && spec.payload_release_kg == 0) {
    return Status::BadInput("disturb: give --gust N,E,D or --payload-release KG");
  }
  const double t0 = hover.settle_s;
  auto sim_or = MakeHoverSim(setup, t0 + spec.after_s, hover, nullptr);
  if (!sim_or.ok()) return sim_or.status();
  Simulation& sim = **sim_or;
  const Eigen::Vector3d p_hover(0, 0, -hover.hover_alt_m);
  const Eigen::Vector3d wind0 = setup.mission.wind ? setup.mission.wind->mean_N_mps : setup.world.wind.mean_N_mps;
  if (spec.payload_release_kg > 0) sim.ChangePayload(spec.payload_release_kg);
  DisturbTestResult res;
  res.t_onset_s = t0;
  const int every = SampleEvery(setup, hover);
  int64_t n = 0;
  bool applied = false, gust_over = false;
  while (true) {
    const double t_now = sim.time_s();
    if (!applied && t_now >= t0 - 1e-9) {
      if (!spec.gust_N_mps.isZero()) sim.SetWindMean(wind0 + spec.gust_N_mps);
      if (spec.payload_release_kg > 0) sim.ChangePayload(-spec.payload_release_kg);
      applied = true;
    }
    if (applied && !gust_over && spec.gust_duration_s > 0 && t_now >= t0 + spec.gust_duration_s) {
      sim.SetWindMean(wind0);
      gust_over = true;
    }
    if (!sim.Step()) break;
    if (++n % every != 0) continue;
    const double t = sim.time_s();
    const BodyState& s = sim.true_state();
    const Eigen::Vector3d d = s.p_N_m - p_hover;
    res.series.t_s.push_back(t);
    res.series.output.push_back(d.norm());
    res.series.reference.push_back(spec.payload_release_kg > 0 ? sim.payload_kg()
                                                               : (applied && !gust_over ? spec.gust_N_mps.norm() : 0.0));
    res.dev_N_m.push_back(d.x());
    res.dev_E_m.push_back(d.y());
    res.dev_D_m.push_back(d.z());
    if (t >= t0) {
      const Eigen::Vector3d e = EulerFromQuat(s.q_NB);
      const double tilt_deg = std::acos(std::clamp(std::cos(e.x()) * std::cos(e.y()), -1.0, 1.0)) * kDegPerRad;
      res.peak_tilt_deg = std::max(res.peak_tilt_deg, tilt_deg);
      if (d.norm() > res.peak_deviation_m) {
        res.peak_deviation_m = d.norm();
        res.peak_time_s = t - t0;
      }
    }
  }
  RunOutput out = sim.Finish();
  HEXSIM_RETURN_IF_ERROR(CheckRun(sim, out));
  // Recovery: the first time after which the deviation stays within the band.
  const size_t N = res.series.t_s.size();
  size_t last_out = N;
  for (size_t i = N; i-- > 0;) {
    if (res.series.t_s[i] < t0) break;
    if (res.series.output[i] > spec.recovery_band_m) {
      last_out = i;
      break;
    }
  }
  if (last_out == N) {
    res.recovery_time_s = 0.0;
  } else if (last_out + 1 < N) {
    res.recovery_time_s = res.series.t_s[last_out + 1] - t0;
  }
  return res;
}

}  // namespace hexsim::sim
