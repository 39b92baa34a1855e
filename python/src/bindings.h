// What the three translation units of the _hexsim module share: the exceptions a Status becomes,
// and the conversions of library results to Python objects (JSON → dict, FlightLog → dict of numpy
// arrays, Eigen → numpy).
#pragma once

#include <string>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "hexsim/common/status.h"
#include "hexsim/logs/flight_log.h"

namespace hexsim::python {

namespace py = pybind11;

// hexsim.Error (RuntimeError) and its subclasses by exit code: CheckFailedError (1), BadInputError
// (2, also a ValueError), NumericalError (3, also an ArithmeticError). Created once by the module.
void DefineExceptions(py::module_& m);

// Raises the exception of `status`'s code carrying the CLI's one-line message (what `hexsim`
// prints after "hexsim: ", newlines folded to spaces). `status` must not be OK.
[[noreturn]] void Raise(const Status& status);
// Raises BadInputError with `message`.
[[noreturn]] void RaiseBadInput(const std::string& message);
inline void ThrowIfError(const Status& status) {
  if (!status.ok()) Raise(status);
}
template <class T>
T ValueOrRaise(Result<T> result) {
  if (!result.ok()) Raise(result.status());
  return std::move(result).value();
}

// JSON → None / bool / int / float / str / list / dict; a NaN or infinite number → None, as the
// written JSON file holds it.
py::object JsonToPython(const nlohmann::json& j);
// Python (None, bool, int, float, str, sequences, dicts, numpy scalars and arrays) → JSON.
nlohmann::json PythonToJson(const py::handle& obj);

// Each column as a float64 array (a copy), in the log's column order.
py::dict FlightLogToDict(const logs::FlightLog& log);
// A FlightLog from {column: 1-D array} (all of one length, "t_s" required) and its meta dict.
logs::FlightLog FlightLogFromDict(const py::dict& columns, const py::object& meta);

py::array_t<double> ToArray(const double* values, size_t n);
inline py::array_t<double> ToArray(const Eigen::Vector3d& v) { return ToArray(v.data(), 3); }
inline py::array_t<double> ToArray(const std::vector<double>& v) { return ToArray(v.data(), v.size()); }
py::array_t<double> ToArray(const Eigen::Matrix3d& m);  // 3×3, row-major as written
// An (N, 3) float array → rows; BadInputError naming `what` for any other shape or a non-finite value.
std::vector<Eigen::Vector3d> Rows3(const py::handle& array, const std::string& what);

// A Python dict {KEY: VALUE} as --set's "KEY=VALUE" strings (None: none).
std::vector<std::string> SetStrings(const py::object& sets);

// The parts of the module, each in its own translation unit.
void BindSimulation(py::module_& m);
void BindAnalysis(py::module_& m);  // wmm, calibration fits, gap diagnosis
void BindEnvs(py::module_& m);      // VectorCore (the environments' C++ core), render_tracks

}  // namespace hexsim::python
