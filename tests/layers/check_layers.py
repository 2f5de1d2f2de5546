#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Lists every include in libnebula that runs up a layer (docs/ARCHITECTURE.md).

Usage: tests/layers/check_layers.py [REPO_ROOT]
Prints each upward include as "file:line: <layer> includes <layer> (header)" and the totals;
exits 1 if there is any. The build enforces the same rule (each layer is a CMake target that
sees only its own and lower layers' headers); this script is the quick, readable check.
"""
import pathlib
import re
import sys

LAYERS = ["core", "volume", "physics", "io", "render", "stages", "cli", "serve"]
INCLUDE = re.compile(r'^\s*#\s*include\s+[<"]nebula/([a-z]+)/([A-Za-z0-9_]+\.h)[>"]')


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
    return 1 if upward else 0


if __name__ == "__main__":
    sys.exit(main())
