#!/usr/bin/python3
"""Withheld cases through the user's path: plant an effect in a copy of a shipped vehicle file, fly
it with `hexsim run`, diagnose the log with `hexsim gap diagnose --sim <unmodified vehicle>` and
without --sim, and judge the verdicts (judge.py). See README.md beside this file.

  /usr/bin/python3 scripts/withheld_sim/withheld_sim.py --seed 7 --cases 40 --jobs 2 --out /tmp/wh
"""
import argparse
import concurrent.futures as cf
import copy
import csv
import json
import math
import os
import shutil
import subprocess
import sys

import numpy as np
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import cases as cases_mod  # noqa: E402
import judge as judge_mod  # noqa: E402

REPO = os.path.abspath(os.path.join(HERE, "..", ".."))


def run(cmd, log_path, timeout=900):
    with open(log_path, "w") as f:
        p = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, cwd=REPO, timeout=timeout)
    return p.returncode


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def write_csv(path, header, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


def col(header, rows, name):
    i = header.index(name)
    return np.array([float(r[i]) if r[i] != "" else math.nan for r in rows])


def fmt(x):
    return "" if not math.isfinite(x) else repr(float(x))


def plant_latency(header, rows, pre, L):
    """Each row carries the newest sample of compass `pre` whose stamp + L has passed, with that
    stamp + L (a driver queue L late; as gap/src/selftest_real.cc DegradeToRealLog)."""
    t = col(header, rows, "t_s")
    ts = col(header, rows, pre + "_t_s")
    idx = [header.index(pre + s) for s in ("_x_uT", "_y_uT", "_z_uT", "_t_s")]
    src = [[r[i] for i in idx] for r in rows]
    j = 0
    for i, r in enumerate(rows):
        while j + 1 < len(rows) and math.isfinite(ts[j + 1]) and ts[j + 1] + L <= t[i] + 1e-12:
            j += 1
        for k in range(3):
            r[idx[k]] = src[j][k]
        r[idx[3]] = fmt(ts[j] + L) if math.isfinite(ts[j]) else ""


def degrade_real(header, rows, rng, meta, attitude):
    """As a real autopilot logs: the current updated at 5 Hz and stale by 0..0.25 s, no per-motor
    currents, rows at 10 Hz; with attitude 'estimate' the estimator's attitude (est_q_* into q_*).
    hexsim's ESKF (hexsim run's default estimator) has a 3-9 deg RMS yaw error in a clean calm square
    (refs/<vehicle>/run: yaw_est_deg - yaw_true_deg), far above a real EKF's, so 'estimate' is an
    option, not the default."""
    t = col(header, rows, "t_s")
    for a in ("w", "x", "y", "z") if attitude == "estimate" else ():
        if "est_q_" + a in header:
            qi, ei = header.index("q_" + a), header.index("est_q_" + a)
            for r in rows:
                r[qi] = r[ei]
    stale = float(rng.uniform(0.0, 0.25))
    ci = header.index("current_A")
    cur = [r[ci] for r in rows]
    for i, r in enumerate(rows):
        upd = math.floor(t[i] / 0.2) * 0.2 - stale
        j = max(0, min(len(rows) - 1, int(np.searchsorted(t, upd + 1e-9, side="right")) - 1))
        r[ci] = cur[j]
    drop = [k for k, h in enumerate(header) if h.startswith("est_") or (h.startswith("motor_") and h.endswith("_A"))
            or h in ("yaw_true_deg", "yaw_est_deg", "wind_N_mps", "wind_E_mps", "wind_D_mps")]
    keep = [k for k in range(len(header)) if k not in drop]
    out, nxt = [], t[0]
    for i, r in enumerate(rows):
        if t[i] + 1e-9 < nxt:
            continue
        nxt = t[i] + 0.1
        out.append([r[k] for k in keep])
    meta["log_rate_hz"] = 10.0
    return [header[k] for k in keep], out, stale


def hover_current(hexsim, vehicle, out_dir):
    """The vehicle's median battery current in flight (a clean square): where the lagged power law
    equals the modelled field (cases._scale_wiring_for_exponent)."""
    d = os.path.join(out_dir, "refs", vehicle)
    os.makedirs(d, exist_ok=True)
    run([hexsim, "run", "square", "--vehicle", f"worlds/vehicles/{vehicle}.yaml", "--seed", "1", "--out", d + "/run"],
        d + "/run.txt")
    header, rows = read_csv(d + "/run/log.csv")
    I, u = col(header, rows, "current_A"), col(header, rows, "control_u")
    return float(np.median(I[u > 0.2]))


def base_of(stdout_path):
    """The shipped vehicle gap diagnose took as the identified vehicle's base (its stdout)."""
    with open(stdout_path) as f:
        for line in f:
            if line.startswith("vehicle: frame") and "base " in line:
                return line.rsplit("base ", 1)[1].split()[0]
    return None


def write_world(case, path):
    with open(os.path.join(REPO, "worlds/environments/default.yaml")) as f:
        w = yaml.safe_load(f)
    w["name"] = "withheld"
    if case["wind"]:
        s, a = case["wind"]["speed_mps"], math.radians(case["wind"]["from_deg"])
        # A wind from bearing a blows towards a + 180 deg.
        w["wind"] = {"mean_N_mps": [round(-s * math.cos(a), 3), round(-s * math.sin(a), 3), 0.0],
                     "turbulence_std_mps": case["wind"]["turbulence_std_mps"], "turbulence_tau_s": 2.0}
    with open(path, "w") as f:
        yaml.safe_dump(w, f, sort_keys=False)


def one_case(case, args, hover):
    d = os.path.join(args.out, "cases", f"{case['id']:03d}")
    os.makedirs(d, exist_ok=True)
    rng = np.random.default_rng(case["seed"])
    with open(os.path.join(REPO, f"worlds/vehicles/{case['vehicle']}.yaml")) as f:
        base = yaml.safe_load(f)
    doc = cases_mod.planted_vehicle(base, case, rng, hover[case["vehicle"]])
    with open(d + "/vehicle.yaml", "w") as f:
        yaml.safe_dump(doc, f, sort_keys=False)
    write_world(case, d + "/world.yaml")
    res = {"case": case, "judgements": []}
    if os.path.isdir(d + "/run"):
        shutil.rmtree(d + "/run")
    rc = run([args.hexsim, "run", case["mission"], "--vehicle", d + "/vehicle.yaml", "--world", d + "/world.yaml",
              "--seed", str(case["seed"] % 100000), "--out", d + "/run"], d + "/run.txt")
    if rc != 0:
        res["error"] = f"hexsim run exit {rc} (see {d}/run.txt)"
        return res
    with open(d + "/run.txt") as f:
        ran = f.read()
    if "not_completed" in ran or "crashed" in ran:
        # A flight that did not finish (a heavy payload, a planted effect on the one compass the
        # flying filter fuses) is no case: not judged, said why.
        res["not_flown"] = ran.strip().splitlines()[-1]
        with open(d + "/result.json", "w") as f:
            json.dump(res, f, indent=2)
        return res
    log = d + "/run/log.csv"
    header, rows = read_csv(log)
    with open(d + "/run/log.meta.json") as f:
        meta = json.load(f)
    for eff in case["effects"]:
        if eff.get("log_latency_s"):
            plant_latency(header, rows, case["channel"], eff["log_latency_s"])
    # The flight's current span (5-95 %, throttle up): a lag or a current field needs the current to
    # move (gap's in-flight model asks 3 A to separate a current field from the offset).
    I, u = col(header, rows, "current_A"), col(header, rows, "control_u")
    fly = np.isfinite(I) & (u > 0.2)
    case["current_span_A"] = round(float(np.percentile(I[fly], 95) - np.percentile(I[fly], 5)), 2) if fly.any() else 0.0
    if case["log_form"] == "real10hz":
        header, rows, case["current_stale_s"] = degrade_real(header, rows, rng, meta, args.attitude)
    write_csv(log, header, rows)
    with open(d + "/run/log.meta.json", "w") as f:
        json.dump(meta, f, indent=2)
    for path in ("sim", "nosim"):
        cmd = [args.hexsim, "gap", "diagnose", "--real", log, "--out", f"{d}/gap_{path}", "--jobs", "1"]
        if path == "sim":
            cmd += ["--sim", f"worlds/vehicles/{case['vehicle']}.yaml"]
        rc = run(cmd, f"{d}/gap_{path}.txt")
        if rc != 0:
            res["judgements"].append({"path": path, "ok": False, "why": [f"gap diagnose exit {rc}"], "verdict": "-", "effects": "-"})
            continue
        j = judge_mod.judge(case, judge_mod.load(f"{d}/gap_{path}/gap.json"), path, base_of(f"{d}/gap_{path}.txt"))
        res["judgements"].append(j)
    if not args.keep_logs:
        os.remove(log)
    with open(d + "/result.json", "w") as f:
        json.dump(res, f, indent=2)
    return res


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--cases", type=int, default=40)
    ap.add_argument("--first", type=int, default=0, help="skip the first N drawn cases (resume a run)")
    ap.add_argument("--jobs", type=int, default=2, choices=[1, 2])
    ap.add_argument("--out", required=True)
    ap.add_argument("--hexsim", default=os.path.join(REPO, "build/apps/hexsim"))
    ap.add_argument("--only", default="", help="comma list of case ids to run (of the drawn cases)")
    ap.add_argument("--forms", default="", help="comma list restricting the forms (a+b for a pair, clean)")
    ap.add_argument("--keep-logs", action="store_true")
    ap.add_argument("--attitude", default="truth", choices=["truth", "estimate"],
                    help="the 10 Hz log form's attitude: the simulator's (q_*) or the estimator's (est_q_*)")
    ap.add_argument("--rejudge", action="store_true", help="judge the gap.json files already under --out again")
    args = ap.parse_args()
    args.out = os.path.abspath(args.out)
    args.hexsim = os.path.abspath(args.hexsim)
    os.makedirs(args.out, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    forms = None
    if args.forms:
        forms = [tuple(f.split("+")) if "+" in f else f for f in args.forms.split(",")]
    drawn = [cases_mod.draw_case(rng, i, forms=forms) for i in range(args.cases)]
    todo = drawn[args.first:]
    if args.only:
        ids = {int(x) for x in args.only.split(",")}
        todo = [c for c in todo if c["id"] in ids]
    if args.rejudge:
        prev = judge_mod.load(os.path.join(args.out, "results.json")) if os.path.exists(os.path.join(args.out, "results.json")) else {}
        args.seed = prev.get("seed", args.seed)
        return write_outputs(args, rejudge(args.out), prev.get("hover_current_A", {}))
    hover = {v: hover_current(args.hexsim, v, args.out) for v in sorted({c["vehicle"] for c in todo})}
    results = []
    with cf.ThreadPoolExecutor(max_workers=args.jobs) as ex:
        futs = {ex.submit(one_case, copy.deepcopy(c), args, hover): c for c in todo}
        for fu in cf.as_completed(futs):
            try:
                res = fu.result()
            except Exception as e:  # a broken case is reported, never silently dropped
                res = {"case": futs[fu], "error": f"{type(e).__name__}: {e}", "judgements": []}
            results.append(res)
            ok = all(j["ok"] is not False for j in res["judgements"]) and not res.get("error")
            word = "NOT FLOWN" if res.get("not_flown") else "PASS" if ok else "FAIL"
            print(f"case {res['case']['id']:3d} {res['case']['form']:<36} {word}", flush=True)
    write_outputs(args, results, hover)


def rejudge(out):
    results = []
    for name in sorted(os.listdir(os.path.join(out, "cases"))):
        d = os.path.join(out, "cases", name)
        if not os.path.exists(d + "/result.json"):
            continue
        res = judge_mod.load(d + "/result.json")
        case = res["case"]
        if res.get("not_flown") or res.get("error"):
            results.append(res)
            continue
        res["judgements"] = []
        for path in ("sim", "nosim"):
            if not os.path.exists(f"{d}/gap_{path}/gap.json"):
                continue
            res["judgements"].append(judge_mod.judge(case, judge_mod.load(f"{d}/gap_{path}/gap.json"), path,
                                                     base_of(f"{d}/gap_{path}.txt")))
        results.append(res)
    return results


def write_outputs(args, results, hover):
    results.sort(key=lambda r: r["case"]["id"])
    summary, counts = judge_mod.per_form(results)
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump({"seed": args.seed, "hover_current_A": hover, "counts": counts, "results": results}, f, indent=2)
    with open(os.path.join(args.out, "results.md"), "w") as f:
        f.write(f"# Withheld cases, seed {args.seed}, {len(results)} cases\n\n{summary}\n\n{judge_mod.table(results)}\n")
    print(summary)


if __name__ == "__main__":
    main()
