#!/usr/bin/env python3
"""Gathers the corpus logs named in a sources file from git mirrors of their repositories.

    python3 scripts/corpus/gather.py SOURCES.json MIRROR_ROOT CORPUS_DIR

SOURCES.json: a list of {"file", "repo", "path", "commit", "licence"} (scripts/corpus/sources.json).
MIRROR_ROOT/<owner>+<name>/repo is a bare git directory of each repository (what the session's
`fetch` tool writes under /work/.mirror). Each log is written to CORPUS_DIR/<file> from
`git show <commit>:<path>` (the newest commit holding the path where the named one is absent) and the
sources file is copied beside them as CORPUS_DIR/sources.json. Prints one line per log; exits 1 if any
log could not be gathered (the others are still written). The logs are not redistributable in
general: never commit CORPUS_DIR.
"""
import json
import os
import subprocess
import sys


def git(gitdir, *args):
    return subprocess.run(["git", "--git-dir", gitdir, *args], capture_output=True, check=False)


def main(argv):
    if len(argv) != 4:
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    sources_path, mirror, corpus = argv[1:]
    sources = json.load(open(sources_path))
    os.makedirs(corpus, exist_ok=True)
    missing = 0
    for s in sources:
        gitdir = os.path.join(mirror, s["repo"].replace("/", "+"), "repo")
        if os.path.isdir(os.path.join(gitdir, ".git")):
            gitdir = os.path.join(gitdir, ".git")
        out = git(gitdir, "show", f"{s.get('commit', 'HEAD')}:{s['path']}")
        if out.returncode != 0:
            rev = git(gitdir, "log", "--all", "-1", "--format=%H", "--", s["path"]).stdout.decode().strip()
            out = git(gitdir, "show", f"{rev}:{s['path']}") if rev else out
        dest = os.path.join(corpus, s["file"])
        if out.returncode != 0 or not out.stdout:
            print(f"MISSING {s['file']}: {s['repo']}:{s['path']} ({out.stderr.decode().strip()[:120]})")
            missing += 1
            continue
        os.makedirs(os.path.dirname(dest), exist_ok=True)
        with open(dest, "wb") as f:
            f.write(out.stdout)
        print(f"ok {s['file']} ({len(out.stdout)} bytes)")
    with open(os.path.join(corpus, "sources.json"), "w") as f:
        json.dump(sources, f, indent=1)
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
