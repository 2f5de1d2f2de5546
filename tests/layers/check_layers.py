#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Lists every include in libnebula that runs up a layer (docs/ARCHITECTURE.md).

Usage: tests/layers/check_layers.py [REPO_ROOT]
Prints each upward include as "file:line: <layer> includes <layer> (header)" and the totals;
exits 1 if there is any, or if a render/ file sees OpenVDB (an <openvdb/...> include, itself
or through the headers it includes) or names GridSet: scenes are assembled in stages/. The build enforces the same rule (each layer is a CMake target that
sees only its own and lower layers' headers); this script is the quick, readable check.
"""
import pathlib
import re
import sys

LAYERS = ["core", "volume", "physics", "io", "render", "stages", "cli", "serve"]
INCLUDE = re.compile(r'^\s*#\s*include\s+[<"]nebula/([a-z]+)/([A-Za-z0-9_]+\.h)[>"]')
LOCAL = re.compile(r'^\s*#\s*include\s+"([A-Za-z0-9_]+\.h)"')
OPENVDB = re.compile(r'^\s*#\s*include\s+<openvdb/')
NO_OPENVDB = ["render"]  # layers that know no files: no OpenVDB, even through a header


def sees_openvdb(path, lib, seen):
    """The chain of files by which @p path includes an OpenVDB header, or None."""
    if path in seen:
        return seen[path]
    seen[path] = None
    for line in path.read_text().splitlines():
        if OPENVDB.match(line):
            seen[path] = [path]
            break
        m = INCLUDE.match(line)
        local = LOCAL.match(line)
        target = (lib / "include" / "nebula" / m.group(1) / m.group(2) if m
                  else path.parent / local.group(1) if local else None)
        if target is not None and target.exists():
            chain = sees_openvdb(target, lib, seen)
            if chain:
                seen[path] = [path] + chain
                break
    return seen[path]


def files_seeing_openvdb(files, lib, root):
    """Prints each file of a NO_OPENVDB layer that sees OpenVDB or names GridSet."""
    bad = 0
    seen = {}
    for path in files:
        if layer_of(path, lib) not in NO_OPENVDB:
            continue
        chain = sees_openvdb(path, lib, seen)
        if chain:
            print(f"{path.relative_to(root)}: sees OpenVDB through "
                  + " -> ".join(str(p.relative_to(root)) for p in chain[1:]))
            bad += 1
        if "GridSet" in path.read_text():
            print(f"{path.relative_to(root)}: names GridSet (scenes are assembled in stages/)")
            bad += 1
    return bad


def layer_of(path, lib):
    rel = path.relative_to(lib)
    # libnebula/include/nebula/<layer>/x.h or libnebula/src/<layer>/x.cpp
    parts = rel.parts
    if parts[0] == "include":
        return parts[2]
    return parts[1]


def main():
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else ".").resolve()
    lib = root / "libnebula"
    files = sorted(p for p in lib.rglob("*") if p.suffix in (".h", ".cpp"))
    total = upward = 0
    for path in files:
        own = layer_of(path, lib)
        if own not in LAYERS:
            print(f"{path.relative_to(root)}: not in a layer folder ({', '.join(LAYERS)})")
            upward += 1
            continue
        for number, line in enumerate(path.read_text().splitlines(), 1):
            m = INCLUDE.match(line)
            if not m:
                continue
            total += 1
            target = m.group(1)
            if target not in LAYERS:
                print(f"{path.relative_to(root)}:{number}: unknown layer '{target}'")
                upward += 1
            elif LAYERS.index(target) > LAYERS.index(own):
                print(f"{path.relative_to(root)}:{number}: {own} includes {target} "
                      f"({m.group(1)}/{m.group(2)})")
                upward += 1
    print(f"{total} includes between libnebula modules, {upward} upward")
    blind = files_seeing_openvdb(files, lib, root)
    print(f"{blind} files of {', '.join(NO_OPENVDB)} seeing OpenVDB or GridSet")
    return 1 if upward or blind else 0


if __name__ == "__main__":
    sys.exit(main())
