"""Withheld effects on real baselines (issue 29): writes a copy of a real ArduPilot DataFlash log
with one compass's logged field changed by a known effect, so `hexsim gap diagnose` can be judged
on a real flight (real noise, real attitude-reference errors, real current) whose truth we know.

Independent of hexsim on purpose: the log is read with logread.py and rewritten byte for byte;
only the chosen compass message's MagX/MagY/MagZ (int16 milligauss) change.

Forms (all in the compass's logged body-frame axes, milligauss):
  current   m += k * I(t)                         k: mG/A vector (--k kx,ky,kz)
  lagpow    m += k * I0 * (J(t)/I0)^p             J: I through a first-order lag tau (--tau s),
                                                  I0 the flight median current, p (--power)
  scale     m_x *= 1 + s (the axis --axis)        a static per-axis scale error s (--scale)
  latency   m(t) -> m(t - tau)                    the compass read tau late (--tau s)
Several forms may be given at once (--form current,scale).

usage: inject.py IN.bin OUT.bin --mag MAG2 --form current --k 3,-2,1 [...]
Prints one JSON line: the forms, their sizes and the truth each should read.
"""
import argparse, json, os, struct, sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import logread  # noqa: E402


def current_series(log):
    """(t_s, I_A) of the battery current, scaled by logread's unit rules."""
    for name in ("CURR", "BAT", "BATT"):
        m = log.msgs.get(name)
        tcol = "TimeUS" if m and "TimeUS" in m else "TimeMS"
        if m and "Curr" in m and tcol in m:
            return np.asarray(m[tcol], float) * (1e-6 if tcol == "TimeUS" else 1e-3), np.asarray(m["Curr"], float)
    raise SystemExit("inject: no CURR/BAT current in the log")


def lowpass(t, x, tau):
    y = np.empty_like(x)
    y[0] = x[0]
    for i in range(1, len(x)):
        a = 1.0 - np.exp(-max(t[i] - t[i - 1], 0.0) / tau) if tau > 0 else 1.0
        y[i] = y[i - 1] + a * (x[i] - y[i - 1])
    return y


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("inp")
    ap.add_argument("out")
    ap.add_argument("--mag", default="MAG2")
    ap.add_argument("--form", required=True)
    ap.add_argument("--k", default="0,0,0")
    ap.add_argument("--tau", type=float, default=0.0)
    ap.add_argument("--power", type=float, default=1.5)
    ap.add_argument("--scale", type=float, default=0.0)
    ap.add_argument("--axis", type=int, default=0)
    a = ap.parse_args()
    forms = a.form.split(",")
    k = np.array([float(v) for v in a.k.split(",")])

    log = logread.DataFlash(a.inp)
    mid = next((i for i, f in log.fmts.items() if f[0] == a.mag), None)
    if mid is None:
        raise SystemExit("inject: %s: no %s message" % (a.inp, a.mag))
    name, st, cols, fmt, length = log.fmts[mid]
    col = [cols.index(c) for c in ("MagX", "MagY", "MagZ")]
    if any(fmt[c] != "h" for c in col) or mid not in log.tscale:
        raise SystemExit("inject: %s: MagX/Y/Z not int16, or no leading time column" % a.mag)

    raw = bytearray(log.raw)
    where, rows = [], []
    i, n = 0, len(raw)
    while i + 3 <= n:              # the same walk as logread: a record's offset and its values
        if raw[i] != 0xA3 or raw[i + 1] != 0x95:
            i += 1
            continue
        m = raw[i + 2]
        if m == logread.DF_FMT_ID:
            i += 89
            continue
        f = log.fmts.get(m)
        if f is None:
            i += 1
            continue
        if i + f[4] > n:
            break
        if m == mid:
            where.append(i)
            rows.append(list(st.unpack_from(raw, i + 3)))
        i += f[4]
    t = np.array([r[0] for r in rows], float) * log.tscale[mid]
    B = np.array([[r[c] for c in col] for r in rows], float)
    ti, I = current_series(log)
    out = B.copy()
    truth = {}
    if "latency" in forms:
        out = np.column_stack([np.interp(t - a.tau, t, B[:, j]) for j in range(3)])
        truth["latency_s"] = a.tau
    if "scale" in forms:
        out[:, a.axis] *= 1.0 + a.scale
        truth["scale_error"] = {"axis": a.axis, "s": a.scale}
    if "current" in forms:
        out += np.outer(np.interp(t, ti, I), k)
        truth["current_mG_per_A"] = k.tolist()
    if "lagpow" in forms:
        J = np.interp(t, ti, lowpass(ti, I, a.tau))
        I0 = float(np.median(I[I > 0.5 * np.max(I)])) if np.any(I > 0) else 1.0
        out += np.outer(I0 * np.power(np.clip(J, 0, None) / I0, a.power), k)
        truth["lagpow"] = {"k_mG_per_A": k.tolist(), "tau_s": a.tau, "power": a.power, "I0_A": I0}
    if np.any(np.abs(out) > 32767):
        raise SystemExit("inject: the changed field overflows int16")
    for off, r, v in zip(where, rows, np.rint(out).astype(int)):
        for j, c in enumerate(col):
            r[c] = int(v[j])
        st.pack_into(raw, off + 3, *r)
    with open(a.out, "wb") as fh:
        fh.write(raw)
    print(json.dumps({"in": a.inp, "out": a.out, "mag": a.mag, "forms": forms, "truth": truth,
                      "rows": len(rows)}))


if __name__ == "__main__":
    main()
