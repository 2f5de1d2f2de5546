#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Checks that docs/ARCHITECTURE.md's layers and registries match the code.

Usage: tests/layers/check_architecture.py [REPO_ROOT] [--self-test]

Layers: the count ARCHITECTURE states ("libnebula is eight layers"; docs/layout.md and
libnebula/CMakeLists.txt say it too) equals the number of layers in its list ("Bottom to
top: `core`, ..."), and that list, in order, is the build's (NEBULA_LAYERS in
libnebula/CMakeLists.txt), check_layers.py's, the order of ARCHITECTURE's layer sections, and
(as a set) the folders of libnebula/include/nebula/ and libnebula/src/.

Registries: each row of the table in "Where to add ..." (| registry | header | registration
symbol | how to add | files touched | status |) names a header under
libnebula/include/nebula/ that exists and contains the symbol as a word. A row whose status
is "pending" is a registry not merged yet: it is reported, not failed.

Prints each mismatch; exits 1 if any. --self-test: the checks run on altered copies of the
document (a wrong count, a layer left out, a missing header, a missing symbol) must fail,
and the document as it is must pass.
"""
import pathlib
import re
import sys

NUMBERS = {w: i for i, w in enumerate(
    "zero one two three four five six seven eight nine ten eleven twelve".split())}
COUNT = re.compile(r"(?:libnebula|[Tt]he library) is (\w+) layers")


def number(word):
    return int(word) if word.isdigit() else NUMBERS.get(word.lower(), -1)


def section(text, heading):
    """The text of the section that starts with the line `heading`, up to the next one of
    the same level."""
    level = heading.split(" ")[0]
    start = text.find("\n" + heading)
    if start < 0:
        return ""
    end = re.compile(r"\n" + re.escape(level) + r" ").search(text, start + 1)
    return text[start:end.start() if end else len(text)]


def stated_layers(doc, errors):
    """The layer count and list ARCHITECTURE states."""
    layers = section(doc, "## The layers of libnebula")
    counts = COUNT.findall(layers)
    if not counts:
        errors.append("ARCHITECTURE.md: no \"libnebula is N layers\" in its layers section")
    listed = re.search(r"Bottom to top:(.*?)\.\s", layers, re.S)
    names = re.findall(r"`([a-z]+)`", listed.group(1)) if listed else []
    if not names:
        errors.append("ARCHITECTURE.md: no \"Bottom to top: `core`, ...\" list of the layers")
    for word in counts:
        if number(word) != len(names):
            errors.append(f"ARCHITECTURE.md says {word} layers, and lists {len(names)}: "
                          f"{', '.join(names)}")
    headings = re.findall(r"^### ([a-z]+): ", layers, re.M)
    if headings != names:
        errors.append(f"ARCHITECTURE.md's layer sections are {headings}, its list {names}")
    return names


def code_layers(root, errors):
    """The layers as the build, check_layers.py and the folders have them."""
    cmake = (root / "libnebula/CMakeLists.txt").read_text()
    found = re.search(r"set\(NEBULA_LAYERS ([a-z ]+)\)", cmake)
    build = found.group(1).split() if found else []
    if not build:
        errors.append("libnebula/CMakeLists.txt: no set(NEBULA_LAYERS ...)")
    for word in COUNT.findall(cmake):
        if number(word) != len(build):
            errors.append(f"libnebula/CMakeLists.txt says {word} layers, NEBULA_LAYERS has "
                          f"{len(build)}")
    layout = (root / "docs/layout.md").read_text()
    for word in COUNT.findall(layout):
        if number(word) != len(build):
            errors.append(f"docs/layout.md says {word} layers, the build has {len(build)}")
    check = (root / "tests/layers/check_layers.py").read_text()
    found = re.search(r"^LAYERS = \[(.*)\]", check, re.M)
    checked = re.findall(r'"([a-z]+)"', found.group(1)) if found else []
    if checked != build:
        errors.append(f"check_layers.py's LAYERS {checked} differ from NEBULA_LAYERS {build}")
    for folder in ("libnebula/include/nebula", "libnebula/src"):
        dirs = sorted(p.name for p in (root / folder).iterdir() if p.is_dir())
        if dirs != sorted(build):
            errors.append(f"{folder}/ holds {dirs}, NEBULA_LAYERS {build}")
    return build


def registry_rows(doc, errors):
    """The rows of the registry table in "Where to add ...", as dicts of the header cells."""
    where = section(doc, "## Where to add ...")
    lines = [line.strip() for line in where.splitlines() if line.strip().startswith("|")]
    if len(lines) < 3 or "registry" not in lines[0].lower():
        errors.append("ARCHITECTURE.md: no registry table (| registry | header | ...) in "
                      "\"Where to add ...\"")
        return []
    keys = [cell.strip().lower() for cell in lines[0].strip("|").split("|")]
    rows = []
    for line in lines[2:]:
        cells = [cell.strip().strip("`").strip() for cell in line.strip("|").split("|")]
        rows.append(dict(zip(keys, cells)))
    return rows


def check_registries(root, doc, errors, notes):
    rows = registry_rows(doc, errors)
    for row in rows:
        name = row.get("registry", "?")
        header = row.get("header", "")
        symbol = row.get("registration symbol", "")
        status = row.get("status", "").lower()
        if status not in ("", "pending", "done"):
            errors.append(f"registry {name}: status \"{status}\" is neither pending nor done")
        path = root / "libnebula/include/nebula" / header
        problem = ""
        if not header or not path.is_file():
            problem = f"header libnebula/include/nebula/{header} does not exist"
        elif not symbol or not re.search(r"\b" + re.escape(symbol) + r"\b", path.read_text()):
            problem = f"{header} does not name {symbol or '(no symbol)'}"
        if problem and status == "pending":
            notes.append(f"registry {name} (pending): {problem}")
        elif problem:
            errors.append(f"registry {name}: {problem}")
    return rows


def check(root, doc):
    errors, notes = [], []
    stated = stated_layers(doc, errors)
    build = code_layers(root, errors)
    if stated and build and stated != build:
        errors.append(f"ARCHITECTURE.md lists the layers {stated}, the build {build}")
    rows = check_registries(root, doc, errors, notes)
    return errors, notes, stated, rows


def self_test(root, doc):
    """Each altered document must fail; the document as it is must pass."""
    failures = []
    if check(root, doc)[0]:
        failures.append("the document as it is fails")
    count = COUNT.search(section(doc, "## The layers of libnebula"))
    alterations = {
        "a wrong layer count": doc.replace(count.group(0), count.group(0).replace(
            count.group(1), "seven" if count.group(1) != "seven" else "nine"), 1) if count
        else doc + "x",
        "a layer left out of the list": doc.replace(", `serve`", "", 1),
        "a layer section out of order": doc.replace("### volume: ", "### volumes: ", 1),
    }
    probe = "\n| probe | `{header}` | `{symbol}` | - | - | |"
    header_line = re.search(r"^\| registry \|.*\n\|[-| ]+\|\n", doc, re.M)
    if header_line:
        at = header_line.end() - 1
        for what, header, symbol in [("a missing header", "render/no_such_registry.h", "X"),
                                     ("a missing symbol", "io/cube_io.h", "NoSuchSymbol")]:
            alterations[what] = doc[:at] + probe.format(header=header, symbol=symbol) + doc[at:]
        passing = doc[:at] + probe.format(header="io/cube_io.h", symbol="CubeFormat") + doc[at:]
        if check(root, passing)[0]:
            failures.append("a done row with an existing header and symbol fails")
    else:
        failures.append("no registry table to alter")
    for what, altered in alterations.items():
        if altered == doc:
            failures.append(f"{what}: the document could not be altered")
        elif not check(root, altered)[0]:
            failures.append(f"{what}: passed")
    for failure in failures:
        print(f"self-test: {failure}")
    print(f"self-test: {len(alterations)} altered documents, {len(failures)} failures")
    return 1 if failures else 0


def main():
    args = [a for a in sys.argv[1:] if a != "--self-test"]
    root = pathlib.Path(args[0] if args else ".").resolve()
    doc = (root / "docs/ARCHITECTURE.md").read_text()
    if "--self-test" in sys.argv[1:]:
        return self_test(root, doc)
    errors, notes, stated, rows = check(root, doc)
    for line in errors + notes:
        print(line)
    print(f"{len(stated)} layers ({', '.join(stated)}), {len(rows)} registries, "
          f"{len(errors)} mismatches")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
