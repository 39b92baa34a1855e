#!/usr/bin/env python3
"""The README's tables of figures, written from fresh outputs (used by scripts/readme_figures.sh).

    readme_tables.py table1 HEADING_ERROR.json            > table.md
    readme_tables.py compare COMPARISON.json               > table.md
    readme_tables.py selftest SELFTEST.json MACHINE DATE   > table.md
    readme_tables.py speed MACHINE DATE BENCH.json...      > table.md
    readme_tables.py log171 GAP_SIM.json GAP_NOSIM.json magN/calib.report.json... > table.md
    readme_tables.py splice README NAME TABLE.md   (replace the block between NAME's markers)
    readme_tables.py check README NAME TABLE.md    (exit 1, with a diff, when they disagree)

A block sits between `<!-- readme_figures:NAME -->` and `<!-- /readme_figures:NAME -->`.
"""
import difflib
import json
import os
import sys

# Table 1: each row's label and the paper's figures (Xu et al. 2016, Table 1: max error in degrees at
# control 0/200/300); rows are the heading-error JSON's names, in the README's order.
TABLE1_ROWS = [
    ("uncorrected", "uncorrected", "12.5 / 13.3 / 14.3"),
    ("traditional", "traditional (ground ellipsoid)", "2.5 / 5.0 / 7.6"),
    ("adaptive", "adaptive (paper: TLS line, control-indexed)", "2.4 / 2.5 / 2.6"),
    ("adaptive-current", "adaptive-current (line indexed by current)", "–"),
    ("compassmot", "compassmot (ArduPilot-style, µT/A)", "–"),
    ("px4-ls", "px4-ls (PX4-style least squares on current)", "–"),
]

COMPARE_COLUMNS = [
    ("yaw_error_deg.max", "yaw max (°)"),
    ("yaw_error_deg.rms", "yaw RMS (°)"),
    ("cross_track_m.max", "cross-track max (m)"),
    ("cross_track_m.rms", "cross-track RMS (m)"),
    ("energy_Wh", "energy (Wh)"),
]


def amps(a):
    return f"{a:.1f} A" if a < 10 else f"{a:.0f} A"


def table1(path):
    j = json.load(open(path))
    rows = {r["name"]: r for r in j["rows"]}
    control = j["control_u"]
    current = rows["uncorrected"]["current_A"]
    head = " | ".join(f"{u:g} ({amps(a)})" for u, a in zip(control, current))
    out = [f"| control amount (battery current) | {head} | paper |", "|---" * (len(control) + 2) + "|"]
    for name, label, paper in TABLE1_ROWS:
        if name not in rows:
            sys.exit(f"readme_tables: {path}: rows: no '{name}'")
        r = rows[name]
        cells = " | ".join(f"{m:.2f} / {s:.2f}" for m, s in zip(r["max_deg"], r["rms_deg"]))
        out.append(f"| {label} | {cells} | {paper} |")
    return "\n".join(out) + "\n"


def compare(path):
    j = json.load(open(path))
    out = ["| calibration | " + " | ".join(c[1] for c in COMPARE_COLUMNS) + " |",
           "|---" * (len(COMPARE_COLUMNS) + 1) + "|"]
    means = {}
    for g in j["groups"]:
        cells = []
        for key, _ in COMPARE_COLUMNS:
            m = g["metrics"].get(key)
            cells.append("–" if m is None else f"{m['mean']:.2f} ± {m['std']:.2f}")
            if m is not None:
                means[(g["calibration"], key)] = m["mean"]
        out.append(f"| {g['calibration']} | " + " | ".join(cells) + " |")
    text = "\n".join(out) + "\n"
    a, t = means.get(("adaptive", "cross_track_m.rms")), means.get(("traditional", "cross_track_m.rms"))
    if a is not None and t:
        text += f"\nAdaptive / traditional cross-track RMS ratio: {a / t:.2f}.\n"
    return text


def pct(x):
    return "–" if x is None else f"{100 * x:.3g} %"


def per_effect(cls):
    pe = cls.get("per_effect", {})
    text = ", ".join(f"{e.replace('_', ' ')} {v['top1']}/{v['trials']}" for e, v in sorted(pe.items()))
    ambiguous = cls.get("verdicts", {}).get("ambiguous", 0)
    return text + (f" — {ambiguous} ambiguous" if ambiguous else "")


def trials_each(cls):
    n = {v["trials"] for v in cls.get("per_effect", {}).values()}
    return f" ({n.pop()} each)" if len(n) == 1 else ""


def target(targets, *prefixes):
    """The target text of the first key in `targets` starting with one of `prefixes`: "≥ 90 %"."""
    for p in prefixes:
        for k in targets or {}:
            if k.startswith(p + "_ge_") or k.startswith(p + "_le_"):
                op, rest = ("≥", k[len(p) + 4:]) if "_ge_" in k[len(p):len(p) + 4] else ("≤", k[len(p) + 4:])
                num = rest.split("u")[0].rstrip("_")
                if "uT_per_A" in rest:
                    return f"{op} {num} µT/A"
                return f"{op} {100 * float(num):.3g} %"
    return "–"


def selftest(path, machine, date):
    j = json.load(open(path))
    c = {k["class"]: k for k in j["classes"]}
    t, dt = j.get("targets"), j.get("dynamics_targets")
    clean, one, two = c.get("clean", {}), c.get("one_effect", {}), c.get("two_effects", {})
    ool, dyn = c.get("out_of_library", {}), c.get("dynamics_one_effect", {})
    thr = (j.get("detection_threshold", {}).get("current_hard_iron", {}) or {}).get("uT_per_A")
    thr_text = "not reached" if thr is None else f"{thr:.2g} µT/A ({10 * thr:.2g} mG/A)"
    families = sorted(ool.get("per_family", {}))
    ool_label = "out of library" + (f" ({', '.join(f.replace('_', ' ') for f in families)})" if families
                                    else " (field ∝ I^1.3, thermal ramp, …)")
    # The figure the profile's target is on: explained share (real) or held-out shrink (ideal).
    share = any(k.startswith("median_explained_share") for k in (t or {})) and "median_explained_share" in one
    one_last = (f"median explained share {pct(one.get('median_explained_share'))}" if share
                else f"median held-out shrink {pct(one.get('median_heldout_shrink'))}")
    if j.get("profile") == "real":
        # The real profile's details: which effects' intervals miss, which families are named.
        def misses(cls, hit, total):
            pe = cls.get("per_effect", {}) or cls.get("per_family", {})
            parts = [f"{e.replace('_', ' ')} {v[hit]}/{v[total]}" for e, v in sorted(pe.items()) if v[hit] < v[total]]
            return ", ".join(parts) + (", the rest all" if parts else "all")
        cov = misses(one, "covered", "coverage_trials")
        ool_miss = misses(ool, "not_confident" if "not_confident_rate" in ool else "unexplained", "trials")
        sweep = j.get("detection_threshold", {}).get("current_hard_iron", {}) or {}
        grid, rate = sweep.get("grid_uT_per_A", []), sweep.get("flagged_rate", [])
        flagged = ", ".join(f"{100 * r:.0f} % at {g:g}" for g, r in zip(grid, rate))
        thr_text += f" (flagged {flagged} µT/A; {sweep.get('trials_per_magnitude')} flights each)"
        one_last += f"; coverage by effect: {cov}"
        ool_detail = f" ({ool_miss})"
    else:
        ool_detail = ""
    rows = [
        ("clean", f"false alarms {pct(clean.get('false_alarm_rate'))}", target(t, "false_alarm")),
        ("one effect", f"top-1 {pct(one.get('top1_rate'))}, 95 % interval covers the truth "
                       f"{pct(one.get('coverage_95'))}, {one_last}",
         ", ".join([target(t, "single_top1"), target(t, "coverage"),
                    target(t, "median_explained_share" if share else "median_shrink")])),
        ("two effects", f"top-1 {pct(two.get('top1_rate'))}; overall top-1 {pct(j.get('overall_top1_rate'))}"
                        + (f"; both in effects {pct(two['both_in_effects_rate'])}" if "both_in_effects_rate" in two else ""),
         "overall " + target(t, "overall_top1")),
        # Out of library: not read confidently (unexplained, ambiguous, partial, or leftover reported).
        (ool_label, f"not confident {pct(ool.get('not_confident_rate', ool.get('unexplained_rate')))}{ool_detail}",
         target(t, "not_confident", "unexplained")),
        ("detection threshold, current hard iron", thr_text, target(t, "current_hard_iron_threshold")),
    ]
    # Forms beyond the library's names (real profile): right when named as the effect each is a form
    # of, or not confident.
    bl = c.get("beyond_library")
    if bl:
        forms = ", ".join(f"{e.replace('_', ' ')} {v.get('judged_right')}/{v['trials']} (named {v.get('named_right')})"
                          for e, v in sorted(bl.get("per_family", {}).items()))
        rows.insert(4, ("beyond library (forms of library effects)",
                        f"right {pct(bl.get('judged_right_rate'))}, named right {pct(bl.get('named_right_rate'))} ({forms})",
                        target(t, "beyond_library_judged_right")))
    # The dynamics channel's rows, where the profile runs that channel (it then has its targets).
    if dt:
        rows.append(("dynamics channel, clean logs", f"false alarms {pct(clean.get('dynamics_false_alarm_rate'))}",
                     target(dt, "false_alarm")))
    if dt and dyn:
        # The share the target is on (explained share; older runs: held-out shrink), the other beside it.
        dyn_share = any(k.startswith("median_explained_share") for k in dt) and "median_explained_share" in dyn
        dyn_last = (f"median explained share {pct(dyn.get('median_explained_share'))} (held-out shrink "
                    f"{pct(dyn.get('median_heldout_shrink'))})" if dyn_share
                    else f"median held-out shrink {pct(dyn.get('median_heldout_shrink'))}")
        rows.append((f"dynamics channel, one effect{trials_each(dyn)}",
                     f"top-1 {pct(dyn.get('top1_rate'))} ({per_effect(dyn)}), interval coverage "
                     f"{pct(dyn.get('coverage_95'))}, {dyn_last}",
                     ", ".join([target(dt, "single_top1"), target(dt, "coverage"),
                                target(dt, "median_explained_share" if dyn_share else "median_shrink")])))
    profile = f" --profile {j['profile']}" if "profile" in j else ""
    out = [f"`hexsim gap selftest{profile} --trials {j.get('trials_per_class')} --seed {j.get('seed')}` on {machine}, "
           f"{date}; targets {'met' if j.get('targets_met') else 'missed'}:", "",
           "| class | result | target |", "|---|---|---|"]
    out += [f"| {a} | {b} | {tt} |" for a, b, tt in rows]
    return "\n".join(out) + "\n"


def log171(gap_sim, gap_nosim, calibs):
    """The shared real log per compass: calibrate --method flight, gap's absolute term and verdicts."""
    gs, gn = json.load(open(gap_sim)), json.load(open(gap_nosim))
    chans = lambda g: {c["channel"]: c for c in g.get("channels", [])}
    cs, cn = chans(gs), chans(gn)

    def mg(t):
        if not t or not t.get("fitted") or t.get("norm_mG_per_A") is None:
            return "not fitted" if not t or not t.get("fitted") else "throttle form"
        lo, hi = t["norm_ci95_mG_per_A"]
        return f"{t['norm_mG_per_A']:.1f} [{lo:.1f}, {hi:.1f}] mG/A" + ("" if t.get("resolved", True)
                                                                        else ", not resolved from zero")

    def verdict(c):
        if c is None:
            return "not diagnosed"
        effects = c.get("effects", [])
        if not effects:
            return c.get("verdict", "–")
        parts = []
        for e in effects:
            unit = e.get("autopilot_unit") or e.get("unit", "")
            m = e.get("autopilot_magnitude", e.get("magnitude"))
            ci = e.get("autopilot_ci95", e.get("ci95")) or [None, None]
            size = f"{m:.3g} [{ci[0]:.3g}, {ci[1]:.3g}] {unit}" if None not in ci and m is not None else ""
            parts.append(f"{e['effect'].replace('_', ' ')} {size} ({pct(e.get('explained_share'))})".replace("  ", " "))
        head = "partial: " if c.get("partial") else ""
        return head + "; ".join(parts)

    def timing(c):
        t = (c or {}).get("timing", {}).get("latency_s")
        if not t:
            return "–"
        return f"{1000 * t['value']:.0f} ms [{1000 * t['ci95'][0]:.0f}, {1000 * t['ci95'][1]:.0f}]"

    out = ["| compass | `calibrate --method flight` | gap: absolute term (in-flight model) | "
           "gap --sim quad_x: effects (share) | gap, identified vehicle: effects (share) | compass latency |",
           "|---|---|---|---|---|---|"]
    for name in sorted(set(cs) | set(cn)):
        if not name.startswith("mag"):
            continue
        cal = json.load(open(calibs[name])) if name in calibs else {}
        cal_t = (cal.get("flight_fit") or {}).get("current")
        abs_t = ((cs.get(name) or {}).get("absolute_terms") or {}).get("current_term")
        out.append(f"| {name.upper()} | {mg(cal_t)} | {mg(abs_t)} | {verdict(cs.get(name))} | "
                   f"{verdict(cn.get(name))} | {timing(cs.get(name))} |")
    return "\n".join(out) + "\n"


def fmt_time(ns):
    for unit, scale in (("s", 1e9), ("ms", 1e6), ("µs", 1e3)):
        if ns >= scale:
            return f"{ns / scale:.3g} {unit}"
    return f"{ns:.3g} ns"


def speed(machine, date, paths):
    scale = {"ns": 1, "us": 1e3, "ms": 1e6, "s": 1e9}
    out = [f"Measured on {machine}, {date} (`scripts/readme_figures.sh speed`; Release build, median of 3 "
           "repetitions, CPU time):", "", "| benchmark | CPU time | wall time | counters |", "|---|---|---|---|"]
    for p in paths:
        for b in json.load(open(p))["benchmarks"]:
            if b.get("aggregate_name", "median") != "median":
                continue
            s = scale[b.get("time_unit", "ns")]
            name = b.get("run_name", b["name"]).replace("/real_time", "")
            skip = {"name", "run_name", "run_type", "repetitions", "repetition_index", "threads", "iterations",
                    "real_time", "cpu_time", "time_unit", "family_index", "per_family_instance_index",
                    "aggregate_name", "aggregate_unit", "error_occurred", "error_message"}
            counters = ", ".join(f"{k} {v:.3g}" for k, v in b.items() if k not in skip and isinstance(v, (int, float)))
            out.append(f"| `{name}` | {fmt_time(b['cpu_time'] * s)} | {fmt_time(b['real_time'] * s)} | {counters} |")
    return "\n".join(out) + "\n"


def markers(name):
    return f"<!-- readme_figures:{name} -->", f"<!-- /readme_figures:{name} -->"


def block(readme, name):
    text = open(readme, encoding="utf-8").read()
    begin, end = markers(name)
    i, k = text.find(begin), text.find(end)
    if i < 0 or k < i:
        sys.exit(f"readme_tables: {readme}: no block '{name}' (markers {begin} ... {end})")
    return text, i + len(begin) + 1, k


def splice(readme, name, table):
    text, i, k = block(readme, name)
    new = text[:i] + open(table, encoding="utf-8").read() + text[k:]
    tmp = readme + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(new)
    os.replace(tmp, readme)


def check(readme, name, table):
    text, i, k = block(readme, name)
    have, want = text[i:k], open(table, encoding="utf-8").read()
    if have == want:
        print(f"readme_figures: {name}: README agrees with a fresh run")
        return 0
    sys.stdout.writelines(difflib.unified_diff(have.splitlines(True), want.splitlines(True),
                                               f"README.md ({name})", f"fresh run ({name})"))
    print(f"readme_figures: {name}: README disagrees with a fresh run: "
          f"run scripts/readme_figures.sh {name} and commit README.md", file=sys.stderr)
    return 1


def main(argv):
    cmd = argv[1] if len(argv) > 1 else ""
    if cmd == "table1" and len(argv) == 3:
        sys.stdout.write(table1(argv[2]))
    elif cmd == "compare" and len(argv) == 3:
        sys.stdout.write(compare(argv[2]))
    elif cmd == "selftest" and len(argv) == 5:
        sys.stdout.write(selftest(argv[2], argv[3], argv[4]))
    elif cmd == "log171" and len(argv) >= 4:
        calibs = {os.path.basename(os.path.dirname(p)): p for p in argv[4:]}
        sys.stdout.write(log171(argv[2], argv[3], calibs))
    elif cmd == "speed" and len(argv) >= 5:
        sys.stdout.write(speed(argv[2], argv[3], argv[4:]))
    elif cmd == "splice" and len(argv) == 5:
        splice(argv[2], argv[3], argv[4])
    elif cmd == "check" and len(argv) == 5:
        return check(argv[2], argv[3], argv[4])
    else:
        sys.exit(__doc__)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
