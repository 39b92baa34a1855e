"""Judging one gap.json against a case's truth, and the tables.

A planted effect is right when (1) one of its names is in the target channel's `effects`, (2) the
headline (`verdict`) is one of the case's names, (3) where its size is a defined number, the
reported 95 % interval widened by 0.2 of its width (0.1 on each side) holds the truth, and (4) for
a lagged current field, timing.current_field_lag_s's interval, widened the same way, holds the lag.
A clean case is right when no compass channel lists an effect and every verdict is `none`. Without
--sim the identified vehicle carries no wiring (README, "Sim-to-real gap"): a current-driven effect
there is the vehicle's own modelled field, correct on every internal compass, so it is no false
alarm and no wrong headline.
"""
import json

CURRENT_NAMES = {"current_hard_iron", "per_motor_current_hard_iron", "current_lag", "throttle_hard_iron"}
WIDEN = 0.1  # of the interval's width, on each side
# A lag needs the current to move: below this 5-95 % span a lag is not observable (gap's in-flight
# model asks 3 A to separate a current field from the offset at all), so it is not judged.
MIN_SPAN_A = 3.0


def widened_holds(lo, hi, x):
    w = hi - lo
    return lo - WIDEN * w <= x <= hi + WIDEN * w


def _channel(gap, name):
    for c in gap.get("channels", []):
        if c.get("channel") == name:
            return c
    return None


def _eff_text(effects):
    out = []
    for e in effects:
        lo, hi = e["ci95"]
        out.append(f"{e['effect']} {e['magnitude']:.4g} [{lo:.4g}, {hi:.4g}] ({100 * e['explained_share']:.0f} %)")
    return "; ".join(out) if out else "-"


def judge(case, gap, path, base=None):
    """path: 'sim' (--sim the unmodified vehicle) or 'nosim' (identified vehicle, from `base`: the
    shipped file gap diagnose chose for the frame). Where the base is another vehicle (paper_hex's
    frame picks default_hex), its compass calibration is not the flown one: the planted names are
    judged, not sizes, and a clean case is not judged (the calibration difference is a real gap)."""
    r = {"path": path, "ok": True, "why": []}
    other_base = path == "nosim" and base is not None and base != case["vehicle"]
    if other_base:
        r["base"] = base
    ch = _channel(gap, case["channel"])
    if ch is None:
        return {"path": path, "ok": False, "why": [f"no channel {case['channel']} in gap.json"], "verdict": "-", "effects": "-"}
    names = [e["effect"] for e in ch["effects"]]
    r["verdict"] = ch["verdict"] + (" (partial)" if ch.get("partial") else "")
    r["effects"] = _eff_text(ch["effects"])
    lag = ch.get("timing", {}).get("current_field_lag_s")
    if lag:
        r["current_field_lag"] = f"{lag['value']:.3g} [{lag['ci95'][0]:.3g}, {lag['ci95'][1]:.3g}] s"
    allowed_extra = CURRENT_NAMES if path == "nosim" else set()
    if not case["effects"]:
        if other_base:
            r["ok"] = None
            r["why"].append(f"not judged: compared with base {base}'s compass")
            return r
        for c in gap.get("channels", []):
            if not c["channel"].startswith("mag"):
                continue
            extra = [e["effect"] for e in c["effects"] if e["effect"] not in allowed_extra]
            # Without --sim, "ambiguous" between two names of the vehicle's own current field is right.
            own = c["verdict"] in allowed_extra or (c["verdict"] == "ambiguous" and c["effects"] and not extra)
            if extra or (c["verdict"] != "none" and not own):
                r["ok"] = False
                r["why"].append(f"false alarm on {c['channel']}: verdict {c['verdict']}, effects {extra}")
        return r
    accept_all = set()
    for eff in case["effects"]:
        acc = set(eff["accept"])
        accept_all |= acc
        hit = [e for e in ch["effects"] if e["effect"] in acc]
        if not hit:
            r["ok"] = False
            r["why"].append(f"{eff['form']} not in effects")
            continue
        mag_name = eff.get("magnitude_effect", eff["accept"][0])
        # Without --sim the current field is reported whole (planted + modelled), and against another
        # base's compass the calibration terms are that compass's: sizes not comparable there.
        check_mag = eff.get("magnitude") is not None and not (path == "nosim" and eff["form"] in
                                                                 ("current_hard_iron", "hard_iron"))
        check_mag = check_mag and not (other_base and eff["form"] != "latency")
        if check_mag:
            m = [e for e in hit if e["effect"] == mag_name]
            if not m:
                r["why"].append(f"{eff['form']}: named as {hit[0]['effect']}, its size not comparable")
            else:
                lo, hi = m[0]["ci95"]
                truth = eff["magnitude"]
                if not widened_holds(lo, hi, truth):
                    r["ok"] = False
                    r["why"].append(f"{eff['form']}: truth {truth:.4g} outside [{lo:.4g}, {hi:.4g}] (+0.2 width)")
        if eff.get("lag_s") is not None and case.get("current_span_A", 99) < MIN_SPAN_A:
            r["why"].append(f"{eff['form']}: lag not judged: the current spans {case['current_span_A']} A (< {MIN_SPAN_A} A)")
        elif eff.get("lag_s") is not None:
            if not lag:
                r["ok"] = False
                r["why"].append(f"{eff['form']}: no timing.current_field_lag_s (truth {eff['lag_s']:.2f} s)")
            elif not widened_holds(lag["ci95"][0], lag["ci95"][1], eff["lag_s"]):
                r["ok"] = False
                r["why"].append(f"{eff['form']}: lag {eff['lag_s']:.2f} s outside {r['current_field_lag']} (+0.2 width)")
    if ch["verdict"] not in accept_all and ch["verdict"] not in allowed_extra:
        r["ok"] = False
        r["why"].append(f"headline {ch['verdict']} is not a planted effect")
    extra = [n for n in names if n not in accept_all and n not in allowed_extra]
    if extra:
        r["extra"] = extra  # reported beside the judgement, not a failure by the brief's rules
    return r


def table(results):
    lines = ["| # | form | size | vehicle / mission / wind / log | channel | path | verdict | effects | lag | PASS | why |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for res in results:
        c = res["case"]
        size = "; ".join(e.get("size", "") for e in c["effects"]) or "-"
        wind = "calm" if not c["wind"] else f"{c['wind']['speed_mps']} m/s"
        for j in res.get("judgements", []):
            why = "; ".join(j.get("why", []))
            if j.get("extra"):
                why += ("; " if why else "") + "extra: " + ", ".join(j["extra"])
            lines.append(f"| {c['id']} | {c['form']} | {size} | {c['vehicle']} / {c['mission']} / {wind} / {c['log_form']} | "
                         f"{c['channel']} | {j['path']} | {j['verdict']} | {j['effects']} | {j.get('current_field_lag', '-')} | "
                         f"{'n/a' if j['ok'] is None else 'PASS' if j['ok'] else 'FAIL'} | {why} |")
        if res.get("error") or res.get("not_flown"):
            word, why = ("ERROR", res["error"]) if res.get("error") else ("not flown", res["not_flown"])
            lines.append(f"| {c['id']} | {c['form']} | {size} | {c['vehicle']} / {c['mission']} / {wind} / {c['log_form']} | "
                         f"{c.get('channel', '-')} | - | - | - | - | {word} | {why} |")
    return "\n".join(lines)


def per_form(results):
    counts = {}
    for res in results:
        form = res["case"]["form"]
        for j in res.get("judgements", []):
            if j["ok"] is None:
                continue
            k = (form, j["path"])
            p, n = counts.get(k, (0, 0))
            counts[k] = (p + (1 if j["ok"] else 0), n + 1)
    not_flown = sum(1 for r in results if r.get("not_flown"))
    lines = ["| form | path | pass / cases |", "|---|---|---|"]
    for (form, path), (p, n) in sorted(counts.items()):
        lines.append(f"| {form} | {path} | {p}/{n} |")
    tot = {}
    for (form, path), (p, n) in counts.items():
        a, b = tot.get(path, (0, 0))
        tot[path] = (a + p, b + n)
    for path, (p, n) in sorted(tot.items()):
        lines.append(f"| **all** | {path} | {p}/{n} |")
    lines.append(f"\n{not_flown} case(s) not flown to the end (not judged); n/a judgements not counted.")
    return "\n".join(lines), {f"{f}|{p}": v for (f, p), v in counts.items()}


def load(path):
    with open(path) as f:
        return json.load(f)
