// ControllerParams <-> the `control:` YAML map.
#include <cmath>

#include "hexsim/control/control_io.h"

namespace hexsim::control {
namespace {

void ReadPid(YamlReader& r, PidGains* g) {
  r.Opt("kp", &g->kp, NonNegative());
  r.Opt("ki", &g->ki, NonNegative());
  r.Opt("kd", &g->kd, NonNegative());
  r.Opt("output_limit", &g->output_limit, Positive());
  r.Opt("integrator_limit", &g->integrator_limit, NonNegative());
  r.Opt("d_filter_hz", &g->d_filter_hz, NonNegative());
}

YAML::Node PidYaml(const PidGains& g) {
  YAML::Node n;
  n["kp"] = g.kp;
  n["ki"] = g.ki;
  n["kd"] = g.kd;
  n["output_limit"] = g.output_limit;
  n["integrator_limit"] = g.integrator_limit;
  n["d_filter_hz"] = g.d_filter_hz;
  return n;
}

}  // namespace

Status ParseControllerParams(YamlReader& r, ControllerParams* p) {
  r.Child("pos", [&](YamlReader& c) {
    c.Opt("kp", &p->pos_xy_kp, NonNegative());
    c.Opt("z_kp", &p->pos_z_kp, NonNegative());
  });
  r.Child("vel", [&](YamlReader& c) {
    c.Child("xy", [&](YamlReader& g) { ReadPid(g, &p->vel_xy); });
    c.Child("z", [&](YamlReader& g) { ReadPid(g, &p->vel_z); });
  });
  r.Child("att", [&](YamlReader& c) {
    c.Child("roll", [&](YamlReader& g) { g.Opt("kp", &p->att_roll_kp, NonNegative()); });
    c.Child("pitch", [&](YamlReader& g) { g.Opt("kp", &p->att_pitch_kp, NonNegative()); });
    c.Child("yaw", [&](YamlReader& g) { g.Opt("kp", &p->att_yaw_kp, NonNegative()); });
  });
  r.Child("rate", [&](YamlReader& c) {
    c.Child("roll", [&](YamlReader& g) { ReadPid(g, &p->rate_roll); });
    c.Child("pitch", [&](YamlReader& g) { ReadPid(g, &p->rate_pitch); });
    c.Child("yaw", [&](YamlReader& g) { ReadPid(g, &p->rate_yaw); });
  });
  r.Child("limits", [&](YamlReader& c) {
    c.Opt("max_tilt_deg", &p->max_tilt_deg, Bound{0.0, 89.0, true, false});
    c.Opt("max_speed_xy_mps", &p->max_speed_xy_mps, Positive());
    c.Opt("max_speed_up_mps", &p->max_speed_up_mps, Positive());
    c.Opt("max_speed_down_mps", &p->max_speed_down_mps, Positive());
    c.Opt("max_rate_rp_dps", &p->max_rate_rp_dps, Positive());
    c.Opt("max_yaw_rate_dps", &p->max_yaw_rate_dps, Positive());
    c.Opt("min_thrust_fraction_of_weight", &p->min_thrust_fraction_of_weight, InRange(0.0, 1.0));
  });
  return r.Finish();
}

YAML::Node ControllerParamsToYaml(const ControllerParams& p) {
  YAML::Node n;
  n["pos"]["kp"] = p.pos_xy_kp;
  n["pos"]["z_kp"] = p.pos_z_kp;
  n["vel"]["xy"] = PidYaml(p.vel_xy);
  n["vel"]["z"] = PidYaml(p.vel_z);
  n["att"]["roll"]["kp"] = p.att_roll_kp;
  n["att"]["pitch"]["kp"] = p.att_pitch_kp;
  n["att"]["yaw"]["kp"] = p.att_yaw_kp;
  n["rate"]["roll"] = PidYaml(p.rate_roll);
  n["rate"]["pitch"] = PidYaml(p.rate_pitch);
  n["rate"]["yaw"] = PidYaml(p.rate_yaw);
  YAML::Node l = n["limits"];
  l["max_tilt_deg"] = p.max_tilt_deg;
  l["max_speed_xy_mps"] = p.max_speed_xy_mps;
  l["max_speed_up_mps"] = p.max_speed_up_mps;
  l["max_speed_down_mps"] = p.max_speed_down_mps;
  l["max_rate_rp_dps"] = p.max_rate_rp_dps;
  l["max_yaw_rate_dps"] = p.max_yaw_rate_dps;
  l["min_thrust_fraction_of_weight"] = p.min_thrust_fraction_of_weight;
  return n;
}

}  // namespace hexsim::control
