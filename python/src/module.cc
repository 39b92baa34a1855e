// The _hexsim extension module: exceptions, conversions (bindings.h), and the parts bound in
// simulation.cc and analysis.cc. The Python package (python/hexsim/__init__.py) re-exports it.
#include <cmath>
#include <cstring>
#include <string>

#include "bindings.h"
#include "hexsim/common/paths.h"

namespace hexsim::python {

namespace {

// The exception types, created in DefineExceptions and alive as long as the interpreter (the
// module object holds a reference too).
PyObject* g_error = nullptr;
PyObject* g_check_failed = nullptr;
PyObject* g_bad_input = nullptr;
PyObject* g_numerical = nullptr;

PyObject* NewException(py::module_& m, const char* name, py::handle bases, const char* doc) {
  const std::string qualified = std::string("hexsim.") + name;
  PyObject* type = PyErr_NewExceptionWithDoc(qualified.c_str(), doc, bases.ptr(), nullptr);
  if (type == nullptr) throw py::error_already_set();
  m.attr(name) = py::handle(type);  // the module keeps a reference as well
  return type;
}

}  // namespace

void DefineExceptions(py::module_& m) {
  g_error = NewException(m, "Error", py::handle(PyExc_RuntimeError),
                         "A hexsim library call failed; the message is the CLI's one line.");
  g_check_failed = NewException(m, "CheckFailedError", py::handle(g_error),
                                "A check the user must look at failed (the CLI's exit code 1).");
  g_bad_input = NewException(m, "BadInputError", py::make_tuple(py::handle(g_error), py::handle(PyExc_ValueError)),
                             "Bad input: FILE[:LINE]: FIELD: what is wrong (the CLI's exit code 2).");
  g_numerical = NewException(m, "NumericalError",
                             py::make_tuple(py::handle(g_error), py::handle(PyExc_ArithmeticError)),
                             "Numerical failure on valid input: divergence, a singular fit (exit code 3).");
}

void Raise(const Status& status) {
  std::string message = status.message();
  for (char& c : message) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  PyObject* type = g_error;
  switch (status.code()) {
    case StatusCode::kCheckFailed: type = g_check_failed; break;
    case StatusCode::kBadInput: type = g_bad_input; break;
    case StatusCode::kNumerical: type = g_numerical; break;
    case StatusCode::kOk: break;
  }
  PyErr_SetString(type, message.c_str());
  throw py::error_already_set();
}

void RaiseBadInput(const std::string& message) { Raise(Status::BadInput(message)); }

py::object JsonToPython(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::null: return py::none();
    case nlohmann::json::value_t::boolean: return py::bool_(j.get<bool>());
    case nlohmann::json::value_t::number_integer: return py::int_(j.get<int64_t>());
    case nlohmann::json::value_t::number_unsigned: return py::int_(j.get<uint64_t>());
    case nlohmann::json::value_t::number_float: {
      const double x = j.get<double>();
      if (!std::isfinite(x)) return py::none();  // as the JSON file holds it (dump writes null)
      return py::float_(x);
    }
    case nlohmann::json::value_t::string: return py::str(j.get_ref<const std::string&>());
    case nlohmann::json::value_t::array: {
      py::list list;
      for (const auto& item : j) list.append(JsonToPython(item));
      return std::move(list);
    }
    case nlohmann::json::value_t::object: {
      py::dict dict;
      for (const auto& [key, value] : j.items()) dict[py::str(key)] = JsonToPython(value);
      return std::move(dict);
    }
    default: return py::none();  // binary and discarded values never occur in hexsim's JSON
  }
}

nlohmann::json PythonToJson(const py::handle& obj) {
  if (obj.is_none()) return nullptr;
  if (py::isinstance<py::bool_>(obj)) return obj.cast<bool>();
  if (py::isinstance<py::int_>(obj)) return obj.cast<int64_t>();
  if (py::isinstance<py::float_>(obj)) return obj.cast<double>();
  if (py::isinstance<py::str>(obj)) return obj.cast<std::string>();
  if (py::isinstance<py::dict>(obj)) {
    nlohmann::json j = nlohmann::json::object();
    for (const auto& [key, value] : obj.cast<py::dict>()) j[py::str(key).cast<std::string>()] = PythonToJson(value);
    return j;
  }
  if (py::hasattr(obj, "tolist")) return PythonToJson(obj.attr("tolist")());  // numpy arrays and scalars
  if (py::isinstance<py::sequence>(obj)) {
    nlohmann::json j = nlohmann::json::array();
    for (const auto& item : obj.cast<py::sequence>()) j.push_back(PythonToJson(item));
    return j;
  }
  RaiseBadInput("meta: a value of type " + py::str(py::type::of(obj).attr("__name__")).cast<std::string>() +
                " cannot be written as JSON");
}

py::array_t<double> ToArray(const double* values, size_t n) {
  py::array_t<double> a(static_cast<py::ssize_t>(n));
  if (n > 0) std::memcpy(a.mutable_data(), values, n * sizeof(double));
  return a;
}

py::array_t<double> ToArray(const Eigen::Matrix3d& m) {
  py::array_t<double> a({3, 3});
  auto r = a.mutable_unchecked<2>();
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 3; ++k) r(i, k) = m(i, k);
  }
  return a;
}

std::vector<Eigen::Vector3d> Rows3(const py::handle& array, const std::string& what) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(array);
  if (!a || a.ndim() != 2 || a.shape(1) != 3) RaiseBadInput(what + ": expected an (N, 3) array of numbers");
  const auto r = a.unchecked<2>();
  std::vector<Eigen::Vector3d> rows(static_cast<size_t>(a.shape(0)));
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    rows[static_cast<size_t>(i)] = Eigen::Vector3d(r(i, 0), r(i, 1), r(i, 2));
    if (!rows[static_cast<size_t>(i)].allFinite()) {
      RaiseBadInput(what + ": row " + std::to_string(i) + ": not a finite number");
    }
  }
  return rows;
}

py::dict FlightLogToDict(const logs::FlightLog& log) {
  py::dict d;
  for (size_t c = 0; c < log.columns().size(); ++c) d[py::str(log.columns()[c])] = ToArray(log.Column(c));
  return d;
}

logs::FlightLog FlightLogFromDict(const py::dict& columns, const py::object& meta) {
  logs::FlightLog log;
  std::vector<py::array_t<double, py::array::c_style | py::array::forcecast>> arrays;
  size_t rows = 0;
  for (const auto& [key, value] : columns) {
    const std::string name = py::str(key).cast<std::string>();
    auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(value);
    if (!a || a.ndim() != 1) RaiseBadInput("log: " + name + ": expected a 1-D array of numbers");
    if (arrays.empty()) rows = static_cast<size_t>(a.shape(0));
    if (static_cast<size_t>(a.shape(0)) != rows) {
      RaiseBadInput("log: " + name + ": " + std::to_string(a.shape(0)) + " rows, the first column has " +
                    std::to_string(rows));
    }
    log.AddColumn(name);
    arrays.push_back(std::move(a));
  }
  if (!log.Has("t_s")) RaiseBadInput("log: t_s: required column missing");
  for (size_t r = 0; r < rows; ++r) log.AppendRow();
  for (size_t c = 0; c < arrays.size(); ++c) {
    std::memcpy(log.MutableColumn(c).data(), arrays[c].data(), rows * sizeof(double));
  }
  if (!meta.is_none()) log.meta = PythonToJson(meta);
  return log;
}

}  // namespace hexsim::python

PYBIND11_MODULE(_hexsim, m) {
  namespace hp = hexsim::python;
  m.doc() = "hexsim's C++ libraries (simulation, WMM, compass calibration, gap diagnosis); use the hexsim package";
  m.attr("__version__") = hexsim::Version();
  hp::DefineExceptions(m);
  hp::BindSimulation(m);
  hp::BindAnalysis(m);
  hp::BindEnvs(m);
}
