"""Independent reference for the motor-current effect on each compass of a real log.

Model over the flight window, stacked over the three axes (9 unknowns, ordinary least squares):
    m(t) = R_NB(t)^T B_N + c + k * I(t)
m the logged compass vector (body, uT; ArduPilot's logged motor compensation MOfs taken back out, so
k is the absolute current effect whatever COMPASS_MOTCT was), R_NB the logged attitude, B_N the earth field in NED
(fitted), c a body offset, k a 3-vector (uT/A) and I the logged battery current (A).
Where the current is unusable the same fit is made with the normalised mean motor output u in
place of I (k then in uT per unit output, ArduPilot's COMPASS_MOTCT 1 form).
The current is aligned to the compass by the reference's own residual: I(t + s) with the shift s
in 0..MAX_SHIFT_S that minimises the stacked fit's residual sum of squares (a logged current that
trails the field it causes - a battery monitor's filter, a stale sample - is a mis-timed regressor,
and a mis-timed regressor biases k toward zero: log171 MAG2 and MAG3 both fit best 0.25-0.3 s
later, residual 2.47 -> 2.24 uT on MAG3, and k at shift 0 was 40 % low). The interval is taken at
the chosen shift (the shift's own uncertainty is not propagated).
Intervals: moving-block bootstrap over 10-s blocks of the flight window, 400 replicates,
2.5/97.5 percentiles. numpy and the readers beside this file only; nothing from hexsim.

usage: reference.py [--json OUT.json] [--md OUT.md] LOG...
       reference.py --selftest   (synthetic flight with a known k and with none; exit 1 on a miss)
"""

import argparse
import json
import os
import sys

import numpy as np

import extract

BLOCK_S = 10.0
REPLICATES = 400
SEED = 29
MIN_AMPS_PER_MOTOR = 0.5      # issue 29 item 1: a flying motor draws more than this
MIN_VOLTS_PER_CELL = 2.5      # a LiPo cell under load never reads below this
MIN_VOLTS_UNKNOWN_CELLS = 3.0
# physical range of |k|: a compass 2 cm from a 20 A lead sees ~200 uT = 2000 mG at most,
# spread over the pack current; beyond 200 mG/A the fit is a model mismatch, not a finding
K_RANGE_MG_PER_A = (0.0, 200.0)
K_RANGE_MG_PER_OUTPUT = (0.0, 5000.0)   # per unit motor output (0..1)
MIN_FIT_SAMPLES = 40       # 120 equations for 9 unknowns (PX4 logs sensor_mag at 1 Hz)
# The current's alignment: a battery monitor's lag is a few samples of its 5-10 Hz stream at most.
MAX_SHIFT_S = 0.5
SHIFT_STEP_S = 0.05


def current_usability(f):
    """dict(usable, text, amps, volts) over the flight window."""
    if f.cur_a is None or not len(f.cur_a):
        return {"usable": False, "text": "none logged", "amps": None, "volts": None,
                "reason": "no current logged"}
    m = extract.in_segments(f.cur_t, f.segs)
    whole = {"amps_all": float(np.median(f.cur_a)), "volts_all": float(np.median(f.volt_v))}
    if not m.any():
        return dict(whole, usable=False, text="no flight window", amps=None, volts=None,
                    reason="no flight window")
    amps, volts = float(np.median(f.cur_a[m])), float(np.median(f.volt_v[m]))
    motors = f.motors or 4
    reasons = []
    if amps / motors < MIN_AMPS_PER_MOTOR:
        reasons.append("%.2f A per motor < %.1f" % (amps / motors, MIN_AMPS_PER_MOTOR))
    if f.cells:
        if volts / f.cells < MIN_VOLTS_PER_CELL:
            reasons.append("%.2f V per cell < %.1f" % (volts / f.cells, MIN_VOLTS_PER_CELL))
    elif volts < MIN_VOLTS_UNKNOWN_CELLS:
        reasons.append("%.2f V < %.1f (cells unknown)" % (volts, MIN_VOLTS_UNKNOWN_CELLS))
    usable = not reasons
    text = "%.1f A, %.1f V: %s" % (amps, volts, "usable" if usable else
                                   "unusable (" + "; ".join(reasons) + ")")
    return dict(whole, usable=usable, text=text, amps=amps, volts=volts,
                reason="; ".join(reasons))


def interp(t_src, v_src, t):
    return np.interp(t, t_src, v_src, left=np.nan, right=np.nan)


def design(rt, x):
    """Rows of the stacked system for samples with rotations R^T (N,3,3) and regressor x (N)."""
    n = len(x)
    a = np.zeros((n, 3, 9))
    a[:, :, 0:3] = rt
    a[:, :, 3:6] = np.eye(3)
    a[:, :, 6:9] = np.eye(3)[None, :, :] * x[:, None, None]
    return a


def solve(a, y):
    sol, *_ = np.linalg.lstsq(a.reshape(-1, 9), y.reshape(-1), rcond=None)
    return sol


def sse(a, y):
    sol = solve(a, y)
    return float(np.sum((y - np.einsum("nij,j->ni", a, sol)) ** 2))


def align_current(t, y, rt, t_src, v_src):
    """(shift_s, x): the current at t + shift, shift minimising the fit's residual (module doc)."""
    best = None
    for shift in np.arange(0.0, MAX_SHIFT_S + 1e-9, SHIFT_STEP_S):
        x = interp(t_src, v_src, t + shift)
        sel = np.isfinite(x)
        if sel.sum() < MIN_FIT_SAMPLES or np.ptp(x[sel]) <= 0:
            continue
        e = sse(design(rt[sel], x[sel]), y[sel]) / sel.sum()
        if best is None or e < best[0]:
            best = (e, float(shift))
    shift = best[1] if best else 0.0
    return shift, interp(t_src, v_src, t + shift)


def fit(t, y, rt, x):
    a = design(rt, x)
    sol = solve(a, y)
    res = y - np.einsum("nij,j->ni", a, sol)
    base = a[:, :, :6]
    sol0, *_ = np.linalg.lstsq(base.reshape(-1, 6), y.reshape(-1), rcond=None)
    res0 = y - np.einsum("nij,j->ni", base, sol0)
    share = 1.0 - float(np.sum(res ** 2) / np.sum(res0 ** 2)) if np.sum(res0 ** 2) > 0 else 0.0
    # moving-block bootstrap over the flight window's blocks
    blocks = np.floor((t - t[0]) / BLOCK_S).astype(int)
    ids = np.unique(blocks)
    members = [np.nonzero(blocks == b)[0] for b in ids]
    rng = np.random.default_rng(SEED)
    ks = []
    for _ in range(REPLICATES):
        pick = rng.integers(0, len(members), len(members))
        idx = np.concatenate([members[p] for p in pick])
        if np.ptp(x[idx]) <= 0:
            continue
        ks.append(solve(a[idx], y[idx])[6:9])
    ks = np.array(ks)
    k = sol[6:9]
    norms = np.linalg.norm(ks, axis=1)
    lo_c, hi_c = np.percentile(ks, 2.5, axis=0), np.percentile(ks, 97.5, axis=0)
    zero_inside = bool(np.all((lo_c <= 0) & (hi_c >= 0)))
    # a norm's percentile interval never reaches 0; where every component's does, |k| can be 0
    return {"k": k.tolist(), "k_norm": float(np.linalg.norm(k)),
            "k_norm_lo": 0.0 if zero_inside else float(np.percentile(norms, 2.5)),
            "k_norm_hi": float(np.percentile(norms, 97.5)),
            "k_lo": lo_c.tolist(), "k_hi": hi_c.tolist(),
            "zero_inside": zero_inside,
            "field_ned_uT": sol[0:3].tolist(), "offset_uT": sol[3:6].tolist(),
            "explained_share": share, "residual_rms_uT": float(np.sqrt(np.mean(res ** 2))),
            "samples": int(len(t)), "blocks": int(len(ids)), "replicates": int(len(ks))}


def analyse_compass(f, c, cur):
    t = c["t"]
    m = extract.in_segments(t, f.segs)
    out = {"compass": c["name"], "external": c["external"], "use": c["use"],
           "motct": c["motct"], "mot": c["mot"]}
    if not len(t) or np.ptp(c["xyz"], axis=0).max() <= 0:
        out["status"] = "compass not logged (constant)"
        return out
    t, y = t[m], c["xyz"][m]
    att_idx = np.clip(np.searchsorted(f.att_t, t), 0, len(f.att_t) - 1)
    rt = np.transpose(f.att_r[att_idx], (0, 2, 1))
    ok = np.abs(f.att_t[att_idx] - t) < 0.2
    forms, shifts = {}, {}
    if f.cur_a is not None and len(f.cur_a):
        base = ok & np.isfinite(interp(f.cur_t, f.cur_a, t))
        shift, x = align_current(t[base], y[base], rt[base], f.cur_t, f.cur_a)
        forms["current"], shifts["current"] = interp(f.cur_t, f.cur_a, t + shift), shift
    if f.thr is not None:
        forms["output"] = interp(f.thr_t, f.thr, t)
    out["status"] = "fitted"
    for name, x in forms.items():
        sel = ok & np.isfinite(x)
        if sel.sum() < MIN_FIT_SAMPLES or np.ptp(x[sel]) <= 0:
            out[name] = {"status": "too few samples (%d) or no variation" % sel.sum()}
            continue
        r = fit(t[sel], y[sel], rt[sel], x[sel])
        if name in shifts:
            r["current_shift_s"] = shifts[name]
        scale = 10.0  # uT -> mG
        unit = "mG/A" if name == "current" else "mG per unit output"
        rng = K_RANGE_MG_PER_A if name == "current" else K_RANGE_MG_PER_OUTPUT
        r.update({"unit": unit, "k_mg": [v * scale for v in r["k"]],
                  "k_norm_mg": r["k_norm"] * scale, "k_norm_lo_mg": r["k_norm_lo"] * scale,
                  "k_norm_hi_mg": r["k_norm_hi"] * scale,
                  "in_range": rng[0] <= r["k_norm"] * scale <= rng[1],
                  "status": "fitted"})
        if name == "current":
            r["usable"] = cur["usable"]
        out[name] = r
    return out


def analyse(path):
    f = extract.read(path)
    cur = current_usability(f)
    return {"log": path, "version": f.version, "frame": f.frame, "motors": f.motors,
            "flight_s": sum(b - a for a, b in f.segs), "current": cur,
            "compasses": [analyse_compass(f, c, cur) for c in f.compasses]}


def fmt_interval(r):
    if not r or r.get("status") != "fitted":
        return (r or {}).get("status", "-")
    flag = "" if r["in_range"] else " (outside range: model mismatch)"
    zero = ", 0 inside" if r["zero_inside"] else ""
    return "%.1f [%.1f, %.1f]%s%s" % (r["k_norm_mg"], r["k_norm_lo_mg"], r["k_norm_hi_mg"], zero,
                                      flag)


def markdown(results):
    rows = ["| log | compass | ext | current in flight | reference norm of k, mG/A [95 %] | share | "
            "output form mG/unit [95 %] |", "|---|---|---|---|---|---|---|"]
    for res in results:
        if "error" in res:
            rows.append("| %s | - | - | %s | - | - | - |" % (os.path.basename(res["log"]),
                                                              res["error"]))
            continue
        for c in res["compasses"]:
            if c["status"] != "fitted":
                continue
            cr, orr = c.get("current"), c.get("output")
            share = "%.0f %%" % (100 * cr["explained_share"]) if cr and "explained_share" in cr \
                else "-"
            rows.append("| %s | %s | %s | %s | %s | %s | %s |" % (
                os.path.basename(res["log"]), c["compass"],
                {None: "?", True: "ext", False: "int"}[c["external"]], res["current"]["text"],
                fmt_interval(cr), share, fmt_interval(orr)))
    return "\n".join(rows) + "\n"


def selftest():
    """The fit on a synthetic flight with a known k, and with none: exit 1 when it misses."""
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 150.0, 0.1)
    roll = np.radians(15) * np.sin(0.31 * t) + np.radians(3) * rng.standard_normal(len(t))
    pitch = np.radians(12) * np.sin(0.23 * t + 1.0)
    yaw = 0.05 * t
    rt = np.transpose(extract.euler_to_r(roll, pitch, yaw), (0, 2, 1))
    cur = 15 + 6 * np.sin(0.11 * t) + np.cumsum(rng.standard_normal(len(t))) * 0.1
    field, offset = np.array([20.0, 2.0, -45.0]), np.array([10.0, -5.0, 30.0])
    ok = True
    # a logged current 0.3 s late: the alignment finds the shift and k, the unaligned fit is low
    k_true = np.array([0.3, -0.4, 0.2])
    fast = 15 + 6 * np.sin(0.11 * t) + 4 * np.sin(1.7 * t) + 3 * np.sin(2.9 * t + 1)
    y = rt @ field + offset + np.outer(fast, k_true) + 0.3 * rng.standard_normal((len(t), 3))
    logged_t = t + 0.3                       # the sample of time t is stamped 0.3 s later
    shift, x = align_current(t, y, rt, logged_t, fast)
    sel = np.isfinite(x)
    r = fit(t[sel], y[sel], rt[sel], x[sel])
    r0 = fit(t, y, rt, np.interp(t, logged_t, fast))
    truth = np.linalg.norm(k_true)
    good = abs(shift - 0.3) < 1e-6 and r["k_norm_lo"] <= truth <= r["k_norm_hi"] and r0["k_norm_hi"] < truth
    sys.stderr.write("reference selftest: current 0.3 s late: shift %.2f s, |k| %.3f [%.3f, %.3f] "
                     "(unaligned %.3f), truth %.3f: %s\n" % (shift, r["k_norm"], r["k_norm_lo"],
                                                            r["k_norm_hi"], r0["k_norm"], truth,
                                                            "ok" if good else "MISSED"))
    ok = ok and good
    for k_true in (np.array([0.3, -0.4, 0.2]), np.zeros(3)):
        y = rt @ field + offset + np.outer(cur, k_true) + 0.5 * rng.standard_normal((len(t), 3))
        r = fit(t, y, rt, cur)
        truth = np.linalg.norm(k_true)
        good = r["k_norm_lo"] <= truth <= r["k_norm_hi"] and abs(r["k_norm"] - truth) < 0.05
        good = good and r["zero_inside"] == (truth == 0)
        sys.stderr.write("reference selftest: |k| %.3f uT/A, fitted %.3f [%.3f, %.3f]: %s\n" % (
            truth, r["k_norm"], r["k_norm_lo"], r["k_norm_hi"], "ok" if good else "MISSED"))
        ok = ok and good
    return 0 if ok else 1


def main():
    if sys.argv[1:] == ["--selftest"]:
        sys.exit(selftest())
    ap = argparse.ArgumentParser()
    ap.add_argument("logs", nargs="+")
    ap.add_argument("--json")
    ap.add_argument("--md")
    a = ap.parse_args()
    results = []
    for p in a.logs:
        try:
            results.append(analyse(p))
        except Exception as e:  # one row per log whatever breaks
            results.append({"log": p, "error": "%s: %s" % (type(e).__name__, e)})
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(results, fh, indent=1)
    md = markdown(results)
    if a.md:
        with open(a.md, "w") as fh:
            fh.write(md)
    sys.stdout.write(md)


if __name__ == "__main__":
    main()
