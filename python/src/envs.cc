// _hexsim.VectorCore: n envs::Env stepped by envs::VectorEnv (C++ episode logic, a thread pool,
// the GIL released), with numpy arrays in and out; and render_tracks, the off-screen track figure
// the environments' render() returns. hexsim/env.py builds the Gymnasium classes on it.
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "bindings.h"
#include "hexsim/envs/vector_env.h"
#include "hexsim/experiments/ground_calibration.h"
#include "hexsim/render/figures.h"
#include "hexsim/sim/run_config.h"

namespace hexsim::python {

namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

Eigen::Vector3d Point(const py::handle& value, const std::string& what) {
  const std::vector<Eigen::Vector3d> rows = Rows3(Array::ensure(value).reshape({-1, 3}), what);
  if (rows.size() != 1) RaiseBadInput(what + ": expected [N, E, D] in m");
  return rows[0];
}

envs::EnvOptions ParseOptions(const py::dict& kw) {
  envs::EnvOptions o;
  for (const auto& [key_handle, value] : kw) {
    const std::string key = py::str(key_handle).cast<std::string>();
    const py::handle item = value;
    auto number = [item] { return item.cast<double>(); };
    if (key == "task") {
      const std::string t = value.cast<std::string>();
      if (t == "hover") o.task = envs::Task::kHover;
      else if (t == "waypoint") o.task = envs::Task::kWaypoint;
      else if (t == "compass_waypoint") o.task = envs::Task::kCompassWaypoint;
      else RaiseBadInput("task: '" + t + "': expected hover, waypoint or compass_waypoint");
    } else if (key == "act") {
      const std::string a = value.cast<std::string>();
      if (a == "motors") o.act = envs::ActMode::kMotors;
      else if (a == "rates") o.act = envs::ActMode::kRates;
      else if (a == "attitude") o.act = envs::ActMode::kAttitude;
      else RaiseBadInput("act: '" + a + "': expected motors, rates or attitude");
    } else if (key == "observe") {
      const std::string s = value.cast<std::string>();
      if (s == "truth") o.observe = envs::ObsSource::kTruth;
      else if (s == "estimator") o.observe = envs::ObsSource::kEstimator;
      else if (s == "sensors") o.observe = envs::ObsSource::kSensors;
      else RaiseBadInput("observe: '" + s + "': expected truth, estimator or sensors");
    } else if (key == "target_N_m") {
      o.target_N_m = Point(value, "target_N_m");
    } else if (key == "waypoints_N_m") {
      o.waypoints_N_m = Rows3(Array::ensure(value).reshape({-1, 3}), "waypoints_N_m");
    } else if (key == "acceptance_m") { o.acceptance_m = number();
    } else if (key == "time_limit_s") { o.time_limit_s = number();
    } else if (key == "control_period_s") { o.control_period_s = number();
    } else if (key == "settle_s") { o.settle_s = number();
    } else if (key == "start_offset_m") { o.start_offset_m = number();
    } else if (key == "max_rate_radps") { o.max_rate_radps = number();
    } else if (key == "max_tilt_rad") { o.max_tilt_rad = number();
    } else if (key == "ground_margin_m") { o.ground_margin_m = number();
    } else if (key == "terminate_tilt_deg") { o.terminate_tilt_deg = number();
    } else if (key == "rate_weight") { o.rate_weight = number();
    } else if (key == "cross_track_weight") { o.cross_track_weight = number();
    } else if (key == "effort_weight") { o.effort_weight = number();
    } else if (key == "progress_weight") { o.progress_weight = number();
    } else {
      RaiseBadInput(key + ": not an environment option");
    }
  }
  return o;
}

py::array_t<double> Matrix(const double* data, size_t rows, size_t cols) {
  py::array_t<double> a({rows, cols});
  std::copy(data, data + rows * cols, a.mutable_data());
  return a;
}

py::array_t<bool> Flags(const std::vector<uint8_t>& v) {
  py::array_t<bool> a(static_cast<py::ssize_t>(v.size()));
  for (size_t i = 0; i < v.size(); ++i) a.mutable_data()[i] = v[i] != 0;
  return a;
}

class VectorCore {
 public:
  VectorCore(size_t n, int threads, bool autoreset, const std::string& vehicle, const std::string& world,
             const std::string& mission, const std::string& estimator, const py::object& sets,
             const std::string& calibration, uint64_t calibration_seed, const py::dict& options) {
    if (n < 1) RaiseBadInput("n: must be >= 1");
    if (threads < 1) RaiseBadInput("threads: must be >= 1");
    sim::RunRequest rq;
    rq.mission = mission;
    rq.vehicle = vehicle;
    rq.world = world;
    rq.estimator = estimator;
    rq.seed = calibration_seed;  // the ground calibration session's seed (calibrations that need one)
    rq.sets = SetStrings(sets);
    sim::RunSetup setup = ValueOrRaise(sim::LoadRunSetup(rq));
    ThrowIfError(experiments::AttachCalibration(calibration, &setup));
    const envs::EnvOptions o = ParseOptions(options);
    std::vector<std::unique_ptr<envs::Env>> list;
    for (size_t i = 0; i < n; ++i) list.push_back(ValueOrRaise(envs::Env::Create(setup, o)));
    vec_ = std::make_unique<envs::VectorEnv>(std::move(list), threads, autoreset);
    obs_.resize(n * vec_->observation_size());
    info_.resize(n * envs::kInfoSize);
    rewards_.resize(n);
    terminated_.resize(n);
    truncated_.resize(n);
  }

  // seeds: None (each env's next episode) or n integers.
  py::tuple Reset(const py::object& seeds) {
    std::vector<uint64_t> s;
    if (!seeds.is_none()) {
      for (const auto& v : seeds.cast<py::sequence>()) s.push_back(v.cast<uint64_t>());
      if (s.size() != vec_->size()) RaiseBadInput("reset: seeds: expected one per env (" + std::to_string(vec_->size()) + ")");
    }
    Status status;
    {
      py::gil_scoped_release unlocked;
      status = vec_->Reset(s.empty() ? nullptr : s.data(), obs_.data(), info_.data());
    }
    ThrowIfError(status);
    return py::make_tuple(Obs(), Info());
  }

  py::tuple Step(const py::object& actions) {
    const Array a = Array::ensure(actions);
    const size_t n = vec_->size(), na = vec_->action_size();
    if (!a || static_cast<size_t>(a.size()) != n * na || (a.ndim() != 2 && !(a.ndim() == 1 && n == 1))) {
      RaiseBadInput("step: actions: expected shape (" + std::to_string(n) + ", " + std::to_string(na) + ")");
    }
    const double* data = a.data();
    for (size_t i = 0; i < n * na; ++i) {
      if (!std::isfinite(data[i])) {
        RaiseBadInput("step: actions: env " + std::to_string(i / na) + ", value " + std::to_string(i % na) +
                      ": not a finite number");
      }
    }
    Status status;
    {
      py::gil_scoped_release unlocked;
      status = vec_->Step(a.data(), obs_.data(), rewards_.data(), terminated_.data(), truncated_.data(), info_.data());
    }
    ThrowIfError(status);
    return py::make_tuple(Obs(), ToArray(rewards_), Flags(terminated_), Flags(truncated_), Info());
  }

  void BenchPhysics(int agent_steps) {
    py::gil_scoped_release unlocked;
    vec_->StepPhysicsOnly(agent_steps);
  }

  py::dict Layout() const {
    const envs::VehicleLayout& l = vec_->env(0).layout();
    py::array_t<double> p({l.rotors, size_t{3}});
    for (size_t i = 0; i < l.rotors; ++i) {
      for (size_t k = 0; k < 3; ++k) p.mutable_at(i, k) = l.rotor_p_B_m[i][static_cast<Eigen::Index>(k)];
    }
    py::array_t<double> mixer({size_t{4}, l.rotors});
    for (size_t r = 0; r < 4; ++r) {
      for (size_t c = 0; c < l.rotors; ++c) {
        mixer.mutable_at(r, c) = l.mixer(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c));
      }
    }
    py::dict d;
    d["rotors"] = l.rotors;
    d["rotor_p_B_m"] = p;
    d["spin"] = py::array_t<int>(static_cast<py::ssize_t>(l.spin.size()), l.spin.data());
    d["mixer"] = mixer;
    d["mass_kg"] = l.mass_kg;
    d["inertia_kgm2"] = ToArray(l.inertia_kgm2);
    d["hover_thrust_N"] = l.hover_thrust_N;
    d["max_thrust_N"] = l.max_thrust_N;
    d["hover_command"] = l.hover_command;
    return d;
  }

  size_t size() const { return vec_->size(); }
  size_t observation_size() const { return vec_->observation_size(); }
  size_t action_size() const { return vec_->action_size(); }
  int threads() const { return vec_->threads(); }
  py::array_t<double> action_low() const { return ToArray(vec_->env(0).action_low()); }
  py::array_t<double> action_high() const { return ToArray(vec_->env(0).action_high()); }
  double agent_dt_s() const { return vec_->env(0).agent_dt_s(); }
  py::list episode_sim_seeds() const {
    py::list s;
    for (size_t i = 0; i < vec_->size(); ++i) s.append(py::int_(vec_->env(i).episode_sim_seed()));
    return s;
  }

 private:
  py::array_t<double> Obs() const { return Matrix(obs_.data(), vec_->size(), vec_->observation_size()); }
  py::array_t<double> Info() const { return Matrix(info_.data(), vec_->size(), envs::kInfoSize); }

  std::unique_ptr<envs::VectorEnv> vec_;
  std::vector<double> obs_, info_, rewards_;
  std::vector<uint8_t> terminated_, truncated_;
};

// The planned path (k, 3) and the flown track (m, 3), NED m, as an (H, W, 3) uint8 image.
py::array_t<uint8_t> RenderTracks(const py::object& planned, const py::object& flown, int width, int height) {
  auto track = [](const py::object& points, const std::string& name) {
    render::Track t;
    t.name = name;
    for (const auto& p : Rows3(Array::ensure(points).reshape({-1, 3}), name)) {
      t.north_m.push_back(p.x());
      t.east_m.push_back(p.y());
      t.down_m.push_back(p.z());
    }
    return t;
  };
  const render::Image image = ValueOrRaise(render::RenderTracks(track(planned, "planned"), {track(flown, "flown")}, width, height));
  py::array_t<uint8_t> out({static_cast<size_t>(image.height), static_cast<size_t>(image.width), size_t{3}});
  uint8_t* o = out.mutable_data();
  for (size_t i = 0; i < static_cast<size_t>(image.width) * static_cast<size_t>(image.height); ++i) {
    o[3 * i] = image.rgba[4 * i];
    o[3 * i + 1] = image.rgba[4 * i + 1];
    o[3 * i + 2] = image.rgba[4 * i + 2];
  }
  return out;
}

}  // namespace

void BindEnvs(py::module_& m) {
  py::class_<VectorCore>(m, "VectorCore", R"doc(
n environments (hexsim's C++ episode logic) stepped in one call on `threads` threads with the GIL
released. The Gymnasium classes in hexsim.env are built on it; use those.)doc")
      .def(py::init<size_t, int, bool, const std::string&, const std::string&, const std::string&,
                    const std::string&, const py::object&, const std::string&, uint64_t, const py::dict&>(),
           py::arg("n"), py::arg("threads"), py::arg("autoreset"), py::arg("vehicle"), py::arg("world"),
           py::arg("mission"), py::arg("estimator"), py::arg("set"), py::arg("calibration"),
           py::arg("calibration_seed"), py::arg("options"))
      .def("reset", &VectorCore::Reset, py::arg("seeds") = py::none(), "-> (obs (n, obs), info (n, info))")
      .def("step", &VectorCore::Step, py::arg("actions"),
           "-> (obs (n, obs), rewards (n), terminated (n), truncated (n), info (n, info))")
      .def("bench_physics", &VectorCore::BenchPhysics, py::arg("agent_steps"),
           "Benchmark reference: the same simulations stepped in a plain C++ loop on this thread.")
      .def_property_readonly("layout", &VectorCore::Layout)
      .def_property_readonly("n", &VectorCore::size)
      .def_property_readonly("observation_size", &VectorCore::observation_size)
      .def_property_readonly("action_size", &VectorCore::action_size)
      .def_property_readonly("threads", &VectorCore::threads)
      .def_property_readonly("action_low", &VectorCore::action_low)
      .def_property_readonly("action_high", &VectorCore::action_high)
      .def_property_readonly("agent_dt_s", &VectorCore::agent_dt_s)
      .def_property_readonly("episode_sim_seeds", &VectorCore::episode_sim_seeds);
  py::tuple names(static_cast<size_t>(envs::kInfoSize));
  for (size_t i = 0; i < names.size(); ++i) names[i] = py::str(envs::kInfoNames[i]);
  m.attr("ENV_INFO_NAMES") = names;
  m.def("render_tracks", &RenderTracks, py::arg("planned_N_m"), py::arg("flown_N_m"), py::arg("width") = 640,
        py::arg("height") = 320, "Off-screen top and 3-D track figure as an (H, W, 3) uint8 array.");
}

}  // namespace hexsim::python
