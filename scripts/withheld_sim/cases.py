"""Drawing withheld cases and planting them in a copy of a shipped vehicle file.

Every planted effect goes through the vehicle file's own keys (vehicle/io/src/vehicle_io.cc
ReadCompass/ReadWiring), except the compass latency: no vehicle-file key delays a compass (hexsim's
simulated compasses are stamped at their measurement epoch; DiagnoseOptions::compass_latency_s says
the vehicle models 0), so, as the selftest does (gap/src/selftest_real.cc DegradeToRealLog), the
latency is planted in the flown log: each compass row carries the newest sample whose delayed stamp
has passed, with that stamp.

Sizes are drawn independently of the selftest's (gap/src/selftest.cc RealInjectableEffects,
selftest_forms.cc), over wider ranges a real aircraft shows; each range's reason is beside it.
"""
import copy
import math

import numpy as np

import physics

VEHICLES = ["quad_x", "paper_hex", "octo_x"]
MISSIONS = ["square", "figure_eight", "lawnmower", "climb_cruise_square", "payload_change", "selftest_flight"]

# Physical ranges of the planted sizes (the maintainers' stated forms, widened):
#   scale_error: one sensor axis' gain off by 2..15 % (an uncalibrated or badly calibrated chip);
#   misalignment: 1..8 deg (a board or mast mounted askew);
#   latency: 20..150 ms (driver queues and bus polling of real autopilots);
#   current_hard_iron: 0.5..10 mG/A = 0.05..1 uT/A (an external mast to a compass beside the PDB);
#   current lag: 0.2..1.5 s (eddy currents in a frame plate, a slow current sensor's filter);
#   exponent: 1.2..2.2 (a field growing faster than the current: saturating ferrite, heating);
#   current_soft_iron: 0.001..0.01 per A (a permeable part magnetised by the wiring);
#   hard_iron: 10..40 uT change of the constant offset (a new screw, a magnetised part).
RANGES = {
    "scale_error": (0.02, 0.15),
    "misalignment": (1.0, 8.0),
    "latency": (0.02, 0.15),
    "current_hard_iron": (0.5, 10.0),   # mG/A
    "per_motor_current": (1.0, 10.0),   # mG/A of the motor's own current at the compass
    "lagged_current": (0.2, 1.5),       # lag s; its field 2..10 mG/A
    "lagged_power": (0.2, 1.5),         # lag s; exponent 1.2..2.2; field 2..10 mG/A at hover
    "current_soft_iron": (0.001, 0.01),
    "hard_iron": (10.0, 40.0),
}
CURRENT_NAMES = ["current_hard_iron", "per_motor_current_hard_iron", "current_lag"]
SINGLE_FORMS = list(RANGES)
PAIR_FORMS = [("scale_error", "current_hard_iron"), ("misalignment", "latency"), ("latency", "current_hard_iron"),
              ("scale_error", "latency"), ("misalignment", "current_soft_iron"), ("lagged_current", "scale_error"),
              ("misalignment", "current_hard_iron")]


# The balanced order: every form in turn (two clean slots per round), the rest of a case drawn.
BALANCED = ["clean"] + SINGLE_FORMS[:5] + ["clean"] + SINGLE_FORMS[5:] + PAIR_FORMS


def draw_case(rng, index, forms=None):
    """One case: vehicle, mission, world, attitude source, log form, target compass and its effects."""
    vehicle = VEHICLES[rng.integers(len(VEHICLES))]
    case = {
        "id": index,
        "seed": int(rng.integers(1, 2**31 - 1)),
        "vehicle": vehicle,
        "mission": MISSIONS[rng.integers(len(MISSIONS))],
        # Wind and turbulence on or off: a mean wind 0..8 m/s from any direction, turbulence 0..1.5 m/s.
        "wind": None if rng.random() < 0.5 else {
            "speed_mps": round(float(rng.uniform(1.0, 8.0)), 2),
            "from_deg": round(float(rng.uniform(0, 360)), 1),
            "turbulence_std_mps": round(float(rng.uniform(0.0, 1.5)), 2)},
        # The log as hexsim run writes it (every row, per-motor currents), or as a real autopilot
        # logs it: 10 Hz rows, the current updated at 5 Hz, no per-motor currents.
        "log_form": "sim" if rng.random() < 0.5 else "real10hz",
    }
    order = forms or BALANCED
    chosen = order[index % len(order)]
    effects = list(chosen) if isinstance(chosen, tuple) else ([] if chosen == "clean" else [chosen])
    case["effects"] = [{"form": f} for f in effects]
    case["form"] = "+".join(effects) if effects else "clean"
    return case


def target_compass(vehicle_doc, rng):
    """The compass the effects are planted on: an internal one where the vehicle has several (the
    first compass is the one an autopilot's filter fuses), else the only one."""
    comps = vehicle_doc["compasses"]
    if len(comps) == 1:
        return 0
    return int(1 + rng.integers(len(comps) - 1))


def _motor_count(doc):
    return len(doc["rotors"])


def _scale_wiring_for_exponent(doc, p, hover_batt_A):
    """Exponent p on the whole wiring, with each segment's share and each dipole's moment rescaled so
    that at hover current the field is the modelled one: the file's field grows faster than the
    current around the operating point instead of jumping by I^(p-1)."""
    n = _motor_count(doc)
    hover_motor_A = max(0.5, hover_batt_A / n)
    w = doc["wiring"]
    w["exponent"] = round(p, 4)
    for s in w.get("segments", []):
        ref = hover_motor_A if s.get("source") == "motor" else hover_batt_A
        s["share"] = float(s.get("share", 1.0)) * ref ** (1.0 / p - 1.0)
    for d in w.get("dipoles", []):
        d["moment_per_A_Am2"] = [float(v) * hover_motor_A ** (1.0 - p) for v in d["moment_per_A_Am2"]]


def plant(doc, ci, eff, rng, hover_batt_A):
    """Plants one effect on compass ci of the vehicle document; fills eff with its truth:
    accept (names that count as right), magnitude (in the effect's gap.json unit) and lag_s."""
    form = eff["form"]
    comp = doc["compasses"][ci]
    M = physics.compass_gain(comp)
    lo, hi = RANGES[form]
    if form == "scale_error":
        s = float(rng.uniform(lo, hi)) * (1 if rng.random() < 0.75 else -1)
        ax = int(rng.integers(3))
        R = physics.compass_r_sb(comp)
        D = np.eye(3)
        D[ax, ax] += s
        K = np.array(comp.get("soft_iron", np.eye(3).tolist()), dtype=float)
        comp["soft_iron"] = (R.T @ D @ R @ K).round(6).tolist()  # R_SB·K' = D·R_SB·K: sensor axis ax
        eff.update(size=f"{s:+.3f} on {'xyz'[ax]}", accept=["scale_error"], magnitude=abs(s), unit="1", axis="xyz"[ax])
    elif form == "misalignment":
        th = float(rng.uniform(lo, hi))
        R_sb = physics.axis_angle(physics.random_unit(rng), math.radians(th)) @ physics.compass_r_sb(comp)
        comp["orientation_rpy_deg"] = [round(v, 6) for v in physics.rpy_deg_from_r_nb(R_sb.T)]
        th_true = physics.rotation_angle_deg(physics.compass_r_sb(comp) @ physics.compass_r_sb(doc["_orig"][ci]).T)
        eff.update(size=f"{th_true:.2f} deg", accept=["misalignment"], magnitude=th_true, unit="deg")
    elif form == "latency":
        L = float(rng.uniform(lo, hi))
        eff.update(size=f"{1000 * L:.0f} ms", accept=["latency"], magnitude=L, unit="s", log_latency_s=L)
    elif form == "current_hard_iron":
        k = float(rng.uniform(lo, hi))  # mG/A
        a, b, got = physics.segment_near(comp["position_B_m"], k / 10.0, M, rng)
        doc["wiring"].setdefault("segments", []).append(
            {"name": "withheld", "a_B_m": a.round(6).tolist(), "b_B_m": b.round(6).tolist(), "source": "battery"})
        eff.update(size=f"{10 * got:.2f} mG/A", accept=["current_hard_iron", "per_motor_current_hard_iron"],
                   magnitude=got, unit="uT/A", magnitude_effect="current_hard_iron")
    elif form == "per_motor_current":
        k = float(rng.uniform(lo, hi))
        m = int(1 + rng.integers(_motor_count(doc)))
        a, b, got = physics.segment_near(comp["position_B_m"], k / 10.0, M, rng)
        doc["wiring"].setdefault("segments", []).append(
            {"name": "withheld", "a_B_m": a.round(6).tolist(), "b_B_m": b.round(6).tolist(), "source": "motor", "motor": m})
        eff.update(size=f"{10 * got:.2f} mG/A of motor {m}", accept=CURRENT_NAMES, magnitude=None)
    elif form in ("lagged_current", "lagged_power"):
        tau = float(rng.uniform(lo, hi))
        k = float(rng.uniform(2.0, 10.0))
        a, b, got = physics.segment_near(comp["position_B_m"], k / 10.0, M, rng)
        seg = {"name": "withheld", "a_B_m": a.round(6).tolist(), "b_B_m": b.round(6).tolist(), "source": "battery"}
        doc["wiring"].setdefault("segments", []).append(seg)
        size = f"{10 * got:.1f} mG/A, lag {tau:.2f} s"
        if form == "lagged_current":
            comp["current_lag_tau_s"] = round(tau, 4)  # this compass sees the currents through a lag
        else:
            p = float(rng.uniform(1.2, 2.2))
            doc["wiring"]["lag_tau_s"] = round(tau, 4)
            _scale_wiring_for_exponent(doc, p, hover_batt_A)
            size += f", exponent {p:.2f}"
        eff.update(size=size, accept=CURRENT_NAMES, magnitude=None, lag_s=tau)
    elif form == "current_soft_iron":
        n = float(rng.uniform(lo, hi))
        D = rng.normal(size=(3, 3))
        D *= n / np.linalg.norm(D)
        comp["soft_iron_per_A"] = D.round(8).tolist()
        R = physics.compass_r_sb(comp)
        truth = np.linalg.norm(R @ (float(comp.get("scale", 1.0)) * D) @ np.linalg.inv(M))  # as selftest.cc
        eff.update(size=f"{truth:.4f} /A", accept=["current_soft_iron"], magnitude=truth, unit="1/A")
    elif form == "hard_iron":
        b = float(rng.uniform(lo, hi))
        d = physics.random_unit(rng) * b
        comp["hard_iron_uT"] = (np.array(comp.get("hard_iron_uT", [0, 0, 0]), dtype=float) + d).round(4).tolist()
        eff.update(size=f"{b:.1f} uT", accept=["hard_iron_offset"], magnitude=b, unit="uT")
    else:
        raise ValueError(f"unknown form {form}")


def planted_vehicle(base_doc, case, rng, hover_batt_A):
    doc = copy.deepcopy(base_doc)
    doc["_orig"] = copy.deepcopy(base_doc["compasses"])
    ci = target_compass(doc, rng)
    case["compass"] = ci
    case["channel"] = "mag" if ci == 0 else f"mag{ci + 1}"
    for eff in case["effects"]:
        plant(doc, ci, eff, rng, hover_batt_A)
    del doc["_orig"]
    return doc
