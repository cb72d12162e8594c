#!/usr/bin/env python3
"""Layering check: no code includes or links anything of a higher layer (docs/architecture.md).

Layers, lowest first (a folder may use its own layer and every lower one):
  core < lcmtypes < drivers, logs < fusion < odometry < tools < viewer < tests, examples
drivers and logs are siblings: neither uses the other. fixtures/ (synthetic scenes and
sequences for tests) sits just above drivers and logs and may be used by test and benchmark
code of every folder, never by a library or program.

Two checks, both per top-level folder:
  * includes: every "#include "pplvo/<dir>/..."" and <pplvo_msgs/...> of a source file, and every
    quoted include that resolves relative to the file, is mapped to the folder that owns it
    (the folder holding include/pplvo/<dir>; pplvo_msgs is lcmtypes);
  * links and include directories: the target table written by cmake/PplvoLayering.cmake at
    configure time (each target's folder, whether it is test code, the project targets it links
    and the source folders it adds to its include path).
Test code: files under a test/, tests/, testdata/ or bench/ folder, targets made by pplvo_test
or pplvo_benchmark.

Usage: check_layers.py --source DIR [--targets FILE] [--allow FILE]
The allowlist holds lines "include FILE HEADER" or "link TARGET DEPENDENCY" ('#' comments);
an entry that no longer matches anything is an error too, so that it goes with its reason.
Exit 0 when clean, 1 on violations (each printed), 2 on usage errors.
"""

import argparse
import os
import re
import sys

RANK = {
    "core": 0,
    "lcmtypes": 1,
    "node": 1.5,
    "drivers": 2,
    "logs": 2,
    "fixtures": 2.5,
    "fusion": 3,
    "odometry": 4,
    "tools": 5,
    "viewer": 6,
    "tests": 7,
    "examples": 7,
}
TEST_ONLY = {"fixtures"}  # layers only test code may use
TEST_DIRS = {"test", "tests", "testdata", "bench"}
SOURCE_EXT = (".cpp", ".cc", ".h", ".hpp")
SKIP_DIRS = {".git", "build", ".ccache"}
INCLUDE_RE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]')


def top_folder(rel_path):
    return rel_path.split("/", 1)[0]


def is_test_path(rel_path):
    parts = rel_path.split("/")
    return parts[0] == "tests" or any(p in TEST_DIRS for p in parts[1:-1])


def allowed(from_folder, from_test, to_folder):
    """None when a use of to_folder by from_folder (test code or not) is fine, else why not."""
    if from_folder == to_folder:
        return None
    if from_folder not in RANK or to_folder not in RANK:
        return None  # not a layered folder (scripts, cmake, docs)
    if to_folder in TEST_ONLY:
        return None if from_test or from_folder in TEST_ONLY else "test-only layer"
    if RANK[to_folder] < RANK[from_folder]:
        return None
    if RANK[to_folder] == RANK[from_folder]:
        return "sibling layer"
    return "upward"


def header_owners(source):
    """pplvo/<dir> -> top-level folder that holds <...>/include/pplvo/<dir>."""
    owners = {"pplvo_msgs": "lcmtypes"}
    for root, dirs, _ in os.walk(source):
        dirs[:] = sorted(d for d in dirs if d not in SKIP_DIRS)
        rel = os.path.relpath(root, source).replace(os.sep, "/")
        if rel.endswith("/include/pplvo") or rel == "include/pplvo":
            for d in dirs:
                owners["pplvo/" + d] = top_folder(rel)
    return owners


def source_files(source):
    for root, dirs, files in os.walk(source):
        dirs[:] = sorted(d for d in dirs if d not in SKIP_DIRS and not d.startswith("build"))
        for f in sorted(files):
            if f.endswith(SOURCE_EXT):
                path = os.path.join(root, f)
                yield path, os.path.relpath(path, source).replace(os.sep, "/")


def include_owner(include, bracket, path, source, owners):
    parts = include.split("/")
    if parts[0] == "pplvo" and len(parts) > 2:
        return owners.get("pplvo/" + parts[1])
    if parts[0] == "pplvo_msgs":
        return owners["pplvo_msgs"]
    if bracket == '"':
        resolved = os.path.normpath(os.path.join(os.path.dirname(path), include))
        if os.path.isfile(resolved):
            rel = os.path.relpath(resolved, source).replace(os.sep, "/")
            if not rel.startswith(".."):
                return top_folder(rel)
    return None


def check_includes(source, owners, allow, used):
    errors = []
    for path, rel in source_files(source):
        folder, test = top_folder(rel), is_test_path(rel)
        with open(path, encoding="utf-8", errors="replace") as f:
            for lineno, line in enumerate(f, 1):
                m = INCLUDE_RE.match(line)
                if not m:
                    continue
                owner = include_owner(m.group(2), m.group(1), path, source, owners)
                if owner is None:
                    continue
                why = allowed(folder, test, owner)
                if why is None:
                    continue
                key = ("include", rel, m.group(2))
                if key in allow:
                    used.add(key)
                    continue
                errors.append(f"{rel}:{lineno}: includes {m.group(2)} of {owner} "
                              f"({why}: {folder} is layer {RANK[folder]}, {owner} {RANK[owner]})")
    return errors


def read_targets(path):
    """name -> (folder, test, [links], [include folders])"""
    targets = {}
    with open(path, encoding="utf-8") as f:
        for line in f:
            line = line.rstrip("\n")
            if not line or line.startswith("#"):
                continue
            name, folder, test, links, incs = (line.split("\t") + [""] * 5)[:5]
            targets[name] = (folder, test == "1", [x for x in links.split(";") if x],
                             [x for x in incs.split(";") if x])
    return targets


def check_targets(targets, allow, used):
    errors = []
    for name in sorted(targets):
        folder, test, links, incs = targets[name]
        for dep in links:
            if dep not in targets:
                continue  # a system library
            owner = targets[dep][0]
            why = allowed(folder, test, owner)
            if why is None:
                continue
            key = ("link", name, dep)
            if key in allow:
                used.add(key)
                continue
            errors.append(f"target {name} ({folder}) links {dep} of {owner} ({why})")
        for inc in incs:
            owner = top_folder(inc)
            why = allowed(folder, test, owner)
            if why is not None:
                errors.append(f"target {name} ({folder}) adds include directory {inc} ({why})")
    return errors


def read_allowlist(path):
    allow = set()
    if not path:
        return allow
    with open(path, encoding="utf-8") as f:
        for lineno, line in enumerate(f, 1):
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            fields = line.split()
            if len(fields) != 3 or fields[0] not in ("include", "link"):
                raise ValueError(f"{path}:{lineno}: expected 'include FILE HEADER' or "
                                 f"'link TARGET DEPENDENCY'")
            allow.add(tuple(fields))
    return allow


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--source", required=True, help="source tree root")
    p.add_argument("--targets", help="target table from cmake/PplvoLayering.cmake")
    p.add_argument("--allow", help="allowlist file")
    a = p.parse_args(argv)
    try:
        allow = read_allowlist(a.allow)
    except (OSError, ValueError) as e:
        print(e, file=sys.stderr)
        return 2
    used = set()
    source = os.path.abspath(a.source)
    errors = check_includes(source, header_owners(source), allow, used)
    if a.targets:
        errors += check_targets(read_targets(a.targets), allow, used)
    for key in sorted(allow - used):
        errors.append(f"allowlist entry no longer needed (remove it): {' '.join(key)}")
    for e in errors:
        print(e)
    if errors:
        print(f"{len(errors)} layering violation(s); layers: docs/architecture.md")
        return 1
    print("layering: clean" + (f" ({len(used)} allowlisted)" if used else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
