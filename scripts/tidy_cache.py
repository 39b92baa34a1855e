#!/usr/bin/env python3
"""clang-tidy result cache for scripts/gates.sh (stage tidy), in the manner of ctcache.

clang-tidy's findings on a file depend only on what the compiler front end sees: the file's text with
every header it includes (comments kept: NOLINT lives there; macro definitions kept: the macro checks
read them), the compile flags, the clang-tidy version and .clang-tidy. This script hashes exactly that
input, with the checkout's root path replaced by a placeholder so the same tree gives the same keys in
any directory. A file whose key is listed in the manifest (.ci/tidy-clean.txt) was checked by the same
clang-tidy with zero findings; gates.sh checks every other file and, when all are clean, rewrites the
manifest. A stale or missing manifest only makes the gate slower, never weaker: any change to a file,
a header it includes, a flag, the tool or the configuration changes the key.

  tidy_cache.py select DB ROOT FILES MANIFEST   -> prints the files to check; writes FILES.keys
  tidy_cache.py update FILES.keys MANIFEST ROOT OUT_DIR
      -> rewrites the manifest: the files listed before and those checked now with exit status 0
"""
import concurrent.futures
import hashlib
import json
import os
import shlex
import subprocess
import sys


def tool_identity(root):
    version = subprocess.run(["clang-tidy", "--version"], capture_output=True, text=True).stdout
    # The first lines name the version; "Host CPU" differs between machines and changes nothing.
    version = "\n".join(l for l in version.splitlines() if "Host CPU" not in l)
    with open(os.path.join(root, ".clang-tidy"), "rb") as f:
        config = f.read()
    return version.encode() + b"\0" + config


def preprocess_args(entry):
    args = shlex.split(entry["command"]) if "command" in entry else list(entry["arguments"])
    out = []
    skip = False
    for a in args:
        if skip:
            skip = False
            continue
        if a == "-o":
            skip = True
            continue
        if a == "-c":
            continue
        out.append(a)
    return out


def key_of(entry, root, identity):
    args = preprocess_args(entry)
    # -E -C -dD: the preprocessed text with comments and macro definitions, line markers kept.
    proc = subprocess.run(args + ["-E", "-C", "-dD"], cwd=entry["directory"], capture_output=True)
    if proc.returncode != 0:
        return None  # let clang-tidy itself report what is wrong with the file
    h = hashlib.sha256()
    h.update(identity)
    h.update("\0".join(args).replace(root, "<root>").encode())
    h.update(b"\0")
    h.update(proc.stdout.replace(root.encode(), b"<root>"))
    return h.hexdigest()


def read_manifest(manifest_path):
    """The keys listed in the manifest (none if it does not exist)."""
    if not os.path.exists(manifest_path):
        return set()
    with open(manifest_path) as f:
        return {l.split()[0] for l in f if l.strip() and not l.startswith("#")}


def select(db_path, root, files_path, manifest_path):
    with open(db_path) as f:
        entries = {e["file"]: e for e in json.load(f)}
    with open(files_path) as f:
        files = [l.strip() for l in f if l.strip()]
    clean = read_manifest(manifest_path)
    identity = tool_identity(root)
    jobs = int(os.environ.get("HEXSIM_GATES_JOBS", os.cpu_count() or 2))
    with concurrent.futures.ThreadPoolExecutor(max_workers=jobs) as pool:
        keys = list(pool.map(lambda p: key_of(entries[p], root, identity), files))
    with open(files_path + ".keys", "w") as f:
        for path, key in zip(files, keys):
            f.write(f"{key or 'none'} {os.path.relpath(path, root)}\n")
    todo = [p for p, k in zip(files, keys) if k is None or k not in clean]
    print("\n".join(todo))
    print(f"tidy cache: {len(files) - len(todo)} of {len(files)} files unchanged since a clean run "
          f"({os.path.relpath(manifest_path, root)}), {len(todo)} to check", file=sys.stderr)


def update(keys_path, manifest_path, root, out_dir):
    """Keeps the key of every file that is clean: listed before, or checked now with exit status 0."""
    old = read_manifest(manifest_path)
    with open(keys_path) as f:
        rows = [l.split() for l in f if l.strip()]
    clean = []
    for key, rel in rows:
        if key == "none":
            continue
        log = os.path.join(out_dir, os.path.join(root, rel).replace("/", "_") + ".log")
        checked_clean = False
        if os.path.exists(log):
            with open(log, errors="replace") as f:
                checked_clean = "tidy-exit 0" in f.read().splitlines()
        if key in old or checked_clean:
            clean.append((rel, key))
    with open(manifest_path + ".tmp", "w") as f:
        f.write("# clang-tidy keys of files checked clean (scripts/tidy_cache.py; written by "
                "scripts/gates.sh tidy)\n")
        for rel, key in sorted(clean):
            f.write(f"{key} {rel}\n")
    os.replace(manifest_path + ".tmp", manifest_path)
    print(f"tidy cache: {len(clean)} of {len(rows)} files recorded clean in "
          f"{os.path.relpath(manifest_path, root)}", file=sys.stderr)


if __name__ == "__main__":
    if len(sys.argv) == 6 and sys.argv[1] == "select":
        select(*sys.argv[2:6])
    elif len(sys.argv) == 6 and sys.argv[1] == "update":
        update(*sys.argv[2:6])
    else:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
