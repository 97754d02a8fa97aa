#!/usr/bin/env python3
"""The translation units scripts/tidy.sh runs clang-tidy on, and which of them it may skip.

Usage: tidy_units.py <compile_commands.json> <package root> <clang-tidy> <header filter>
       <cache folder or "">

Prints one line per translation unit of the database under src/ and examples/ (each once):
"<key> <file>" for a unit to run, "cached <file>" for one skipped. A unit is skipped when its
key is a file in the cache folder: scripts/tidy.sh writes the keys of the units a clean run
covered. The key is a SHA-256 of everything clang-tidy's answer on the unit depends on: the
clang-tidy version, .clang-tidy, the header filter, the unit's compile flags and the path and
contents of every file the unit includes (the compiler's -M list: the package's headers, the
generated message headers and the system headers). Paths under the package are taken relative to
it, so that a clone elsewhere finds the same keys. With no cache folder, every unit runs.
"""
import concurrent.futures
import hashlib
import json
import os
import shlex
import subprocess
import sys


def unit_arguments(entry):
    """The compile command of a database entry as a list of arguments."""
    if "arguments" in entry:
        return list(entry["arguments"])
    return shlex.split(entry["command"])


def dependencies(entry, args):
    """Every file the unit reads (itself included), from the compiler's -M list."""
    deps = []
    skip = False
    for a in args:
        if skip:
            skip = False
            continue
        if a in ("-o", "-MF", "-MT", "-MQ"):
            skip = True
            continue
        if a in ("-c", "-MD", "-MMD"):
            continue
        deps.append(a)
    out = subprocess.run(deps + ["-M"], cwd=entry["directory"],
                         check=True, capture_output=True, text=True).stdout
    files = []
    for token in out.replace("\\\n", " ").split()[1:]:
        files.append(os.path.realpath(os.path.join(entry["directory"], token)))
    return sorted(set(files))


def main():
    db_path, root, tidy, header_filter, cache = sys.argv[1:6]
    root = os.path.realpath(root)

    def rel(text):
        return text.replace(root + "/", "./").replace(root, ".")

    version = subprocess.run([tidy, "--version"], check=True, capture_output=True,
                             text=True).stdout
    with open(os.path.join(root, ".clang-tidy"), "rb") as f:
        config = f.read()
    units = []
    seen = set()
    for entry in json.load(open(db_path)):
        path = os.path.realpath(os.path.join(entry["directory"], entry["file"]))
        if os.path.relpath(path, root).split(os.sep)[0] in ("src", "examples") and path not in seen:
            seen.add(path)
            units.append((path, entry))

    def key(unit):
        path, entry = unit
        if not cache:
            return path, "run"
        args = unit_arguments(entry)
        h = hashlib.sha256()
        h.update(version.encode())
        h.update(config)
        h.update(rel(header_filter).encode() + b"\0")
        h.update(rel(" ".join(args)).encode() + b"\0")
        for dep in dependencies(entry, args):
            with open(dep, "rb") as f:
                h.update(rel(dep).encode() + b"\0" + hashlib.sha256(f.read()).digest())
        return path, h.hexdigest()

    with concurrent.futures.ThreadPoolExecutor(max_workers=os.cpu_count() or 2) as pool:
        for path, k in pool.map(key, units):
            cached = cache and os.path.exists(os.path.join(cache, k))
            print(("cached " if cached else k + " ") + path)


if __name__ == "__main__":
    main()
