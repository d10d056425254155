#!/usr/bin/python3
"""The house's rule for folders (issue 51): rooms by concern, and includes that run one way.

Checks, over the project's own sources (raster/, vector/, service/, python/, tests/, bench/):
  1. no source folder holds more than 20 source files (C++ sources and headers, Python, shell,
     JavaScript, CMake lists; data such as fuzz corpora and fixtures are not sources);
  2. every quoted #include resolves to a file of the repository (or to a header the build
     generates, listed below), so that no edge of the graph goes unseen;
  3. the floors keep their order: raster/ includes only itself, vector/ includes raster/ and
     itself, service/ all three; nothing includes tests/ or bench/ from outside them;
  4. no include cycle between folders (directories), nor between rooms: a room is a concern of a
     floor, its public headers and its sources together (raster/include/rv/lines and
     raster/src/lines are the room raster/lines), so that a room's sources may not include the
     public header of a room that includes its own.
Then it prints which folder includes which, with the number of include lines of each edge.

An include is resolved as the compiler does: the including file's own folder first, then the
include directories the CMake lists give (the floors' include/ and src/, tests/support, the
test floor's folder).

usage:
  tools/check-folders.py [--quiet]    # check the repository; exit 1 and list what is wrong
  tools/check-folders.py --self-test  # the checks on a made-up tree that breaks each of them
"""
import os
import re
import sys
import tempfile

MAX_FILES = 20
SOURCE_EXT = (".cpp", ".hpp", ".h", ".py", ".sh", ".js", ".cmake", ".in")
CPP_EXT = (".cpp", ".hpp", ".h")
TREES = ["raster", "vector", "service", "python", "tests", "bench"]
SKIP = ("tests/fuzz/corpus",)
INCLUDE_DIRS = ["raster/include", "raster/src", "vector/include", "vector/src", "service/include",
                "service/src", "tests/support"]
GENERATED = {"rv/version.hpp"}  # service/include/rv/version.hpp.in, configured by CMake
FLOOR_MAY_INCLUDE = {
    "raster": {"raster"},
    "vector": {"raster", "vector"},
    "service": {"raster", "vector", "service"},
    "python": {"raster", "vector", "service", "python"},
    "tests": {"raster", "vector", "service", "python", "tests"},
    "bench": {"raster", "vector", "service", "bench"},
}
INCLUDE_RE = re.compile(r'^\s*#\s*include\s*"([^"]+)"', re.M)


def is_source(name):
    return name.endswith(SOURCE_EXT) or name == "CMakeLists.txt"


def scan(root):
    """{folder: [files]} of source files, folders relative to root."""
    folders = {}
    for tree in TREES:
        for dirpath, dirnames, filenames in os.walk(os.path.join(root, tree)):
            rel = os.path.relpath(dirpath, root)
            if rel.startswith(SKIP) or "node_modules" in rel.split(os.sep):
                dirnames[:] = []
                continue
            dirnames.sort()
            files = sorted(f for f in filenames if is_source(f))
            if files:
                folders[rel] = files
    return folders


def resolve(root, path, spelled):
    folder = os.path.dirname(path)
    candidates = [folder] + INCLUDE_DIRS
    parts = path.split("/")
    if parts[0] == "tests" and len(parts) > 2:
        candidates.append("/".join(parts[:2]))  # the test floor's own helpers
    for c in candidates:
        p = os.path.normpath(os.path.join(c, spelled))
        if os.path.isfile(os.path.join(root, p)):
            return p
    return None


def include_edges(root, folders):
    """(edges {(from, to): [file:line ...]}, problems)."""
    edges, problems = {}, []
    for folder, files in folders.items():
        for name in files:
            if not name.endswith(CPP_EXT):
                continue
            path = os.path.join(folder, name)
            text = open(os.path.join(root, path), encoding="utf-8", errors="replace").read()
            for m in INCLUDE_RE.finditer(text):
                spelled = m.group(1)
                line = text.count("\n", 0, m.start()) + 1
                target = resolve(root, path, spelled)
                if target is None:
                    if spelled not in GENERATED:
                        problems.append(f'{path}:{line}: "{spelled}" resolves to no file of the repository')
                    continue
                src_floor, dst_floor = folder.split("/")[0], target.split("/")[0]
                if dst_floor not in FLOOR_MAY_INCLUDE.get(src_floor, {src_floor}):
                    problems.append(f"{path}:{line}: {src_floor}/ may not include {target} (not a floor below it)")
                dst = os.path.dirname(target)
                if dst != folder:
                    edges.setdefault((folder, dst), []).append(f"{path}:{line}")
    return edges, problems


def cycles(nodes, edges):
    """The groups of more than one node that reach each other (the graph's cycles, merged)."""
    out = {n: set() for n in nodes}
    for a, b in edges:
        out[a].add(b)

    def reach(n):
        seen, todo = set(), [n]
        while todo:
            for w in out[todo.pop()] - seen:
                seen.add(w)
                todo.append(w)
        return seen

    reached = {n: reach(n) for n in nodes}
    groups, placed = [], set()
    for n in sorted(nodes):
        if n not in placed:
            group = sorted({n} | {m for m in reached[n] if n in reached[m]})
            placed.update(group)
            if len(group) > 1:
                groups.append(group)
    return groups


def room_of(folder):
    """The room a folder belongs to: <floor>/include/rv/<room>/... and <floor>/src/<room>/... are
    <floor>/<room>; any other folder is its own room."""
    parts = folder.split("/")
    if len(parts) >= 4 and parts[1] == "include" and parts[2] == "rv":
        return f"{parts[0]}/{parts[3]}"
    if len(parts) >= 3 and parts[1] == "src":
        return f"{parts[0]}/{parts[2]}"
    return folder


def check(root, quiet=False, show=print):
    folders = scan(root)
    problems = []
    for folder, files in sorted(folders.items()):
        if len(files) > MAX_FILES:
            problems.append(f"{folder}/: {len(files)} source files (at most {MAX_FILES}): split it by concern")
    edges, include_problems = include_edges(root, folders)
    problems += include_problems
    nodes = set(folders) | {b for (_, b) in edges}
    for comp in cycles(nodes, edges):
        inside = [(a, b) for (a, b) in sorted(edges) if a in comp and b in comp]
        detail = "; ".join(f"{a} -> {b} ({edges[(a, b)][0]})" for a, b in inside)
        problems.append(f"include cycle between {', '.join(comp)}: {detail}")
    room_edges = {}
    for (a, b), where in edges.items():
        ra, rb = room_of(a), room_of(b)
        if ra != rb:
            room_edges.setdefault((ra, rb), []).extend(where)
    rooms = {room_of(n) for n in nodes}
    for comp in cycles(rooms, room_edges):
        inside = [(a, b) for (a, b) in sorted(room_edges) if a in comp and b in comp]
        detail = "; ".join(f"{a} -> {b} ({room_edges[(a, b)][0]})" for a, b in inside)
        problems.append(f"include cycle between rooms {', '.join(comp)}: {detail}")
    if not quiet:
        show("Folders (source files) and what each includes (include lines):")
        for folder in sorted(folders):
            targets = sorted((b, len(v)) for (a, b), v in edges.items() if a == folder)
            shown = ", ".join(f"{b} {n}" for b, n in targets) or "-"
            show(f"  {folder}/ ({len(folders[folder])}) -> {shown}")
    return problems


def self_test():
    """Each rule on a tree made to break it, and a clean tree that passes."""
    def tree(files):
        d = tempfile.mkdtemp(prefix="rv-folders-")
        for path, text in files.items():
            os.makedirs(os.path.join(d, os.path.dirname(path)), exist_ok=True)
            open(os.path.join(d, path), "w").write(text)
        return d

    clean = {
        "raster/include/rv/field/grid.hpp": "#pragma once\n",
        "raster/src/field/grid.cpp": '#include "rv/field/grid.hpp"\n',
        "raster/src/engine/engine.cpp": '#include "rv/field/grid.hpp"\n#include "field/codec.hpp"\n',
        "raster/src/field/codec.hpp": "#pragma once\n",
        "vector/src/reading/read.cpp": '#include "rv/field/grid.hpp"\n',
        "tests/raster/field/test_grid.cpp": '#include "rv/field/grid.hpp"\n#include "helper.hpp"\n',
        "tests/raster/helper.hpp": "#pragma once\n",
    }
    cases = {
        "clean": (clean, None),
        "too many files": (dict(clean, **{f"raster/src/lines/l{i}.cpp": "" for i in range(21)}), "21 source files"),
        "cycle": (dict(clean, **{"raster/src/field/back.cpp": '#include "engine/culling.hpp"\n',
                                 "raster/src/engine/culling.hpp": "#pragma once\n"}),
                  "include cycle between raster/src/engine, raster/src/field"),
        "cycle through a public header": (
            dict(clean, **{"raster/include/rv/field/up.hpp": '#include "rv/lines/b.hpp"\n',
                           "raster/include/rv/lines/b.hpp": '#include "rv/field/grid.hpp"\n'}),
            "include cycle between raster/include/rv/field, raster/include/rv/lines"),
        "cycle between rooms": (
            dict(clean, **{"raster/include/rv/engine/e.hpp": '#include "rv/field/grid.hpp"\n',
                           "raster/src/field/f.cpp": '#include "rv/engine/e.hpp"\n'}),
            "include cycle between rooms raster/engine, raster/field"),
        "unresolved include": (dict(clean, **{"raster/src/field/x.cpp": '#include "nowhere.hpp"\n'}),
                                          "resolves to no file"),
        "floor order": (dict(clean, **{"raster/src/field/y.cpp": '#include "reading/z.hpp"\n',
                                       "vector/src/reading/z.hpp": "#pragma once\n"}),
                        "raster/ may not include vector/src/reading/z.hpp"),
    }
    failed = 0
    for name, (files, expect) in cases.items():
        lines = []
        problems = check(tree(files), show=lines.append)
        ok = (not problems) if expect is None else any(expect in p for p in problems)
        if name == "clean":
            ok = ok and any("raster/src/engine/ (1) -> raster/include/rv/field 1, raster/src/field 1" in l for l in lines)
        print(("ok   " if ok else "FAIL ") + name + ("" if ok else f": {problems or lines}"))
        failed += not ok
    return 1 if failed else 0


def main():
    if "--self-test" in sys.argv:
        return self_test()
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    problems = check(root, quiet="--quiet" in sys.argv)
    for p in problems:
        print("check-folders: " + p)
    print(f"check-folders: {len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
