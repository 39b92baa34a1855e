"""Write the corpus index (README.md beside the logs) from sources.json and the logs themselves.

usage: index.py CORPUS_DIR  (the sources are CORPUS_DIR/sources.json, which gather.py writes beside
the logs; where it is absent, the sources.json of this script's folder)
"""

import datetime
import json
import os
import sys

import numpy as np

import extract
import reference


def describe(root, src):
    f = extract.read(os.path.join(root, src["file"]))
    fl = sum(b - a for a, b in f.segs)
    cur = reference.current_usability(f)
    comps = []
    for c in f.compasses:
        live = len(c["t"]) and np.ptp(c["xyz"], axis=0).max() > 0
        ext = {None: "?", True: "external", False: "internal"}[c["external"]]
        comps.append("%s %s%s" % (c["name"], ext, "" if live else " (constant: not logged)"))
    return f, fl, cur, comps


def main(root):
    here = os.path.dirname(os.path.abspath(__file__))
    beside = os.path.join(root, "sources.json")
    sources = json.load(open(beside if os.path.exists(beside) else os.path.join(here, "sources.json")))
    out = ["# Real-log corpus", "",
           "Public real flight logs for hexsim's issue-29 checks, gathered with the search tool's "
           "`fetch` (snapshots of public GitHub repositories). Written by "
           "`scripts/corpus/index.py %s` on %s. The logs stay here, outside the repository: "
           "only a log whose licence allows it may ever be committed." %
           (root, datetime.date.today().isoformat()), "",
           "Columns: flight = armed with mean motor output above 0.25 of the PWM range, 2 s cut at "
           "each end, segments >= 5 s; current = flight-window median; usable = >= 0.5 A per motor "
           "and >= 2.5 V per cell (>= 3 V in all where the cell count is unknown).", "",
           "| file | source (repo: path @ commit) | licence | autopilot | frame, motors | "
           "log s | flight s | current in flight | compasses |",
           "|---|---|---|---|---|---|---|---|---|"]
    for s in sources:
        try:
            f, fl, cur, comps = describe(root, s)
        except Exception as e:  # the index lists a broken log rather than stopping
            out.append("| %s | %s | %s | unreadable: %s |" % (s["file"], s["repo"], s["licence"], e))
            continue
        out.append("| `%s` | %s: `%s` @ %s | %s | %s | %s, %s | %.0f | %.0f | %s | %s |" % (
            s["file"], s["repo"], s["path"], s["commit"][:10], s["licence"], f.version,
            f.frame or "not logged", f.motors or "?", f.duration_s, fl, cur["text"],
            "; ".join(comps) or "none logged"))
    out += ["", "Sources: %d logs from %d repositories." % (
        len(sources), len(set(s["repo"] for s in sources))), "",
            "Beside this file, written by `bash scripts/corpus/run.sh HEXSIM`: `reference.md`/`.json` "
            "(the independent reference per compass), `check.md`/`.json` (hexsim against it) and "
            "`STATUS.md` (the failures only)."]
    with open(os.path.join(root, "README.md"), "w") as fh:
        fh.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main(sys.argv[1])
