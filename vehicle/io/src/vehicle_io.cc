// VehicleParams from the vehicle YAML (worlds/vehicles/*.yaml).
#include "hexsim/vehicle/vehicle_io.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>

#include "hexsim/common/rotation.h"
#include "hexsim/common/yaml_reader.h"

namespace hexsim::vehicle {

namespace {

// Reads a NoiseParams block whose keys carry `unit`: noise_std_<u> or noise_density_<u>_per_sqrt_hz
// (converted with the sample rate), bias_std_<u>, bias_walk_<u>_per_sqrt_s.
void ReadNoise(YamlReader& r, const std::string& unit, double rate_hz, NoiseParams* n) {
  const std::string std_key = "noise_std_" + unit;
  const std::string density_key = "noise_density_" + unit + "_per_sqrt_hz";
  if (r.Has(std_key) && r.Has(density_key)) {
    r.Fail(density_key, "give either " + std_key + " or " + density_key + ", not both");
    return;
  }
  r.Opt(std_key, &n->noise_std, NonNegative());
  double density = -1.0;
  r.Opt(density_key, &density, NonNegative());
  if (density >= 0.0) n->noise_std = density * std::sqrt(rate_hz);
  r.Opt("bias_std_" + unit, &n->bias_std, NonNegative());
  r.Opt("bias_walk_" + unit + "_per_sqrt_s", &n->bias_walk_per_sqrt_s, NonNegative());
}

void ReadImu(YamlReader& r, const std::string& unit, ImuSensorParams* p) {
  r.Opt("rate_hz", &p->rate_hz, Positive());
  ReadNoise(r, unit, p->rate_hz, &p->noise);
}

// A unit vector; zero length is an error.
void ReadAxis(YamlReader& r, const std::string& key, Eigen::Vector3d* axis) {
  Eigen::Vector3d v = *axis;
  r.Opt(key, &v);
  if (!r.ok()) return;
  if (v.norm() < 1e-9) return r.Fail(key, "must not be the zero vector");
  *axis = v.normalized();
}

void ReadInertia(YamlReader& r, Eigen::Matrix3d* J) {
  r.Opt("inertia_kgm2", J);
  if (!r.ok()) return;
  if ((*J - J->transpose()).norm() > 1e-12 * std::max(1.0, J->norm())) {
    return r.Fail("inertia_kgm2", "must be symmetric");
  }
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(*J).eigenvalues();
  if (!(ev.minCoeff() > 0.0)) {
    return r.Fail("inertia_kgm2", fmt::format("must be positive definite (smallest eigenvalue {})", ev.minCoeff()));
  }
  // Principal moments of a rigid body obey the triangle inequality.
  if (ev(0) + ev(1) < ev(2) * (1.0 - 1e-9)) {
    return r.Fail("inertia_kgm2", "principal moments violate the triangle inequality (not a rigid body)");
  }
}

struct RotorDefaults {
  std::optional<double> k_T, k_Q, inertia;
  Eigen::Vector3d axis_B = Eigen::Vector3d(0.0, 0.0, -1.0);
};

void ReadRotor(YamlReader& r, const RotorDefaults& d, RotorParams* rotor) {
  r.Req("position_B_m", &rotor->position_B_m);
  r.Req("spin", &rotor->spin);
  if (r.ok() && rotor->spin != 1 && rotor->spin != -1) {
    r.Fail("spin", fmt::format("must be +1 (CCW seen from above) or -1 (CW) (got {})", rotor->spin));
  }
  rotor->axis_B = d.axis_B;
  ReadAxis(r, "axis_B", &rotor->axis_B);
  if (d.k_T) rotor->k_T_Nprps2 = *d.k_T;
  if (d.k_Q) rotor->k_Q_Nmprps2 = *d.k_Q;
  if (d.inertia) rotor->inertia_kgm2 = *d.inertia;
  if (d.k_T) r.Opt("k_T_Nprps2", &rotor->k_T_Nprps2, Positive());
  else r.Req("k_T_Nprps2", &rotor->k_T_Nprps2, Positive());
  if (d.k_Q) r.Opt("k_Q_Nmprps2", &rotor->k_Q_Nmprps2, Positive());
  else r.Req("k_Q_Nmprps2", &rotor->k_Q_Nmprps2, Positive());
  r.Opt("inertia_kgm2", &rotor->inertia_kgm2, NonNegative());
}

void ReadMotorIndex(YamlReader& r, size_t rotor_count, int* motor_index_0based) {
  int motor = 0;
  r.Req("motor", &motor);
  if (!r.ok()) return;
  if (motor < 1 || static_cast<size_t>(motor) > rotor_count) {
    return r.Fail("motor", fmt::format("must name a rotor 1..{} (got {})", rotor_count, motor));
  }
  *motor_index_0based = motor - 1;
}

void ReadWiring(YamlReader& r, size_t rotor_count, magnetics::CurrentFieldParams* w) {
  r.Opt("lag_tau_s", &w->lag_tau_s, NonNegative());
  r.Opt("exponent", &w->exponent, Positive());
  r.ForEach("segments", [&](YamlReader& s, size_t) {
    magnetics::WireSegment seg;
    s.Opt("name", &seg.name);
    s.Req("a_B_m", &seg.a_B_m);
    s.Req("b_B_m", &seg.b_B_m);
    std::string source = "battery";
    s.Opt("source", &source, {"battery", "motor"});
    s.Opt("share", &seg.share, InRange(-1.0, 1.0));
    if (!s.ok()) return;
    if ((seg.b_B_m - seg.a_B_m).norm() < 1e-6) return s.Fail("b_B_m", "segment has zero length");
    if (source == "motor") {
      seg.source = magnetics::CurrentSource::kMotor;
      ReadMotorIndex(s, rotor_count, &seg.motor_index);
    } else {
      seg.source = magnetics::CurrentSource::kBattery;
      seg.motor_index = -1;
    }
    w->segments.push_back(seg);
  });
  r.ForEach("dipoles", [&](YamlReader& d, size_t) {
    magnetics::MotorDipole dip;
    ReadMotorIndex(d, rotor_count, &dip.motor_index);
    d.Req("p_B_m", &dip.p_B_m);
    d.Req("moment_per_A_Am2", &dip.moment_per_A_Am2);
    w->dipoles.push_back(dip);
  });
}

void ReadCompass(YamlReader& r, CompassParams* c) {
  r.Req("name", &c->name);
  r.Req("position_B_m", &c->position_B_m);
  r.Opt("external", &c->external);
  r.Opt("hard_iron_uT", &c->error.hard_iron_uT);
  r.Opt("soft_iron", &c->error.soft_iron);
  r.Opt("soft_iron_per_A", &c->error.soft_iron_per_A);
  r.Opt("scale", &c->error.scale, Positive());
  Eigen::Vector3d rpy_deg = Eigen::Vector3d::Zero();
  r.Opt("orientation_rpy_deg", &rpy_deg);
  r.Opt("rate_hz", &c->rate_hz, Positive());
  ReadNoise(r, "uT", c->rate_hz, &c->noise);
  r.Opt("current_lag_tau_s", &c->current_lag_tau_s, NonNegative());
  if (!r.ok()) return;
  // Sensor axes S rotated from body by roll-pitch-yaw; R_SB takes body vectors into S.
  const Eigen::Vector3d rpy = rpy_deg * kPi / 180.0;
  c->error.R_SB = QuatFromEuler(rpy(0), rpy(1), rpy(2)).toRotationMatrix().transpose();
  const double det = c->error.soft_iron.determinant();
  if (!(det > 1e-6)) {
    r.Fail("soft_iron", fmt::format("must be invertible with positive determinant (got det {})", det));
  }
}

void ReadGps(YamlReader& r, GpsParams* g) {
  r.Opt("rate_hz", &g->rate_hz, Positive());
  r.Opt("latency_s", &g->latency_s, InRange(0.0, 5.0));
  r.Child("horizontal", [&](YamlReader& c) { ReadNoise(c, "m", g->rate_hz, &g->horizontal_m); });
  r.Child("vertical", [&](YamlReader& c) { ReadNoise(c, "m", g->rate_hz, &g->vertical_m); });
  r.Child("velocity", [&](YamlReader& c) { ReadNoise(c, "mps", g->rate_hz, &g->velocity_mps); });
}

void ReadBattery(YamlReader& r, BatteryParams* b) {
  r.Req("cells_series", &b->cells_series, InRange(1, 100));
  r.Req("capacity_Ah", &b->capacity_Ah, Positive());
  r.Req("internal_resistance_ohm", &b->internal_resistance_ohm, NonNegative());
  r.Opt("ocv_soc", &b->ocv_soc, InRange(0.0, 1.0));
  r.Opt("ocv_cell_V", &b->ocv_cell_V, InRange(0.5, 5.0));
  r.Opt("initial_soc", &b->initial_soc, InRange(0.0, 1.0));
  // The continuous discharge limit: as a current, or as a C rating (times capacity_Ah).
  if (r.Has("max_current_A") && r.Has("c_rating")) {
    return r.Fail("c_rating", "give either max_current_A or c_rating, not both");
  }
  r.Opt("max_current_A", &b->max_current_A, Positive());
  double c_rating = 0.0;
  r.Opt("c_rating", &c_rating, Positive());
  if (!r.ok()) return;
  if (c_rating > 0.0) b->max_current_A = c_rating * b->capacity_Ah;
  if (b->ocv_soc.size() < 2 || b->ocv_soc.size() != b->ocv_cell_V.size()) {
    return r.Fail("ocv_cell_V", fmt::format("needs as many entries as ocv_soc, at least 2 (got {} and {})",
                                            b->ocv_cell_V.size(), b->ocv_soc.size()));
  }
  for (size_t i = 1; i < b->ocv_soc.size(); ++i) {
    if (!(b->ocv_soc[i] > b->ocv_soc[i - 1])) return r.Fail("ocv_soc", "must be strictly ascending");
    if (b->ocv_cell_V[i] < b->ocv_cell_V[i - 1]) return r.Fail("ocv_cell_V", "must not decrease with SoC");
  }
}

}  // namespace

Result<VehicleParams> ParseVehicle(const YAML::Node& root, const std::string& file) {
  VehicleParams p;
  YamlReader r(root, file);
  // A vehicle file may carry its tuned gains: `control:` and `nav:` are read by
  // control::ParseControllerParams and nav::ParseNavParams (see sim::LoadRunSetup).
  r.Ignore("control");
  r.Ignore("nav");
  r.Req("name", &p.name);
  r.Req("mass_kg", &p.mass_kg, Positive());
  ReadInertia(r, &p.inertia_kgm2);

  r.Child("motor", [&](YamlReader& m) {
    m.Req("kv_rpm_per_V", &p.motor.kv_rpm_per_V, Positive());
    m.Req("winding_resistance_ohm", &p.motor.winding_resistance_ohm, Positive());
    m.Req("no_load_current_A", &p.motor.no_load_current_A, NonNegative());
    m.Req("inertia_kgm2", &p.motor.inertia_kgm2, Positive());
  }, /*required=*/true);

  RotorDefaults defaults;
  r.Child("rotor_defaults", [&](YamlReader& d) {
    double v = 0.0;
    if (d.Has("k_T_Nprps2")) { d.Opt("k_T_Nprps2", &v, Positive()); defaults.k_T = v; } else d.Opt("k_T_Nprps2", &v);
    if (d.Has("k_Q_Nmprps2")) { d.Opt("k_Q_Nmprps2", &v, Positive()); defaults.k_Q = v; } else d.Opt("k_Q_Nmprps2", &v);
    if (d.Has("inertia_kgm2")) { d.Opt("inertia_kgm2", &v, NonNegative()); defaults.inertia = v; } else d.Opt("inertia_kgm2", &v);
    ReadAxis(d, "axis_B", &defaults.axis_B);
  });
  r.ForEach("rotors", [&](YamlReader& item, size_t) {
    RotorParams rotor;
    ReadRotor(item, defaults, &rotor);
    p.rotors.push_back(rotor);
  }, /*required=*/true);

  r.Child("esc", [&](YamlReader& e) {
    e.Opt("efficiency", &p.esc.efficiency, Bound{0.0, 1.0, true, false});
    e.Opt("duty_min", &p.esc.duty_min, InRange(0.0, 1.0));
    e.Opt("duty_max", &p.esc.duty_max, InRange(0.0, 1.0));
    e.Opt("current_limit_A", &p.esc.current_limit_A, Positive());
    e.Opt("spool_up_time_s", &p.esc.spool_up_time_s, InRange(0.0, 10.0));
    if (e.ok() && !(p.esc.duty_max > p.esc.duty_min)) {
      e.Fail("duty_max", fmt::format("must be > duty_min {} (got {})", p.esc.duty_min, p.esc.duty_max));
    }
  });
  r.Child("battery", [&](YamlReader& b) { ReadBattery(b, &p.battery); }, /*required=*/true);
  r.Opt("avionics_current_A", &p.avionics_current_A, NonNegative());
  if (r.ok() && !(p.battery.max_current_A > p.avionics_current_A)) {
    r.Fail("battery", fmt::format("max_current_A {} must exceed avionics_current_A {}", p.battery.max_current_A,
                                  p.avionics_current_A));
  }

  r.Child("drag", [&](YamlReader& d) {
    auto read = [&](const char* key, Eigen::Vector3d* v) {
      d.Opt(key, v);
      if (d.ok() && v->minCoeff() < 0.0) d.Fail(key, fmt::format("must be >= 0 on every axis (got {})", v->minCoeff()));
    };
    read("linear_Nspm", &p.drag.linear_Nspm);
    read("quadratic_Ns2pm2", &p.drag.quadratic_Ns2pm2);
    read("rotational_Nmsprad", &p.drag.rotational_Nmsprad);
    read("rotational_quad_Nms2prad2", &p.drag.rotational_quad_Nms2prad2);
  });
  r.Child("aero", [&](YamlReader& a) {
    a.Opt("rotor_drag_N_per_radps_mps", &p.aero.rotor_drag_N_per_radps_mps, NonNegative());
    a.Opt("ground_effect_radius_m", &p.aero.ground_effect_radius_m, NonNegative());
  });
  r.Child("payload", [&](YamlReader& pl) {
    pl.Opt("mass_kg", &p.payload.mass_kg, NonNegative());
    pl.Opt("attach_B_m", &p.payload.attach_B_m);
    pl.Opt("tether_length_m", &p.payload.tether_length_m, NonNegative());
  });

  // Wiring refers to rotors by number, so rotors must be read first (they are, above).
  r.Child("wiring", [&](YamlReader& w) { ReadWiring(w, p.rotors.size(), &p.wiring); });
  r.ForEach("compasses", [&](YamlReader& c, size_t) {
    CompassParams compass;
    ReadCompass(c, &compass);
    p.compasses.push_back(compass);
  });
  if (r.ok()) {
    for (size_t i = 0; i < p.compasses.size(); ++i) {
      for (size_t j = 0; j < i; ++j) {
        if (p.compasses[i].name == p.compasses[j].name) {
          r.Fail("compasses", fmt::format("compass name '{}' is used twice", p.compasses[i].name));
        }
      }
    }
  }
  r.Child("sensors", [&](YamlReader& s) {
    s.Child("gyro", [&](YamlReader& g) { ReadImu(g, "radps", &p.sensors.gyro); });
    s.Child("accel", [&](YamlReader& a) { ReadImu(a, "mps2", &p.sensors.accel); });
    s.Child("gps", [&](YamlReader& g) { ReadGps(g, &p.sensors.gps); });
    s.Child("baro", [&](YamlReader& b) {
      b.Opt("rate_hz", &p.sensors.baro.rate_hz, Positive());
      ReadNoise(b, "m", p.sensors.baro.rate_hz, &p.sensors.baro.noise_m);
    });
  });
  HEXSIM_RETURN_IF_ERROR(r.Finish());
  return p;
}

Result<VehicleParams> LoadVehicleFile(const std::string& path) {
  Result<YAML::Node> doc = YamlReader::LoadFile(path);
  if (!doc.ok()) return doc.status();
  return ParseVehicle(*doc, path);
}

}  // namespace hexsim::vehicle
