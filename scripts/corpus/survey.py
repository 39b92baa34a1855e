"""One line of facts per log: version, frame, motors, duration, flight time, current, compasses."""

import json
import sys

import numpy as np

import extract


def facts(path):
    f = extract.read(path)
    fl = sum(b - a for a, b in f.segs)
    cur = "none"
    if f.cur_a is not None and len(f.cur_a):
        m = extract.in_segments(f.cur_t, f.segs)
        if m.any():
            cur = "%.1f A median, %.1f V" % (np.median(f.cur_a[m]), np.median(f.volt_v[m]))
        else:
            cur = "logged (no flight)"
    comps = ["%s%s" % (c["name"], {None: "?", True: " ext", False: " int"}[c["external"]])
             for c in f.compasses if len(c["t"]) and np.ptp(c["xyz"], axis=0).max() > 0]
    return {"path": path, "kind": f.kind, "version": f.version, "frame": f.frame,
            "motors": f.motors, "duration_s": round(f.duration_s, 1),
            "flight_s": round(fl, 1), "current": cur, "compasses": comps}


if __name__ == "__main__":
    for p in sys.argv[1:]:
        try:
            print(json.dumps(facts(p)))
        except Exception as e:  # a survey line per file, whatever breaks
            print(json.dumps({"path": p, "error": "%s: %s" % (type(e).__name__, e)}))
        sys.stdout.flush()
