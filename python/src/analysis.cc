// hexsim.wmm.field, hexsim.calibrate and hexsim.gap.diagnose: the library calls behind
// `hexsim field`, `hexsim calibrate` and `hexsim gap diagnose --sim`, on Python objects.
#include <string>
#include <vector>

#include "bindings.h"
#include "hexsim/experiments/log_diagnosis.h"
#include "hexsim/logs/read_log.h"
#include "hexsim/magnetics/autopilot_params.h"
#include "hexsim/magnetics/calib_io.h"
#include "hexsim/magnetics/calibrate.h"
#include "hexsim/magnetics/wmm.h"

namespace hexsim::python {

namespace {

// A date as `hexsim field` takes it: "YYYY-MM-DD" or a decimal year, as text or a number;
// datetime.date objects by their ISO text.
std::string DateText(const py::object& date) {
  if (py::isinstance<py::str>(date)) return date.cast<std::string>();
  if (py::hasattr(date, "isoformat")) return date.attr("isoformat")().cast<std::string>().substr(0, 10);
  return py::repr(date).cast<std::string>();
}

// hexsim.field/1, as `hexsim field --json` prints it, plus B_N_uT as an array.
py::dict Field(double lat_deg, double lon_deg, double alt_m, const py::object& date, const std::string& model,
               bool allow_extrapolation) {
  const std::string text = DateText(date);
  const double year = ValueOrRaise(magnetics::DecimalYearFromDate(text));
  const magnetics::GeodeticPoint where{lat_deg, lon_deg, alt_m};
  const magnetics::EarthField f = ValueOrRaise(
      model.empty() ? magnetics::EvaluateWmm(where, year, allow_extrapolation)
                    : magnetics::EvaluateWmmModel(model, where, year, allow_extrapolation));
  const Eigen::Vector3d B_nT = f.B_N_uT * 1000.0;
  py::dict d;
  d["schema"] = "hexsim.field/1";
  d["model"] = f.model;
  d["model_id"] = f.model_id;
  d["lat_deg"] = lat_deg;
  d["lon_deg"] = lon_deg;
  d["alt_m"] = alt_m;
  d["date"] = text;
  d["decimal_year"] = year;
  d["north_nT"] = B_nT(0);
  d["east_nT"] = B_nT(1);
  d["down_nT"] = B_nT(2);
  d["horizontal_nT"] = f.horizontal_uT * 1000.0;
  d["total_nT"] = f.total_uT * 1000.0;
  d["declination_deg"] = f.declination_deg;
  d["inclination_deg"] = f.inclination_deg;
  d["B_N_uT"] = ToArray(f.B_N_uT);
  return d;
}

int CompassIndex(const std::string& compass) {
  if (compass == "mag") return 0;
  if (compass == "mag2") return 1;
  if (compass == "mag3") return 2;
  RaiseBadInput("compass: '" + compass + "': expected mag, mag2 or mag3");
}

// `hexsim calibrate` on free-hand samples: the fit (offset, A, K), hexsim.calib/1 as `report`, and
// the files' texts (calib.yaml, ArduPilot .parm, PX4 .params). A fit its gate rejects is returned
// with accepted False and exit_code 1, as the CLI exits 1 with its outputs written.
py::dict Calibrate(const py::object& samples, const std::string& method, const std::string& units,
                   double field_norm_uT, const std::string& compass, const py::object& prior_offset) {
  const std::vector<Eigen::Vector3d> raw = Rows3(samples, "samples");
  std::vector<magnetics::MagSample> s(raw.size());
  for (size_t i = 0; i < raw.size(); ++i) s[i].mag_B_uT = raw[i];
  magnetics::CalibrateRequest rq;
  rq.method = method;
  rq.units = units;
  rq.field_norm_uT = field_norm_uT;
  rq.compass_index = CompassIndex(compass);
  if (!prior_offset.is_none()) {
    const py::array_t<double, py::array::forcecast> p = py::array_t<double, py::array::forcecast>::ensure(prior_offset);
    if (!p || p.size() != 3) RaiseBadInput("prior_offset: expected 3 numbers (input units)");
    rq.prior_offset = Eigen::Vector3d(p.at(0), p.at(1), p.at(2));
  }
  const magnetics::CalibrateOutcome o = ValueOrRaise(magnetics::Calibrate(std::move(s), rq));
  py::dict d;
  d["method_used"] = o.field.method_used;
  d["why"] = o.field.why;
  d["accepted"] = o.exit_code == 0;
  d["exit_code"] = o.exit_code;
  d["offset_uT"] = ToArray(o.field.offset_uT);
  d["A"] = ToArray(o.field.A);
  d["K"] = ToArray(o.field.K);
  d["radius_uT"] = o.field.radius_uT;
  d["fitness_uT"] = o.field.fitness_uT;
  d["units"] = o.units.unit;
  d["report"] = JsonToPython(o.report);
  d["calib_yaml"] = magnetics::CompensatorToYamlText(*o.compensator);
  d["ardupilot_parm"] = magnetics::ArduPilotParmText(o.ardupilot);
  d["px4_params"] = magnetics::Px4ParamsText(o.px4);
  return d;
}

// `hexsim gap diagnose --real LOG [--sim VEHICLE]`: gap.json's content (experiments::DiagnoseLog, the
// CLI's call). `log` is a path read as the CLI reads it (FlightLog CSV, ArduPilot .bin or PX4 .ulg,
// logs::ReadAnyFlightLog; what the import says goes to "import_notes", the CLI's "log:" lines) or
// {column: array} (with `meta`, the .meta.json content, when the log has one); vehicle "" identifies
// the vehicle from the log (held-out blocks diagnosed).
py::dict Diagnose(const py::object& log_arg, const std::string& vehicle_name, uint64_t seed, double from_s,
                  double to_s, const py::object& meta) {
  logs::FlightLog log;
  std::vector<std::string> notes;
  experiments::LogDiagnosisOptions o;
  o.log_name = "<dict>";
  if (py::isinstance<py::dict>(log_arg)) {
    log = FlightLogFromDict(log_arg.cast<py::dict>(), meta);
  } else {
    o.log_name = py::str(py::module_::import("os").attr("fspath")(log_arg)).cast<std::string>();
    log = ValueOrRaise(logs::ReadAnyFlightLog(o.log_name, &notes));
  }
  o.vehicle = vehicle_name;
  o.seed = seed;
  o.from_s = from_s;
  o.to_s = to_s;
  const experiments::LogDiagnosis d = ValueOrRaise(experiments::DiagnoseLog(log, o));
  py::dict out = JsonToPython(experiments::LogDiagnosisJson(d));
  out["summary_text"] = gap::Summary(d.report);
  py::list import_notes;
  for (const auto& line : notes) import_notes.append(line);
  out["import_notes"] = import_notes;
  return out;
}

}  // namespace

void BindAnalysis(py::module_& m) {
  m.def("wmm_field", &Field, py::arg("lat_deg"), py::arg("lon_deg"), py::arg("alt_m"), py::arg("date"),
        py::kw_only(), py::arg("model") = "", py::arg("allow_extrapolation") = false,
        "World Magnetic Model field (hexsim.field/1 keys, nT, plus B_N_uT); date: YYYY-MM-DD or a decimal year.");
  m.def("calibrate", &Calibrate, py::arg("samples"), py::kw_only(), py::arg("method") = "auto",
        py::arg("units") = "auto", py::arg("field_norm_uT") = 0.0, py::arg("compass") = "mag",
        py::arg("prior_offset") = py::none(),
        "Compass calibration of an (N, 3) array: calibrated = A·(raw − offset_uT); report = hexsim.calib/1.");
  m.def("gap_diagnose", &Diagnose, py::arg("log"), py::arg("vehicle"), py::kw_only(), py::arg("seed") = 1,
        py::arg("from_s") = 0.0, py::arg("to_s") = 0.0, py::arg("meta") = py::none(),
        "Sim-to-real gap diagnosis of a log (FlightLog CSV, .bin or .ulg path, or {column: array}) against a "
        "vehicle ('': identified from the log, held-out blocks diagnosed): gap.json as a dict, plus summary_text "
        "and import_notes.");
}

}  // namespace hexsim::python
