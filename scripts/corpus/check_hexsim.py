"""Run hexsim on every corpus log and judge it against the independent reference (issue 29).

For each log: `hexsim import`, `hexsim gap diagnose` without --sim and with --sim VEHICLE, and
`hexsim calibrate LOG --method flight --compass magN` per compass. Per compass it tabulates
the reference |k| [lo, hi] (reference.py), calibrate's and both gap paths' verdict and size,
and PASS/FAIL against issue 29's "Done when":
  * internal compass, usable current: gap's verdict (or an effect of its decomposition) current-
    or throttle-driven, with the mG/A point of its absolute current term (gap.json absolute_terms:
    the in-flight compass model's, which calibrate prints too; gap's own candidate where there is
    none) inside [lo - 0.2 w, hi + 0.2 w] of the reference interval (w = hi - lo). Where the
    reference's own interval holds 0 (it cannot tell the field from none), a verdict that is not
    current-driven agrees with it (a note, not a failure); a current-driven one is judged by size;
  * external compass: no material current effect, or one whose interval includes 0 - unless
    the reference resolves one (its k interval excludes 0): then a reported effect's absolute
    term must lie in the widened reference interval like an internal compass's (real logs have
    such masts);
  * each reference compass is paired with hexsim's column by device id, else by the external
    flag, else by position (the readers order a PX4 log's compasses differently);
  * no printed number outside its physical range (a selected implausible candidate, a mG/A
    beyond the reference's physical range);
  * calibrate and gap: each absolute current term inside the other's interval; calibrate and
    the reference must not exclude each other (a one-sided miss is a note);
  * unusable current (issue 29 item 1): no current-based verdict or calibration term at all;
  * every command exits 0 (or 1/2/3 with one clear line), never by a signal; a gap that refuses a
    log (exit 2, one "hexsim:" line, no gap.json) has not diagnosed it, for that reason.

usage: check_hexsim.py --hexsim BIN [--sim quad_x] [--work DIR] [--json OUT] [--md OUT]
                        [--status OUT] CORPUS_DIR
"""

import argparse
import datetime
import json
import os
import re
import subprocess
import sys
import time

import reference

TIMEOUT_S = 120
SLACK = 0.2                    # issue 29: the point may lie 0.2 interval widths outside
CURRENT_WORDS = ("current", "throttle")


WALL = {}   # command kind -> [(log, seconds)]


def run(cmd, log_to):
    start = time.monotonic()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=TIMEOUT_S)
        out, rc = p.stdout + p.stderr, p.returncode
    except subprocess.TimeoutExpired:
        out, rc = "timeout after %d s" % TIMEOUT_S, "timeout"
    wall = time.monotonic() - start
    kind = " ".join(c for c in cmd[1:3] if not c.startswith("/"))
    if "--sim" in cmd:
        kind += " --sim"
    WALL.setdefault(kind, []).append((os.path.basename(os.path.dirname(log_to)), wall))
    with open(log_to, "w") as fh:
        fh.write("$ %s\n%s\nexit %s (%.2f s wall)\n" % (" ".join(cmd), out, rc, wall))
    return rc, out


def mg_per_a(cand):
    """(point, lo, hi) in mG/A of a gap candidate, in battery-current terms, or None."""
    if cand is None:
        return None
    if cand.get("magnitude_unit") == "uT/A":
        lo, hi = cand["magnitude_ci95"]
        return cand["magnitude"] * 10, lo * 10, hi * 10
    p = cand.get("params", {}).get("current_equivalent_uT_per_A")
    ci = cand.get("ci95", {}).get("current_equivalent_uT_per_A")
    if p is not None and ci:
        return p * 10, ci[0] * 10, ci[1] * 10
    return None


def gap_compass(gdir, name):
    """Verdict of one compass channel of gap.json: dict or None."""
    path = os.path.join(gdir, "gap.json")
    if not os.path.exists(path):
        return None
    try:
        d = json.load(open(path))
    except ValueError:
        return {"verdict": "gap.json unreadable"}
    for ch in d.get("channels", []):
        if ch.get("channel") != name:
            continue
        sel = [c for c in ch.get("candidates", []) if c.get("effect") == ch.get("verdict")]
        cand = sel[0] if sel else None
        out = {"verdict": ch.get("verdict"), "headline": ch.get("headline", ""),
               "share": ch.get("explained_share"), "cand": cand,
               "selected_implausible": [c["effect"] for c in ch.get("candidates", [])
                                        if c.get("selected") and not c.get("plausible", True)],
               "findings": ch.get("findings", [])}
        out["mg"] = mg_per_a(cand) if cand else None
        # a current effect anywhere among the selected ones (the headline may be another), or in the
        # channel's decomposition (`effects`, material effects only)
        cur = [c for c in ch.get("candidates", []) if c.get("selected")
               and any(w in c.get("effect", "") for w in CURRENT_WORDS)]
        out["current_selected"] = [c["effect"] for c in cur] + [
            e["effect"] for e in ch.get("effects", [])
            if any(w in e.get("effect", "") for w in CURRENT_WORDS)]
        # the in-flight compass model's absolute current term (the number calibrate prints too)
        term = (ch.get("absolute_terms") or {}).get("current_term") or {}
        out["abs"] = None
        if term.get("fitted") and term.get("norm_mG_per_A") is not None:
            lo, hi = term["norm_ci95_mG_per_A"]
            out["abs"] = (term["norm_mG_per_A"], lo, hi)
        if out["mg"] is None and cur:
            out["mg"] = mg_per_a(cur[0])
        return out
    for nd in d.get("not_diagnosed", []):
        if isinstance(nd, dict) and nd.get("channel") == name:
            return {"verdict": "not diagnosed (%s)" % nd.get("why", nd.get("reason", "")),
                    "mg": None, "not_diagnosed": True,
                    "current_selected": [], "selected_implausible": [], "findings": []}
    return {"verdict": "channel absent", "mg": None, "current_selected": [],
            "selected_implausible": [], "findings": []}


def calib_current(cdir):
    path = os.path.join(cdir, "calib.report.json")
    if not os.path.exists(path):
        return None
    d = json.load(open(path))
    cur = d.get("flight_fit", {}).get("current", {})
    if not cur.get("fitted"):
        return {"fitted": False, "note": cur.get("note", "")}
    if cur.get("norm_mG_per_A") is None:  # the throttle form (no usable current): no mG/A figure
        return {"fitted": True, "mg": None, "form": cur.get("form", "throttle"),
                "applied": cur.get("applied"), "plausible": cur.get("plausible"),
                "resolved": cur.get("resolved")}
    lo, hi = cur.get("norm_ci95_mG_per_A", [None, None])
    return {"fitted": True, "mg": (cur.get("norm_mG_per_A"), lo, hi),
            "applied": cur.get("applied"), "plausible": cur.get("plausible"),
            "resolved": cur.get("resolved")}


def import_units(csv, ref):
    """Failures of hexsim's imported current/voltage against the reference's own reading.

    The reference's median is over the power messages as logged, so hexsim's is taken over its
    native-rate power stream (<log>.batt.csv, the same records) where it wrote one: the main CSV holds
    each value until the next on its own row grid, and on a short log that is half on the ground (a
    current 0 A or 15 A) the median of two samplings of one signal can sit anywhere on the take-off
    ramp (a 19-s PX4 log: 10.3 A on the row grid, 7.0 A over the records)."""
    fails = []
    batt = csv[:-len(".csv")] + ".batt.csv"
    if os.path.exists(batt):
        csv = batt
    try:
        import numpy as np
        with open(csv) as fh:
            head = fh.readline().strip().split(",")
        data = np.genfromtxt(csv, delimiter=",", skip_header=1, invalid_raise=False, ndmin=2)
    except (OSError, ValueError) as e:
        return ["import: CSV unreadable (%s)" % e]
    for col, key, unit in (("current_A", "amps_all", "A"), ("voltage_V", "volts_all", "V")):
        want = ref["current"].get(key)
        if col not in head or want is None:
            continue
        got = np.nanmedian(data[:, head.index(col)])
        if abs(want) < 0.05 and abs(got) < 0.05:
            continue
        ratio = got / want if want else float("inf")
        if not 0.8 <= ratio <= 1.25:
            fails.append("import units: %s median %.3g %s, the log's own %.3g %s (x%.3g)" % (
                col, got, unit, want, unit, ratio))
    return fails


def inside(point, lo, hi, slack=0.0):
    w = hi - lo
    return lo - slack * w <= point <= hi + slack * w


def judge(c, ref_c, usable, gaps, cal, notes):
    """List of failure strings for one compass (empty = PASS); remarks go to notes."""
    fails = []
    ext = ref_c.get("external")
    rc_ = ref_c.get("current") or {}
    for path, g in gaps.items():
        if g is None:
            fails.append("%s: no gap.json" % path)
            continue
        if g["selected_implausible"]:
            fails.append("%s: selected implausible %s" % (path, ",".join(g["selected_implausible"])))
        is_cur = any(w in (g.get("verdict") or "") for w in CURRENT_WORDS) or g["current_selected"]
        if not usable and is_cur and g["mg"] is not None and "throttle" not in (g["verdict"] or ""):
            fails.append("%s: current-based verdict %s on an unusable current" % (path, g["verdict"]))
        if usable and ext is False and rc_.get("status") == "fitted":
            if not is_cur and rc_.get("zero_inside"):
                # the reference cannot tell the current field from none (a short or steady flight):
                # a diagnosis that does not claim one agrees with it
                notes.append("%s: internal compass not current-driven (%s); the reference's interval "
                             "holds 0 too" % (path, g["verdict"]))
            elif not is_cur:
                fails.append("%s: internal compass not current-driven (%s)" % (path, g["verdict"]))
            elif (g.get("abs") or g["mg"]) is None:
                fails.append("%s: current verdict without a mG/A size" % path)
            elif not inside((g.get("abs") or g["mg"])[0], rc_["k_norm_lo_mg"], rc_["k_norm_hi_mg"], SLACK):
                fails.append("%s: %.1f mG/A (absolute term) outside reference [%.1f, %.1f] +-0.2w" % (
                    path, (g.get("abs") or g["mg"])[0], rc_["k_norm_lo_mg"], rc_["k_norm_hi_mg"]))
        # Where the reference resolves a current field on an external compass (masts near power
        # leads: 1-5 mG/A on most of the quiver fleet's external compasses), a reported effect is
        # judged like an internal compass's: by its absolute term (the reference measures the whole
        # field; gap --sim's own candidate is the part the vehicle file does not model, which the
        # reference knows nothing of), inside the widened reference interval.
        ext_size = g.get("abs") or g["mg"]
        real_ext = ext is True and rc_.get("status") == "fitted" and not rc_["zero_inside"]
        if real_ext and is_cur and ext_size is not None:
            if not inside(ext_size[0], rc_["k_norm_lo_mg"], rc_["k_norm_hi_mg"], SLACK):
                fails.append("%s: external compass %.1f mG/A outside reference [%.1f, %.1f] "
                             "+-0.2w" % (path, ext_size[0], rc_["k_norm_lo_mg"],
                                         rc_["k_norm_hi_mg"]))
            else:
                notes.append("%s: external compass current-driven as the reference (the issue's "
                             "external rule would refuse it)" % path)
        elif ext is True and is_cur and g["mg"] is not None and g["mg"][1] > 0:
            fails.append("%s: external compass with a current effect %.1f [%.1f, %.1f] mG/A" % (
                path, g["mg"][0], g["mg"][1], g["mg"][2]))
        if g["mg"] is not None and not (reference.K_RANGE_MG_PER_A[0] <= g["mg"][0]
                                        <= reference.K_RANGE_MG_PER_A[1]):
            fails.append("%s: %.1f mG/A outside 0..%g" % (path, g["mg"][0],
                                                          reference.K_RANGE_MG_PER_A[1]))
        gabs = g.get("abs") or g["mg"]  # calibrate agrees with gap's absolute term (issue 29 item 2)
        if cal and cal.get("fitted") and gabs is not None and cal["mg"] and None not in cal["mg"]:
            cp, clo, chi = cal["mg"]
            gp, glo, ghi = gabs
            if not (glo <= cp <= ghi and clo <= gp <= chi):
                fails.append("%s vs calibrate: %.1f [%.1f, %.1f] vs %.1f [%.1f, %.1f] mG/A" % (
                    path, gp, glo, ghi, cp, clo, chi))
    if cal and cal.get("fitted") and usable and rc_.get("status") == "fitted" and \
            cal["mg"] and None not in cal["mg"]:
        cp, clo, chi = cal["mg"]
        lo, hi = rc_["k_norm_lo_mg"], rc_["k_norm_hi_mg"]
        if not inside(cp, lo, hi, SLACK) and not clo <= rc_["k_norm_mg"] <= chi:
            fails.append("calibrate: %.1f [%.1f, %.1f] mG/A and reference %.1f [%.1f, %.1f] "
                         "exclude each other" % (cp, clo, chi, rc_["k_norm_mg"], lo, hi))
        elif not inside(cp, lo, hi, SLACK):
            notes.append("calibrate's %.1f mG/A outside the reference [%.1f, %.1f] +-0.2w" %
                         (cp, lo, hi))
    if cal is None:
        pass   # calibrate refused the compass: its exit and line are checked by the caller
    elif cal.get("fitted") and not usable and cal["mg"]:
        fails.append("calibrate: current term fitted on an unusable current")
    elif cal.get("fitted") and cal["mg"] and cal["mg"][0] is not None and \
            cal["mg"][0] > reference.K_RANGE_MG_PER_A[1]:
        fails.append("calibrate: %.1f mG/A outside 0..%g" % (cal["mg"][0],
                                                              reference.K_RANGE_MG_PER_A[1]))
    return fails


def fmt_mg(m):
    if m is None:
        return "-"
    return "%.1f [%.1f, %.1f]" % m


def hexsim_compasses(csv):
    """The imported log's compasses (meta.json beside the CSV): [{column, device_id, external}]."""
    path = os.path.splitext(csv)[0] + ".meta.json"
    try:
        meta = json.load(open(path))
    except (OSError, ValueError):
        return []
    return [c for c in meta.get("compasses", []) if isinstance(c, dict) and c.get("column")]


def pair_compass(idx, rcomp, ref_compasses, hex_compasses):
    """hexsim's column for the reference's compass `idx`, and how it was paired.

    The two readers order a log's compasses differently (a PX4 log: the reference lists
    vehicle_magnetometer before sensor_mag, hexsim by calibration slot), so the position alone can
    pair an internal compass with an external one. Pairing by the sensor's device id, else by the
    external flag where each side has exactly one compass with it, else by position."""
    dev = rcomp.get("device_id")
    if dev is not None:
        hit = [c for c in hex_compasses if c.get("device_id") is not None
               and int(c["device_id"]) == int(dev)]
        if len(hit) == 1:
            return hit[0]["column"], "device id %d" % int(dev)
    ext = rcomp.get("external")
    if ext is not None and len(hex_compasses) == len(ref_compasses):
        ref_same = [c for c in ref_compasses if c.get("external") == ext]
        hex_same = [c for c in hex_compasses if c.get("external") == ext]
        if len(ref_same) == 1 and len(hex_same) == 1:
            return hex_same[0]["column"], "the only %s compass" % ("external" if ext else "internal")
    return ("mag" if idx == 0 else "mag%d" % (idx + 1)), "position"


def check_log(hexsim, log, work, sim, ref):
    base = os.path.splitext(os.path.basename(log))[0]
    wd = os.path.join(work, base)
    os.makedirs(wd, exist_ok=True)
    csv = os.path.join(wd, base + ".csv")
    rows = []
    rc_imp, out_imp = run([hexsim, "import", log, "--out", csv], os.path.join(wd, "import.txt"))
    gdirs = {"gap": os.path.join(wd, "gap_nosim"), "gap --sim": os.path.join(wd, "gap_sim")}
    rcs = {"import": rc_imp}
    outs = {}
    if rc_imp == 0:
        rcs["gap"], outs["gap"] = run([hexsim, "gap", "diagnose", "--real", csv, "--out",
                                       gdirs["gap"]], os.path.join(wd, "gap_nosim.txt"))
        rcs["gap --sim"], outs["gap --sim"] = run(
            [hexsim, "gap", "diagnose", "--real", csv, "--sim", sim, "--out", gdirs["gap --sim"]],
            os.path.join(wd, "gap_sim.txt"))
    usable = ref["current"]["usable"]
    hex_compasses = hexsim_compasses(csv)
    for idx, rcomp in enumerate(ref["compasses"]):
        if rcomp.get("status") != "fitted":
            continue
        cname, paired_by = pair_compass(idx, rcomp, ref["compasses"], hex_compasses)
        cdir = os.path.join(wd, "cal_" + cname)
        rcal, _ = run([hexsim, "calibrate", log, "--method", "flight", "--compass", cname,
                       "--out", os.path.join(cdir, "calib.yaml")],
                      os.path.join(wd, "cal_%s.txt" % cname))
        cal = calib_current(cdir)
        notes = []
        if paired_by != "position" and cname != ("mag" if idx == 0 else "mag%d" % (idx + 1)):
            notes.append("reference %s is hexsim's %s (by %s)" % (rcomp.get("compass"), cname,
                                                                paired_by))
        if cal is None:
            last = [ln for ln in open(os.path.join(wd, "cal_%s.txt" % cname)).read().splitlines()
                    if ln.startswith("hexsim:")]
            notes.append("calibrate refused (exit %s): %s" % (rcal, last[0] if last else "no line"))
            if rcal != 2 or not last:
                fails_extra = ["calibrate: no report and no one-line reason (exit %s)" % rcal]
            else:
                fails_extra = []
        else:
            fails_extra = []
        gaps = {p: gap_compass(d, cname) for p, d in gdirs.items()}
        for p in gaps:
            # a refusal (exit 2) with its one clear line is the rule's allowed answer: the log is
            # not diagnosed, for that reason (e.g. a one-rotor log that no multirotor file fits)
            refusal = [ln for ln in outs.get(p, "").splitlines() if ln.startswith("hexsim:")]
            if gaps[p] is None and rcs.get(p) == 2 and len(refusal) == 1:
                gaps[p] = {"verdict": "not diagnosed (%s)" % refusal[0], "mg": None,
                           "not_diagnosed": True, "current_selected": [],
                           "selected_implausible": [], "findings": []}
        fails = judge(cname, rcomp, usable, gaps, cal, notes) + fails_extra
        for p, g in gaps.items():
            if g and g.get("not_diagnosed"):
                notes.append("%s: %s" % (p, g["verdict"]))
            bad = [f.split(" fits ")[0] for f in (g or {}).get("findings", [])
                   if "implausible" in f and " fits " in f]
            if bad:
                notes.append("%s prints %d implausible fit(s) as findings (%s)" % (
                    p, len(bad), ", ".join(bad)))
        fails += import_units(csv, ref)
        if re.search(r"damaged log: 0\.0 %", out_imp):
            fails.append("import: prints 'damaged log: 0.0 %'")
        if not usable and not re.search(r"unusable|no power monitor", out_imp, re.I):
            fails.append("import: current unusable (%s) but not flagged" %
                         ref["current"]["reason"])
        for step, rc in list(rcs.items()) + [("calibrate " + cname, rcal)]:
            if rc not in (0, 1, 2, 3):
                fails.append("%s: exit %s" % (step, rc))
        rows.append({"log": base, "compass": cname, "external": rcomp.get("external"),
                     "usable": usable, "current": ref["current"]["text"],
                     "reference": rcomp.get("current"), "reference_output": rcomp.get("output"),
                     "calibrate": cal, "calibrate_exit": rcal,
                     "gap": {p: ({k: v for k, v in g.items() if k != "cand"} if g else None)
                             for p, g in gaps.items()},
                     "exits": rcs, "fails": fails, "notes": notes})
    return rows


def table(rows):
    out = ["| log | compass | ext | current | reference mG/A | calibrate mG/A | gap (no --sim) | "
           "gap --sim | result |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        ref = r["reference"] or {}
        refs = ("%.1f [%.1f, %.1f]" % (ref["k_norm_mg"], ref["k_norm_lo_mg"], ref["k_norm_hi_mg"])
                if ref.get("status") == "fitted" else ref.get("status", "-"))
        cal = r["calibrate"]
        cals = ("-" if cal is None else fmt_mg(cal["mg"]) if cal.get("fitted") and cal["mg"] else
            "%s form" % cal.get("form") if cal.get("fitted") else "not fitted")
        gs = []
        for p in ("gap", "gap --sim"):
            g = r["gap"][p]
            gs.append("-" if g is None else "%s %s%s" % (
                g["verdict"], fmt_mg(g["mg"]),
                "; absolute %s" % fmt_mg(g["abs"]) if g.get("abs") else ""))
        res = "PASS" if not r["fails"] else "FAIL: " + "; ".join(r["fails"])
        if r.get("notes"):
            res += " (" + "; ".join(r["notes"]) + ")"
        out.append("| %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
            r["log"], r["compass"], {None: "?", True: "ext", False: "int"}[r["external"]],
            "usable" if r["usable"] else "unusable", refs, cals, gs[0], gs[1], res))
    return "\n".join(out) + "\n"


def commit_of(hexsim):
    d = os.path.dirname(os.path.realpath(hexsim))
    try:
        top = subprocess.run(["git", "-C", d, "rev-parse", "--short", "HEAD"],
                             capture_output=True, text=True).stdout.strip()
        return top or "unknown"
    except OSError:
        return "unknown"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("corpus")
    ap.add_argument("--hexsim", required=True)
    ap.add_argument("--sim", default="quad_x")
    ap.add_argument("--work", default="/tmp/hexsim-corpus")
    ap.add_argument("--json")
    ap.add_argument("--md")
    ap.add_argument("--status")
    ap.add_argument("--sources", help="the sources file naming the logs (default: sources.json beside "
                    "this script)")
    a = ap.parse_args()
    here = os.path.dirname(os.path.abspath(__file__))
    logs = [os.path.join(a.corpus, s["file"])
            for s in json.load(open(a.sources or os.path.join(here, "sources.json")))]
    rows = []
    for log in logs:
        try:
            ref = reference.analyse(log)
        except Exception as e:  # the reference could not read it: say so, go on
            rows.append({"log": os.path.basename(log), "compass": "-", "external": None,
                         "usable": False, "current": "-", "reference": {"status": str(e)},
                         "calibrate": None, "gap": {"gap": None, "gap --sim": None},
                         "fails": ["reference: %s" % e]})
            continue
        rows.extend(check_log(a.hexsim, log, a.work, a.sim, ref))
        sys.stderr.write("%s done\n" % log)
    head = ("hexsim %s (%s), corpus %s, %s; --sim %s. %d of %d compass rows pass.\n\n" % (
        a.hexsim, commit_of(a.hexsim), a.corpus, datetime.date.today().isoformat(), a.sim,
        sum(1 for r in rows if not r["fails"]), len(rows)))
    walls = "; ".join("%s max %.2f s (%s)" % (k, max(v, key=lambda x: x[1])[1],
                                               max(v, key=lambda x: x[1])[0])
                      for k, v in sorted(WALL.items()) if k.startswith("gap"))
    head += "Wall time per run (shared 2-core machine, not the bench): %s.\n\n" % walls
    md = head + table(rows)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1, default=str)
    if a.md:
        with open(a.md, "w") as fh:
            fh.write(md)
    if a.status:
        with open(a.status, "w") as fh:
            fh.write("# hexsim on the real-log corpus: failures\n\n" + head)
            for r in rows:
                for f in r["fails"]:
                    fh.write("- %s %s: %s\n" % (r["log"], r["compass"], f))
    sys.stdout.write(md)


if __name__ == "__main__":
    main()
