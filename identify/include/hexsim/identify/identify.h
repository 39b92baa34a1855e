// Vehicle identification from a real or simulated FlightLog (issue 18, CONTRACTS `hexsim.identify/1`).
//
// In flight windows (all motors turning, clear of the ground), per IMU sample, with every other
// stream held at its latest sample (never interpolated):
//   vertical    −f_z = c·Σ_i LP_τ[φ(x_i)] + d_z·v_z,B         x_i = u_i·V/V_ref,  φ(x) = (1−e)·x + e·x²
//               (ArduPilot's thrust model: e = MOT_THST_EXPO where logged, else profiled over [0, 1];
//               LP_τ the first-order motor lag, τ profiled over 5–300 ms; c the specific thrust of
//               one motor at full output and V_ref, m/s²)
//   lateral     f_x,y = −δ1·v − δ2·|v|·v + b_x,y            (linear and quadratic drag per unit mass)
//   yaw         ṙ = κ·c·Σ_i s_i·LP_τ[φ(x_i)] − ζ·r + b_r    (s_i the rotor spin; k_Q/k_T = κ·J_z/m)
//   battery     V = V_oc − R·I − k_q·Q(t)                    (Q the charge drawn so far)
//   IMU noise   σ = RMS(Δ²y)/√6 over consecutive samples (white noise per logged sample)
// Hover output u_h: n·c·φ(u_h) = g at V_ref. Each parameter carries a 95 % interval from a block
// bootstrap over contiguous time blocks (profiled parameters re-profiled per resample) and its
// physical range; a value outside its range is a model mismatch and is not used in the vehicle.
#pragma once

#include <array>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hexsim/common/status.h"
#include "hexsim/logs/flight_log.h"
#include "hexsim/vehicle/vehicle_params.h"

namespace hexsim::identify {

struct IdentifyOptions {
  std::string frame = "auto";  // auto | quad-x | quad-plus | hex-x | hex-plus | octo-x
  int blocks = 20;             // contiguous time blocks (bootstrap unit; even/odd: fit/held-out)
  int bootstrap_samples = 200;
  uint64_t seed = 1;
  double min_height_m = 0.5;   // flight: CG this far above the take-off point
  double window_edge_s = 1.0;  // trimmed from each end of a flight window (take-off/landing transients)
  double min_flight_s = 10.0;  // less flight than this is not identifiable (bad input)
  // Fit only on these blocks (empty: all). gap diagnose fits on even blocks and tests on odd ones.
  std::vector<int> fit_blocks;
  // The base vehicle's mass is this airframe's (a vehicle file given for it, `--base`): the logged
  // electrical power is then judged per newton of its weight. False: the base is the shipped vehicle
  // of the frame class, whose mass says nothing of the log's airframe (a 12S heavy-lift quad draws
  // 270 W per newton of a 1.5 kg quad's weight and 16 of its own); the power is not judged.
  bool base_mass_known = false;
  std::string IsValid() const;  // empty when valid
};

// One identified (or base) parameter.
struct Param {
  double value = 0.0;
  double ci95[2] = {0.0, 0.0};
  std::string unit;
  std::string source = "fitted";  // fitted | base | "model mismatch"
  double range[2] = {0.0, 0.0};   // physical range (the shared plausibility table's row)
  std::string range_reason;       // that row's reason
  std::string note;
  // Written into the vehicle: fitted, and the whole 95 % interval inside the physical range (a fit
  // whose interval leaves the range did not determine the parameter; the base value stays), and, for
  // a value profiled over a grid, not the grid's last value (there it is a bound, not an estimate).
  bool applied = false;
  std::string not_applied;  // why a fitted value was not applied ("" where applied or not fitted)
  bool plausible() const { return value >= range[0] && value <= range[1]; }
};

struct FlightWindow {
  double start_s = 0.0, end_s = 0.0;
  std::string kind = "flight";  // flight | ground
  std::string why;
};

// One contiguous time block of the flight windows.
struct BlockSpan {
  double start_s = 0.0, end_s = 0.0;
  int block = 0;
};

// Fit quality on held-out blocks (fitted on the even blocks, evaluated on the odd ones).
struct HeldoutFit {
  std::string output, unit;
  double rms_measured = 0.0;  // about its mean
  double rms_residual = 0.0;
  double r2 = 0.0;            // 1 − SS_res/SS_tot
  size_t samples = 0;
};

// Measured vs predicted on held-out samples, for the report's plots.
struct Trace {
  std::string output, unit;
  std::vector<double> t_s, measured, predicted;
};

struct IdentifyResult {
  std::string frame;         // quad-x, hex-x, ...
  std::string frame_source;  // FRAME_CLASS/FRAME_TYPE, FRAME, motor outputs
  size_t motors = 0;
  std::string base_name;
  std::map<std::string, Param> params;
  std::vector<std::string> param_order;  // report order
  std::vector<FlightWindow> windows;
  std::vector<BlockSpan> blocks;
  std::vector<int> fit_blocks;  // the blocks the parameters were fitted on
  std::vector<HeldoutFit> heldout;
  // Dynamics residual on the held-out blocks, 3 axes, RMS about zero: measured specific force
  // against (−Σ_i T_i(u_i, V)·ẑ + F_drag(v_B))/m through hexsim's steady powertrain, for the base
  // vehicle and for the identified one (fitted on the even blocks).
  double dynamics_rms_base = 0.0, dynamics_rms_identified = 0.0;
  // Why the two vehicles are not compared on this log (empty when they are): the log's bus voltage
  // is not the base vehicle's battery, so the base's motors would be driven at a voltage they never
  // see (the residuals, NaN then, would measure the voltage, not the vehicle).
  std::string dynamics_not_comparable;
  // The identified vehicle's held-out residual is below the base's. When it is not, the
  // identification improves nothing: `hexsim identify` exits 1 without writing the vehicle, and
  // `gap diagnose` without --sim diagnoses against the base instead.
  bool improves_on_base = false;
  std::vector<Trace> traces;
  std::vector<double> hover_voltage_V, hover_output;  // steady-hover samples (for the plot)
  double v_ref_V = 0.0;       // reference bus voltage (median in flight; 0 when not logged)
  double thrust_expo = 0.0;
  std::string thrust_expo_source;
  std::vector<int> spins;     // rotor spins used for the yaw fit (+1 counter-clockwise seen from above)
  // Each motor's position in the body x-y plane (m) and where spins and positions came from: the log's
  // own geometry (PX4 CA_ROTORn_PX/PY/KM), its frame's motor table (ArduPilot AP_MotorsMatrix, at the
  // base's arm length), or the base vehicle's rotors (a hexsim log numbers motors as its vehicle file).
  std::vector<std::array<double, 2>> rotor_xy_m;
  std::string layout_source;
  // The layout differs from the base vehicle's (another motor order, spin or position): the vehicle
  // written takes the log's layout.
  bool layout_from_log = false;
  std::string data_source;    // which streams or columns fed the fit
  std::vector<std::string> notes;
};

// Identifies the log's vehicle. `base` supplies what the log cannot determine (mass, inertia,
// motor constants). Bad input: no usable flight (too short, missing accel/motor outputs).
Result<IdentifyResult> Identify(const logs::FlightLog& log, const vehicle::VehicleParams& base,
                                const IdentifyOptions& options = {});

// Frame from the log: FRAME_CLASS/FRAME_TYPE (3.5+), FRAME (3.3: 0 plus, 1 X), else the motor outputs.
// Returns e.g. "quad-x"; `source` says from what. Empty when not determined.
std::string FrameOfLog(const logs::FlightLog& log, std::string* source);
// Every frame name identify knows (the --frame values besides auto): ArduPilot's motor tables
// (quad plus/x/v/h/plus-rev/bf-x/dji-x/cw-x/bf-x-rev, hex x/plus/h/dji-x/cw-x, octo x).
std::vector<std::string> FrameNames();
// The shipped vehicle of a frame class: quad_* -> quad_x, hex_* -> default_hex, else empty.
std::string DefaultBaseFor(const std::string& frame);

// The base vehicle of an identification, and how it was chosen: the sequence `hexsim identify` and
// `gap diagnose` without --sim share.
struct BaseVehicle {
  vehicle::VehicleParams params;
  std::string yaml;          // the vehicle file's text
  std::string path;          // the file it was read from
  std::string frame;         // the log's frame when the base was chosen by it, else ""
  std::string frame_source;  // what decided that frame
};
// `name` (a name under worlds/vehicles, or a YAML path) when not empty; else the shipped vehicle of the
// frame class of `frame` ("auto" or "": FrameOfLog). Bad input when no base can be chosen:
// "LOG: frame: not determined (...); <what_to_give>", or when the vehicle does not load.
Result<BaseVehicle> ChooseBaseVehicle(const logs::FlightLog& log, const std::string& name, const std::string& frame,
                                      const std::string& log_name, const std::string& what_to_give);

// The vehicle YAML: the base vehicle's document with the fitted values applied (k_T, k_Q, rotor
// inertia, drag, battery), a header comment listing what was fitted and what kept.
Result<std::string> IdentifiedVehicleYaml(const std::string& base_yaml_text, const vehicle::VehicleParams& base,
                                          const IdentifyResult& result);
// The vehicle file at `path`, which means "done": written (IdentifiedVehicleYaml) when the
// identification improves on its base; otherwise nothing is written and a file an earlier run left
// at `path` is removed, so no stale vehicle stands beside this run's identify.json. `*outcome` (optional)
// gets "written", "not written" or "not written (the file an earlier run left there removed)".
Status WriteIdentifiedVehicle(const std::string& path, const BaseVehicle& base, const IdentifyResult& result,
                              std::string* outcome = nullptr);
// The vehicle without its current wiring (segments and dipoles of wiring:): a shipped base's wiring
// is hexsim's airframe's layout, not the log's, so `gap diagnose` without --sim compares each
// compass with no modelled current field (the log's field is then reported whole, and the updated
// vehicle adds it). `yaml_text` loses the wiring key and gains a comment saying so.
Status DropWiring(vehicle::VehicleParams* v, std::string* yaml_text);
// The base vehicle with the identified values applied (what the YAML describes).
vehicle::VehicleParams ApplyIdentified(const vehicle::VehicleParams& base, const IdentifyResult& result);

// The log with its measured sensor columns (gyro_*, accel_*, mag*_x/y/z_uT, in the table and in the
// imu/mag streams) emptied inside the fitting blocks: what `gap diagnose` without `--sim` diagnoses,
// so the identified vehicle is judged on data it was not fitted to.
logs::FlightLog HeldOutLog(const logs::FlightLog& log, const IdentifyResult& result);
// How far `vehicle` is from the identified one: per comparable parameter, the identified value and
// interval, the vehicle's value through hexsim's models (hover output at the log's V_ref, thrust
// scale 1, motor time constant at hover, k_Q/k_T, drag per mass, battery resistance), and whether the
// interval holds it. `lines` (optional) gets one readable line per parameter.
nlohmann::json DistanceFromVehicle(const IdentifyResult& result, const vehicle::VehicleParams& vehicle,
                                   std::vector<std::string>* lines = nullptr);

// identify.json (hexsim.identify/1).
nlohmann::json ToJson(const IdentifyResult& result);
// A plain-text summary (one line per parameter).
std::string Summary(const IdentifyResult& result);
// One line saying whether the identification improves on its base, with both held-out residuals.
std::string ImprovementLine(const IdentifyResult& result);

}  // namespace hexsim::identify
