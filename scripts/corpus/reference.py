"""Independent reference for the motor-current effect on each compass of a real log.

Model over the flight window, stacked over the three axes (9 unknowns, ordinary least squares):
    m(t) = R_NB(t)^T B_N + c + k * I(t)
m the logged compass vector (body, uT; ArduPilot's logged motor compensation MOfs taken back out, so
k is the absolute current effect whatever COMPASS_MOTCT was), R_NB the logged attitude, B_N the earth field in NED
(fitted), c a body offset, k a 3-vector (uT/A) and I the logged battery current (A).
Where the current is unusable the same fit is made with the normalised mean motor output u in
place of I (k then in uT per unit output, ArduPilot's COMPASS_MOTCT 1 form).
Timing. The attitude is interpolated at the compass sample's time (rotation matrices interpolated
linearly between the two neighbouring attitude samples and re-orthonormalised), never taken from one
neighbour: a vehicle yawing at 100-360 deg/s (PX4 log_66) turns 5-18 deg between 20 Hz attitude
samples, and a misplaced attitude is a field error correlated with the yaw manoeuvres and, through
them, with the current. Two delays are fitted by the stacked fit's own residual on one grid:
  L  the compass latency (a sample stamped t measured the field at t - L; LATENCY_GRID_S), and
  s  the current's staleness (the logged current trails the field it causes: the regressor is the
     current at t - L + s; 0..MAX_SHIFT_S).
A mis-timed attitude or current biases k: on a simulated quad yawing at up to 210 deg/s with a 2 Hz
compass 30 ms late, the nearest-later attitude without L read |k| 3.8 [3.0, 4.6] mG/A for a true
2.3, and 1.9 [1.1, 3.3] for an external compass with none; log171 MAG2 and MAG3 both fit best
with the current 0.25-0.3 s later (k at shift 0 was 40 % low).
Intervals: moving-block bootstrap over 10-s blocks of the flight window, 400 replicates,
2.5/97.5 percentiles, their distances from the point widened for the few blocks a short flight
holds (widening()); each replicate picks its own (L, s) by its own residual, so the timing's
uncertainty is in the interval (at 1-2 Hz compass rates it dominates it). numpy and the readers beside this file only; nothing from hexsim.

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
# The compass latency: a driver's queue and a logger's sampling put a compass sample 0-0.3 s after
# the field it measured (ArduPilot and PX4 logs: 10-100 ms); a negative value would mean the stamp
# precedes the measurement, which a small clock offset can do. Step 10 ms: k moves ~0.4 mG/A per
# 10 ms of misalignment on a fast-yawing log (log_66).
LATENCY_GRID_S = np.round(np.arange(-0.1, 0.3 + 1e-9, 0.01), 3)
ATT_GAP_S = 0.2            # the attitude is interpolated only between samples this close
BOOT_CHUNK = 50            # replicates solved at once (memory: chunk x grid x 81 floats)


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


def attitude_at(att_t, att_r, t):
    """R_NB (N, 3, 3) at times t: linear between the two neighbouring attitude samples,
    re-orthonormalised (the polar factor); NaN where t is outside them or they are ATT_GAP_S apart."""
    i = np.searchsorted(att_t, t)
    ok = (i > 0) & (i < len(att_t))
    i = np.clip(i, 1, len(att_t) - 1)
    t0, t1 = att_t[i - 1], att_t[i]
    ok &= (t1 - t0 <= ATT_GAP_S) & (t1 > t0)
    w = np.where(ok, (t - t0) / np.where(t1 > t0, t1 - t0, 1.0), 0.0)[:, None, None]
    u, _, vt = np.linalg.svd((1 - w) * att_r[i - 1] + w * att_r[i])
    r = u @ vt
    r[~ok] = np.nan
    return r


def _normal_sums(a, y, starts):
    """Per-block sums of the normal equations X'X, X'y of the stacked rows."""
    xx = np.einsum("nij,nik->njk", a, a)
    xy = np.einsum("nij,ni->nj", a, y)
    return np.add.reduceat(xx, starts, axis=0), np.add.reduceat(xy, starts, axis=0)


def _solve_batch(n, r):
    """theta and the residual sum of squares' variable part (-theta'r) for batched systems."""
    tr = np.trace(n, axis1=-2, axis2=-1)[..., None, None]
    ridge = 1e-12 * tr * np.eye(n.shape[-1])   # a replicate without the regressor's variation
    theta = np.linalg.solve(n + ridge, r[..., None])[..., 0]
    return theta, -np.einsum("...j,...j->...", theta, r)


def timed_fit(t, y, att, regressor, shifts):
    """The stacked fit with the compass latency L (LATENCY_GRID_S) and the regressor's shift s
    (`shifts`) chosen by the residual; the bootstrap re-chooses them per replicate (module doc).
    att(t) -> R_NB, regressor(t) -> values (NaN unknown). None when too few samples."""
    grid = [(lat, sh) for lat in LATENCY_GRID_S for sh in shifts]
    rts = {lat: np.transpose(att(t - lat), (0, 2, 1)) for lat in LATENCY_GRID_S}
    xs = [regressor(t - lat + sh) for lat, sh in grid]
    valid = np.all([np.isfinite(x) for x in xs], axis=0)
    valid &= np.all([np.isfinite(r).all(axis=(1, 2)) for r in rts.values()], axis=0)
    if valid.sum() < MIN_FIT_SAMPLES or np.ptp(xs[0][valid]) <= 0:
        return None
    t, y = t[valid], y[valid]
    blocks = np.floor((t - t[0]) / BLOCK_S).astype(int)
    starts = np.concatenate([[0], np.nonzero(np.diff(blocks))[0] + 1])
    yy = np.add.reduceat(np.sum(y * y, axis=1), starts)
    nb, rb = zip(*(_normal_sums(design(rts[lat][valid], x[valid]), y, starts)
                   for (lat, _), x in zip(grid, xs)))
    nb, rb = np.array(nb), np.array(rb)           # (grid, blocks, 9, 9), (grid, blocks, 9)
    theta, part = _solve_batch(nb.sum(axis=1), rb.sum(axis=1))
    best = int(np.argmin(part))
    lat, sh = grid[best]
    x = xs[best][valid]
    out = fit(t, y, rts[lat][valid], x, bootstrap=False)
    rng = np.random.default_rng(SEED)
    picks = rng.integers(0, len(starts), (REPLICATES, len(starts)))
    counts = np.array([np.bincount(p, minlength=len(starts)) for p in picks], float)
    ks, lats = [], []
    for c0 in range(0, REPLICATES, BOOT_CHUNK):
        w = counts[c0:c0 + BOOT_CHUNK]
        th, pt = _solve_batch(np.einsum("rb,gbij->rgij", w, nb), np.einsum("rb,gbi->rgi", w, rb))
        pick = np.argmin(pt, axis=1)
        ks.append(th[np.arange(len(w)), pick, 6:9])
        lats.extend(grid[g][0] for g in pick)
    out.update(interval(out["k"], np.concatenate(ks), len(starts)))
    out.update({"latency_s": float(lat), "shift_s": float(sh),
                "latency_ci95_s": [float(np.percentile(lats, 2.5)), float(np.percentile(lats, 97.5))],
                "replicates": REPLICATES, "blocks": int(len(starts))})
    return out


def widening(blocks):
    """The factor the percentile spread is widened by for `blocks` resampled blocks: the bootstrap's
    variance is (B - 1)/B of the jackknife's, and a spread estimated from B blocks takes Student-t at
    B - 1 degrees of freedom, not the normal 1.96 (a 60-s flight holds 6 blocks of 10 s: x1.35;
    unwidened, 4 of 11 simulated 1-2 Hz flights missed their true k)."""
    b = max(int(blocks), 3)
    return np.sqrt(b / (b - 1.0)) * T975[min(b - 1, len(T975) - 1)] / 1.959964


# Student-t 97.5 % points for 0..30 degrees of freedom (index = dof; 30 stands for more)
T975 = [np.inf, 12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179,
        2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060,
        2.056, 2.052, 2.048, 2.045, 2.042]


def interval(k, ks, blocks):
    """Percentile intervals of the bootstrap replicates ks of k, their distances from the point
    widened by widening(blocks) (module doc)."""
    k = np.asarray(k)
    c = widening(blocks)
    norm = float(np.linalg.norm(k))
    norms = np.linalg.norm(ks, axis=1)
    lo_c = k - c * (k - np.percentile(ks, 2.5, axis=0))
    hi_c = k + c * (np.percentile(ks, 97.5, axis=0) - k)
    zero_inside = bool(np.all((lo_c <= 0) & (hi_c >= 0)))
    lo_n = norm - c * max(norm - float(np.percentile(norms, 2.5)), 0.0)
    hi_n = norm + c * max(float(np.percentile(norms, 97.5)) - norm, 0.0)
    # a norm's percentile interval never reaches 0; where every component's does, |k| can be 0
    return {"k_norm_lo": 0.0 if zero_inside else max(lo_n, 0.0), "k_norm_hi": hi_n,
            "k_lo": lo_c.tolist(), "k_hi": hi_c.tolist(), "zero_inside": zero_inside,
            "widening": float(c)}


def fit(t, y, rt, x, bootstrap=True):
    """The stacked fit on fixed timing; with `bootstrap` its block-bootstrap interval."""
    a = design(rt, x)
    sol = solve(a, y)
    res = y - np.einsum("nij,j->ni", a, sol)
    base = a[:, :, :6]
    sol0, *_ = np.linalg.lstsq(base.reshape(-1, 6), y.reshape(-1), rcond=None)
    res0 = y - np.einsum("nij,j->ni", base, sol0)
    share = 1.0 - float(np.sum(res ** 2) / np.sum(res0 ** 2)) if np.sum(res0 ** 2) > 0 else 0.0
    k = sol[6:9]
    out = {"k": k.tolist(), "k_norm": float(np.linalg.norm(k)),
           "field_ned_uT": sol[0:3].tolist(), "offset_uT": sol[3:6].tolist(),
           "explained_share": share, "residual_rms_uT": float(np.sqrt(np.mean(res ** 2))),
           "samples": int(len(t))}
    if not bootstrap:
        return out
    blocks = np.floor((t - t[0]) / BLOCK_S).astype(int)
    members = [np.nonzero(blocks == b)[0] for b in np.unique(blocks)]
    rng = np.random.default_rng(SEED)
    ks = []
    for _ in range(REPLICATES):
        idx = np.concatenate([members[p] for p in rng.integers(0, len(members), len(members))])
        if np.ptp(x[idx]) > 0:
            ks.append(solve(a[idx], y[idx])[6:9])
    out.update(interval(k, np.array(ks), len(members)))
    out.update({"blocks": len(members), "replicates": len(ks)})
    return out


def analyse_compass(f, c, cur):
    t = c["t"]
    m = extract.in_segments(t, f.segs)
    out = {"compass": c["name"], "external": c["external"], "use": c["use"],
           "motct": c["motct"], "mot": c["mot"], "device_id": c.get("device_id")}
    if not len(t) or np.ptp(c["xyz"], axis=0).max() <= 0:
        out["status"] = "compass not logged (constant)"
        return out
    t, y = t[m], c["xyz"][m]
    att = lambda tq: attitude_at(f.att_t, f.att_r, tq)  # noqa: E731
    forms = {}
    if f.cur_a is not None and len(f.cur_a):
        forms["current"] = (lambda tq: interp(f.cur_t, f.cur_a, tq),
                            np.arange(0.0, MAX_SHIFT_S + 1e-9, SHIFT_STEP_S))
    if f.thr is not None:
        forms["output"] = (lambda tq: interp(f.thr_t, f.thr, tq), [0.0])
    out["status"] = "fitted"
    for name, (regressor, shifts) in forms.items():
        r = timed_fit(t, y, att, regressor, shifts)
        if r is None:
            out[name] = {"status": "too few samples or no variation"}
            continue
        if name == "current":
            r["current_shift_s"] = r["shift_s"]
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


def _report(what, r, truth, good):
    sys.stderr.write("reference selftest: %s: |k| %.3f [%.3f, %.3f] uT/A, truth %.3f: %s\n" % (
        what, r["k_norm"], r["k_norm_lo"], r["k_norm_hi"], truth, "ok" if good else "MISSED"))
    return good


def _yawing_flight(rng, k_true, latency_s):
    """A quad yawing at up to ~200 deg/s (attitude at 20 Hz), a 2 Hz compass `latency_s` late and a
    5 Hz current that moves with the yaw manoeuvres (log_66: corr(I, dm/dt) 0.3-0.4 per axis)."""
    dt = 0.005
    tt = np.arange(0.0, 150.0, dt)
    w = 2.0 * np.sin(0.4 * tt) + 1.5 * np.sin(1.3 * tt + 0.4)          # yaw rate, rad/s
    yaw = np.cumsum(w) * dt
    roll, pitch = np.radians(12) * np.sin(0.31 * tt), np.radians(10) * np.sin(0.23 * tt + 1.0)
    r_true = extract.euler_to_r(roll, pitch, yaw)
    cur = 12 + 3 * np.sin(0.11 * tt) + 2.0 * w * np.sin(yaw + 0.5) + 0.3 * rng.standard_normal(len(tt))
    field, offset = np.array([20.7, 1.5, 44.2]), np.array([7.0, 7.0, 0.0])
    tau = np.arange(0.3, 149.5, 0.5)                                      # compass measurements
    idx = np.searchsorted(tt, tau)
    y = np.einsum("nji,j->ni", r_true[idx], field) + offset + np.outer(cur[idx], k_true)
    y += 0.3 * rng.standard_normal(y.shape)
    att_t = tt[::10]                                                      # 20 Hz attitude
    cur_t = tt[::40]                                                      # 5 Hz current
    return tau + latency_s, y, att_t, r_true[::10], cur_t, cur[::40]


def selftest():
    """The fit on synthetic flights with a known k, and with none: exit 1 when it misses."""
    rng = np.random.default_rng(1)
    ok = True
    shifts = np.arange(0.0, MAX_SHIFT_S + 1e-9, SHIFT_STEP_S)
    # a logged current 0.3 s late: the alignment finds the shift and k, the unaligned fit is low
    t = np.arange(0.0, 150.0, 0.1)
    roll = np.radians(15) * np.sin(0.31 * t) + np.radians(3) * rng.standard_normal(len(t))
    pitch = np.radians(12) * np.sin(0.23 * t + 1.0)
    r_nb = extract.euler_to_r(roll, pitch, 0.05 * t)
    rt = np.transpose(r_nb, (0, 2, 1))
    att = lambda tq: attitude_at(t, r_nb, tq)  # noqa: E731
    field, offset = np.array([20.0, 2.0, -45.0]), np.array([10.0, -5.0, 30.0])
    k_true = np.array([0.3, -0.4, 0.2])
    fast = 15 + 6 * np.sin(0.11 * t) + 4 * np.sin(1.7 * t) + 3 * np.sin(2.9 * t + 1)
    y = rt @ field + offset + np.outer(fast, k_true) + 0.3 * rng.standard_normal((len(t), 3))
    logged_t = t + 0.3                       # the sample of time t is stamped 0.3 s later
    sel = t < 149.0
    r = timed_fit(t[sel], y[sel], att, lambda tq: interp(logged_t, fast, tq), shifts)
    r0 = fit(t, y, rt, np.interp(t, logged_t, fast))
    truth = np.linalg.norm(k_true)
    ok &= _report("current 0.3 s late: shift %.2f s (unaligned %.3f)" % (r["shift_s"], r0["k_norm"]), r, truth,
                  abs(r["shift_s"] - 0.3) < 1e-6 and r["k_norm_lo"] <= truth <= r["k_norm_hi"]
                  and r0["k_norm_hi"] < truth)
    cur = 15 + 6 * np.sin(0.11 * t) + np.cumsum(rng.standard_normal(len(t))) * 0.1
    for k_true in (np.array([0.3, -0.4, 0.2]), np.zeros(3)):
        y = rt @ field + offset + np.outer(cur, k_true) + 0.5 * rng.standard_normal((len(t), 3))
        r = timed_fit(t, y, att, lambda tq: interp(t, cur, tq), [0.0])
        truth = np.linalg.norm(k_true)
        ok &= _report("in time", r, truth, r["k_norm_lo"] <= truth <= r["k_norm_hi"]
                      and abs(r["k_norm"] - truth) < 0.05 and r["zero_inside"] == (truth == 0))
    # a fast-yawing flight, compass 2 Hz and 40 ms late: the interpolated attitude at the fitted
    # latency recovers k (and no k on a compass without one); the later attitude sample without a
    # latency (this script's lookup before) does not
    for k_true in (np.array([0.1, -0.2, 0.05]), np.zeros(3)):
        tc, y, att_t, att_r, cur_t, cur = _yawing_flight(rng, k_true, 0.04)
        r = timed_fit(tc, y, lambda tq: attitude_at(att_t, att_r, tq),
                      lambda tq: interp(cur_t, cur, tq), shifts)
        later = np.transpose(att_r[np.clip(np.searchsorted(att_t, tc), 0, len(att_t) - 1)], (0, 2, 1))
        r0 = fit(tc, y, later, interp(cur_t, cur, tc))
        truth = np.linalg.norm(k_true)
        good = r["k_norm_lo"] <= truth <= r["k_norm_hi"] and r["zero_inside"] == (truth == 0)
        good &= abs(r["latency_s"] - 0.04) <= 0.011 and not r0["k_norm_lo"] <= truth <= r0["k_norm_hi"]
        ok &= _report("yawing, 2 Hz compass 40 ms late: latency %.2f s (later attitude sample: %.3f "
                      "[%.3f, %.3f])" % (r["latency_s"], r0["k_norm"], r0["k_norm_lo"], r0["k_norm_hi"]),
                      r, truth, good)
    ok &= _short_flights_covered(np.random.default_rng(0))
    return 0 if ok else 1


def _short_flights_covered(rng, flights=40, need=34):
    """40-s flights at 2 Hz (4 bootstrap blocks) with serially correlated compass noise: the widened
    interval holds the true |k| in at least `need` of `flights` (85 %; 35-40 over six seeds); the
    plain percentile interval held it in 25-32 (31 on this seed)."""
    hits = 0
    k_true = np.array([0.1, -0.2, 0.05])
    for i in range(flights):
        t = np.arange(0.0, 40.0, 0.5)
        r = extract.euler_to_r(np.radians(10) * np.sin(0.31 * t + i), np.radians(8) * np.sin(0.23 * t),
                               0.4 * t + 0.5 * np.sin(0.3 * t + i))
        rt = np.transpose(r, (0, 2, 1))
        cur = 12 + 4 * np.sin(0.13 * t + i) + 2 * np.sin(0.7 * t)
        e = np.zeros((len(t), 3))
        for j in range(1, len(t)):
            e[j] = 0.8 * e[j - 1] + 0.6 * rng.standard_normal(3)
        y = rt @ np.array([20.7, 1.5, 44.2]) + np.array([7.0, 7.0, 0.0]) + np.outer(cur, k_true) + e
        r = fit(t, y, rt, cur)
        hits += r["k_norm_lo"] <= np.linalg.norm(k_true) <= r["k_norm_hi"]
    sys.stderr.write("reference selftest: 40-s flights at 2 Hz (4 blocks): true |k| inside %d of %d "
                     "(needs %d): %s\n" % (hits, flights, need, "ok" if hits >= need else "MISSED"))
    return hits >= need


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
