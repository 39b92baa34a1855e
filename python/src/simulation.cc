// hexsim.Simulation: sim::Simulation as `hexsim run` sets it up (LoadRunSetup, AttachCalibration),
// with the choice of where Python acts (envs/act.h: builtin, position [N, E, D(, yaw_rad)],
// attitude [q_w, q_x, q_y, q_z, thrust_N], rates [p, q, r (rad/s, body), thrust_N], motors [0..1 each]);
// builtin flies the mission as `hexsim run` does, byte for byte. The action is held until changed.
#include <cmath>
#include <cstdint>
#include <optional>
#include <memory>
#include <string>
#include <vector>

#include "bindings.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/common/rotation.h"
#include "hexsim/envs/act.h"
#include "hexsim/experiments/ground_calibration.h"
#include "hexsim/experiments/point_runner.h"
#include "hexsim/sim/run_config.h"
#include "hexsim/sim/simulation.h"

namespace hexsim::python {

namespace {

using envs::Action;
using envs::ActMode;

std::vector<double> Values(const py::object& values, const std::string& what) {
  if (values.is_none()) return {};
  if (PyList_Check(values.ptr()) || PyTuple_Check(values.ptr())) {  // the fast path of a 1 kHz loop
    const auto seq = py::reinterpret_borrow<py::sequence>(values);
    std::vector<double> v(seq.size());
    for (size_t i = 0; i < v.size(); ++i) {
      v[i] = PyFloat_AsDouble(seq[i].ptr());
      if (v[i] == -1.0 && PyErr_Occurred()) {
        PyErr_Clear();
        RaiseBadInput(what + ": value " + std::to_string(i) + " is not a number");
      }
      if (!std::isfinite(v[i])) RaiseBadInput(what + ": value " + std::to_string(i) + " is not a finite number");
    }
    return v;
  }
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(values);
  if (!a || a.ndim() > 1) RaiseBadInput(what + ": expected a sequence of numbers");
  std::vector<double> v(a.data(), a.data() + a.size());
  for (size_t i = 0; i < v.size(); ++i) {
    if (!std::isfinite(v[i])) RaiseBadInput(what + ": value " + std::to_string(i) + " is not a finite number");
  }
  return v;
}

void ExpectCount(const std::vector<double>& v, size_t n, const std::string& what, const std::string& layout) {
  if (v.size() != n) {
    RaiseBadInput("act: " + what + ": expected " + std::to_string(n) + " values " + layout + " (got " +
                  std::to_string(v.size()) + ")");
  }
}

class PySimulation {
 public:
  PySimulation(const std::string& mission, const std::string& vehicle, const std::string& world, uint64_t seed,
               const std::string& estimator, double duration_s, const py::object& sets, const std::string& calibration,
               bool allow_field_extrapolation)
      : action_(std::make_unique<Action>()) {
    sim::RunRequest rq;
    rq.mission = mission;
    rq.vehicle = vehicle;
    rq.world = world;
    rq.seed = seed;
    rq.estimator = estimator;
    rq.duration_s = duration_s;
    rq.sets = SetStrings(sets);
    rq.allow_field_extrapolation = allow_field_extrapolation;
    sim::RunSetup setup = ValueOrRaise(sim::LoadRunSetup(rq));
    ThrowIfError(experiments::AttachCalibration(calibration, &setup));
    sim_ = ValueOrRaise(sim::Simulation::Create(setup, envs::ActPlugins(setup, action_.get())));
    rotors_ = setup.vehicle.rotors.size();
    action_->motors.assign(rotors_, 0.0);
  }

  bool Step(int64_t n) {
    if (n < 0) RaiseBadInput("step: n: must be >= 0 (got " + std::to_string(n) + ")");
    if (out_) return false;
    bool running = !sim_->finished();
    {
      py::gil_scoped_release unlocked;
      for (int64_t i = 0; i < n && running; ++i) running = sim_->Step();
    }
    return running;
  }

  py::dict Run() {
    Step(INT64_MAX);
    return Finish();
  }

  // Ends the run where it is: summary and log meta (as `hexsim run` writes them). A diverged run
  // raises NumericalError with the CLI's message; result() still gives the log and summary.
  py::dict Finish() {
    if (!out_) out_ = sim_->Finish();
    if (!out_->status.ok()) Raise(out_->status);
    return RunResult();
  }

  py::dict RunResult() const {
    if (!out_) RaiseBadInput("result: the run is not finished (call run() or finish() first)");
    py::dict d;
    d["status"] = sim::RunStatusName(out_->summary.status);
    d["summary"] = JsonToPython(sim::ToJson(out_->summary));
    d["log"] = FlightLogToDict(out_->log);
    d["meta"] = JsonToPython(out_->log.meta);
    return d;
  }

  // DIR/log.csv, log.meta.json and summary.json, as `hexsim run --out DIR` writes them.
  void Write(const std::string& dir) const {
    if (!out_) RaiseBadInput("write: the run is not finished (call run() or finish() first)");
    OutputDirectory out;
    ThrowIfError(out.Open(dir));
    ThrowIfError(experiments::WriteRunLog(*out_, out.path()));
    ThrowIfError(experiments::WriteRunSummary(*out_, out.path()));
    out.Commit();
  }

  void Act(const std::string& mode, const py::object& values) {
    std::vector<double> v = Values(values, "act: " + mode);
    Action a = *action_;
    if (mode == "builtin") {
      ExpectCount(v, 0, mode, "(none)");
      a.mode = ActMode::kBuiltin;
    } else if (mode == "position") {
      if (v.size() == 3) v.push_back(0.0);
      ExpectCount(v, 4, mode, "[N, E, D (m)] or [N, E, D (m), yaw (rad)]");
      a.mode = ActMode::kPosition;
      a.p_sp_N_m = Eigen::Vector3d(v[0], v[1], v[2]);
      a.yaw_sp_rad = v[3];
    } else if (mode == "attitude") {
      ExpectCount(v, 5, mode, "[q_w, q_x, q_y, q_z, thrust_N]");
      const Eigen::Quaterniond q(v[0], v[1], v[2], v[3]);
      if (!(q.norm() > 1e-6)) RaiseBadInput("act: attitude: the quaternion q_NB is zero");
      a.mode = ActMode::kAttitude;
      a.q_sp_NB = q.normalized();
      a.thrust_N = Thrust(v[4]);
    } else if (mode == "rates") {
      ExpectCount(v, 4, mode, "[p, q, r (rad/s, body FRD), thrust_N]");
      a.mode = ActMode::kRates;
      a.w_sp_B_radps = Eigen::Vector3d(v[0], v[1], v[2]);
      a.thrust_N = Thrust(v[3]);
    } else if (mode == "motors") {
      ExpectCount(v, rotors_, mode, "(one command per motor, 0..1)");
      for (size_t i = 0; i < v.size(); ++i) {
        if (v[i] < 0.0 || v[i] > 1.0) {
          RaiseBadInput("act: motors: motor " + std::to_string(i + 1) + ": command " + py::repr(py::float_(v[i])).cast<std::string>() +
                        " outside [0, 1]");
        }
      }
      a.mode = ActMode::kMotors;
      a.motors = std::move(v);
    } else {
      RaiseBadInput("act: mode: '" + mode + "': expected builtin, position, attitude, rates or motors");
    }
    *action_ = std::move(a);
  }

  py::dict State() const {
    const sim::BodyState& s = sim_->true_state();
    const vehicle::PowertrainOutput& pt = sim_->powertrain();
    std::vector<double> omega(rotors_, 0.0), motor_A(rotors_, 0.0);
    for (size_t i = 0; i < pt.motors.size() && i < rotors_; ++i) {
      omega[i] = pt.motors[i].omega_radps;
      motor_A[i] = pt.motors[i].dc_A;
    }
    py::dict d;
    d["t_s"] = sim_->time_s();
    d["p_N_m"] = ToArray(s.p_N_m);
    d["v_N_mps"] = ToArray(s.v_N_mps);
    const double q[4] = {s.q_NB.w(), s.q_NB.x(), s.q_NB.y(), s.q_NB.z()};
    d["q_NB"] = ToArray(q, 4);
    d["w_B_radps"] = ToArray(s.w_B_radps);
    d["motor_command"] = ToArray(sim_->motor_commands());
    d["motor_omega_radps"] = ToArray(omega);
    d["motor_A"] = ToArray(motor_A);
    d["battery_A"] = sim_->currents().battery_A;
    d["bus_V"] = pt.bus_V;
    d["soc"] = pt.motors.empty() ? sim_->setup().vehicle.battery.initial_soc : pt.soc;
    return d;
  }

  // [t_s, p_N_m (3), v_N_mps (3), q_NB (w, x, y, z), w_B_radps (3)]: the fast path for a controller.
  py::array_t<double> StateVector() const {
    const sim::BodyState& s = sim_->true_state();
    const double v[14] = {sim_->time_s(), s.p_N_m.x(), s.p_N_m.y(), s.p_N_m.z(), s.v_N_mps.x(), s.v_N_mps.y(),
                          s.v_N_mps.z(), s.q_NB.w(), s.q_NB.x(), s.q_NB.y(), s.q_NB.z(), s.w_B_radps.x(),
                          s.w_B_radps.y(), s.w_B_radps.z()};
    return ToArray(v, 14);
  }

  py::dict Sensors() const {
    const vehicle::SensorReadings& r = sim_->sensors();
    py::dict d;
    d["gyro_radps"] = ToArray(r.gyro_radps.value);
    d["gyro_t_s"] = r.gyro_radps.t_s;
    d["accel_mps2"] = ToArray(r.accel_mps2.value);
    d["accel_t_s"] = r.accel_mps2.t_s;
    for (size_t c = 0; c < r.mag_uT.size(); ++c) {
      const std::string name = c == 0 ? "mag" : "mag" + std::to_string(c + 1);  // the FlightLog's prefixes
      d[py::str(name + "_uT")] = ToArray(r.mag_uT[c].value);
      d[py::str(name + "_t_s")] = r.mag_uT[c].t_s;
    }
    d["gps_p_N_m"] = ToArray(r.gps.p_N_m);
    d["gps_v_N_mps"] = ToArray(r.gps.v_N_mps);
    d["gps_t_s"] = r.gps.t_s;
    d["baro_alt_m"] = r.baro.alt_m;
    d["baro_t_s"] = r.baro.t_s;
    return d;
  }

  py::dict Log() const { return FlightLogToDict(out_ ? out_->log : sim_->log()); }

  std::string StatusName() const {
    if (out_) return sim::RunStatusName(out_->summary.status);
    return sim_->finished() ? "finished" : "running";
  }
  double time_s() const { return sim_->time_s(); }
  bool finished() const { return out_.has_value() || sim_->finished(); }
  size_t rotors() const { return rotors_; }
  std::string act_mode() const { return envs::ActModeName(action_->mode); }
  double hover_thrust_N() const { return sim_->control_model().mass_kg * kGravity_mps2; }
  double max_thrust_N() const { return sim_->control_model().max_thrust_N; }

  void SetWind(const py::object& wind) {
    const std::vector<double> w = Values(wind, "set_wind");
    if (w.size() != 3) RaiseBadInput("set_wind: expected [N, E, D] in m/s");
    sim_->SetWindMean(Eigen::Vector3d(w[0], w[1], w[2]));
  }

 private:
  static double Thrust(double thrust_N) {
    if (thrust_N < 0.0) RaiseBadInput("act: thrust_N: must be >= 0 (got " + std::to_string(thrust_N) + ")");
    return thrust_N;
  }

  std::unique_ptr<Action> action_;  // heap: the plug-ins hold its address
  std::unique_ptr<sim::Simulation> sim_;
  std::optional<sim::RunOutput> out_;
  size_t rotors_ = 0;
};

}  // namespace

// "KEY=VALUE" for --set: strings as they are, booleans as YAML's true/false, the rest by repr()
// (floats round-trip; lists read as YAML flow sequences).
std::vector<std::string> SetStrings(const py::object& sets) {
  std::vector<std::string> out;
  if (sets.is_none()) return out;
  if (!py::isinstance<py::dict>(sets)) RaiseBadInput("set: expected a dict {KEY: VALUE}");
  for (const auto& [key, value] : sets.cast<py::dict>()) {
    std::string text;
    if (py::isinstance<py::str>(value)) {
      text = value.cast<std::string>();
    } else if (py::isinstance<py::bool_>(value)) {
      text = value.cast<bool>() ? "true" : "false";
    } else {
      text = py::repr(py::hasattr(value, "tolist") ? value.attr("tolist")() : value).cast<std::string>();
    }
    out.push_back(py::str(key).cast<std::string>() + "=" + text);
  }
  return out;
}

void BindSimulation(py::module_& m) {
  py::class_<PySimulation>(m, "Simulation", R"doc(
One closed-loop run, set up as `hexsim run` does (names under worlds/ or YAML paths; `set` is
--set as a dict, e.g. {"vehicle.mass_kg": 9.5}). NED earth frame, FRD body frame, SI units in names.
Where Python acts: act(mode, values), see the module's doc; the default is the built-in controller
flying the mission, and run() then gives `hexsim run`'s log.csv byte for byte.)doc")
      .def(py::init<const std::string&, const std::string&, const std::string&, uint64_t, const std::string&, double,
                    const py::object&, const std::string&, bool>(),
           py::kw_only(), py::arg("mission") = "square", py::arg("vehicle") = "default_hex",
           py::arg("world") = "default", py::arg("seed") = 1, py::arg("estimator") = "",
           py::arg("duration") = 0.0, py::arg("set") = py::none(), py::arg("calibration") = "none",
           py::arg("allow_field_extrapolation") = false)
      .def("step", &PySimulation::Step, py::arg("n") = 1,
           "Advances n physics steps (1 ms each by default); False once the run is over.")
      .def("run", &PySimulation::Run, "Steps to the end, then finish().")
      .def("finish", &PySimulation::Finish,
           "Ends the run: {'status', 'summary', 'log', 'meta'}. A diverged run raises NumericalError.")
      .def("result", &PySimulation::RunResult, "The finished run's {'status', 'summary', 'log', 'meta'}.")
      .def("write", &PySimulation::Write, py::arg("dir"), "log.csv, log.meta.json, summary.json into dir.")
      .def("act", &PySimulation::Act, py::arg("mode"), py::arg("values") = py::none(),
           "builtin | position [N,E,D(,yaw)] | attitude [qw,qx,qy,qz,thrust_N] | rates [p,q,r,thrust_N] | "
           "motors [u1..un in 0..1]; held until changed.")
      .def("state", &PySimulation::State, "True state: t_s, p_N_m, v_N_mps, q_NB, w_B_radps, motors, currents.")
      .def("state_vector", &PySimulation::StateVector,
           "[t_s, p_N_m(3), v_N_mps(3), q_NB(w,x,y,z), w_B_radps(3)] as one array.")
      .def("sensors", &PySimulation::Sensors, "Held sensor readings: gyro, accel, each compass, GPS, baro.")
      .def("log", &PySimulation::Log, "The FlightLog so far as {column: array}.")
      .def("set_wind", &PySimulation::SetWind, py::arg("wind_N_mps"), "Mean wind (NED, m/s) from now on.")
      .def_property_readonly("status", &PySimulation::StatusName)
      .def_property_readonly("time_s", &PySimulation::time_s)
      .def_property_readonly("finished", &PySimulation::finished)
      .def_property_readonly("rotors", &PySimulation::rotors)
      .def_property_readonly("act_mode", &PySimulation::act_mode)
      .def_property_readonly("hover_thrust_N", &PySimulation::hover_thrust_N, "m·g of the vehicle")
      .def_property_readonly("max_thrust_N", &PySimulation::max_thrust_N, "Largest collective thrust at full charge");
}

}  // namespace hexsim::python
