#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Opens nebgen's (also --spectral), nebionize's and nebillum's output in headless Blender and checks the grid
# names, voxel size, transform, active-voxel bounding box and value range that
# Blender sees against `vdb_print -l -m` (OpenVDB's own numbers).
#
#   run_blender_test.sh TOOLS_DIR WORK_DIR
#
# TOOLS_DIR holds nebgen, nebillum and nebionize; WORK_DIR is created if needed and this
# script's files in it are replaced. BLENDER and VDB_PRINT may name other
# executables. Exit 0 only if every check passed. A missing blender is a
# failure, not a skip.
set -u
set -o pipefail

if [ $# -ne 2 ]; then
    echo "usage: $0 TOOLS_DIR WORK_DIR" >&2
    exit 2
fi
TOOLS=$1
WORK=$2
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
CHECKER=$HERE/check_grids.py
BLENDER=${BLENDER:-blender}
VDB_PRINT=${VDB_PRINT:-vdb_print}

fail() {
    echo "FAIL: $*" >&2
    exit 1
}

command -v "$BLENDER" >/dev/null 2>&1 ||
    fail "blender not found (BLENDER=$BLENDER). This test needs Blender: install it (Debian 12: apt-get install blender) -- the project's test command installs it."
command -v "$VDB_PRINT" >/dev/null 2>&1 ||
    fail "vdb_print not found (VDB_PRINT=$VDB_PRINT): install libopenvdb-tools."
command -v python3 >/dev/null 2>&1 || fail "python3 not found (needed to parse vdb_print)."
for t in nebgen nebillum nebionize; do
    [ -x "$TOOLS/$t" ] || fail "$TOOLS/$t is missing or not executable."
done

mkdir -p "$WORK" || fail "cannot create $WORK"
WORK=$(cd "$WORK" && pwd)
rm -rf "$WORK/blender-user"
rm -f "$WORK"/nebula.* "$WORK"/lit.* "$WORK"/spectral.* "$WORK"/ionised.* "$WORK"/wrong_*
# Keep Blender away from the user's own configuration and scripts.
export BLENDER_USER_CONFIG=$WORK/blender-user/config
export BLENDER_USER_SCRIPTS=$WORK/blender-user/scripts
export BLENDER_USER_DATAFILES=$WORK/blender-user/datafiles

now_ms() { echo $(($(date +%s%N) / 1000000)); }
secs() { printf '%d.%d' $(($1 / 1000)) $(($1 % 1000 / 100)); }
T_START=$(now_ms)

RES=32
SIZE=10
echo "== generating a small nebula in $WORK (nebgen --res $RES --size $SIZE, nebillum)"
"$TOOLS/nebgen" --res $RES --size $SIZE -q -o "$WORK/nebula.vdb" || fail "nebgen failed"
"$TOOLS/nebillum" -q -i "$WORK/nebula.vdb" -o "$WORK/lit.vdb" || fail "nebillum failed"
# nebionize's grids: ionisation fractions and line emissivities (an O star in the cloud).
"$TOOLS/nebionize" -q -i "$WORK/nebula.vdb" --star o:0,0,0:2e5:40000 -o "$WORK/ionised.vdb" ||
    fail "nebionize failed"
# The spectral grids: temperature (float), velocity (vec3s, world space), emission.oiii.
"$TOOLS/nebgen" --res $RES --size $SIZE -q --spectral --rotation 20 --turbulence 5 --oiii 0.5 \
    -o "$WORK/spectral.vdb" || fail "nebgen --spectral failed"

# expected_json VDB OUT.json NOMINAL_VOXEL_SIZE REQUIRED_NAME...: OpenVDB's truth,
# parsed from vdb_print -l -m.
expected_json() {
    local vdb=$1 out=$2
    shift 2
    "$VDB_PRINT" -l -m "$vdb" >"$out.vdb_print.txt" 2>&1 ||
        fail "vdb_print -l -m $vdb failed: $(cat "$out.vdb_print.txt")"
    python3 - "$vdb" "$out.vdb_print.txt" "$out" "$@" <<'PY' || fail "cannot parse vdb_print output of $vdb (see $out.vdb_print.txt)"
import json, math, re, sys

vdb, txt, out, nominal, required = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4]), sys.argv[5:]

def half_ulp(s, digits):
    """vdb_print rounds to `digits` significant digits: the largest rounding error of s."""
    v = float(s)
    if v == 0.0:
        return 0.0  # a rounded non-zero value is never printed as 0 (it would read 1e-..)
    return 0.5 * 10.0 ** (math.floor(math.log10(abs(v))) - (digits - 1))

NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|[-+]?(?:inf|nan)"
grids, g, in_matrix = [], None, False
for line in open(txt):
    s = line.strip()
    m = re.match(r"^Name: (.*)$", s)
    if m and not line.startswith(" "):
        g = {"name": m.group(1), "matrix": []}
        grids.append(g)
        in_matrix = False
        continue
    if g is None:
        continue
    if in_matrix:
        m = re.match(r"^\[(.*)\]$", s)
        if m and len(g["matrix"]) < 4:
            g["matrix"].append(m.group(1).split(","))
            continue
        in_matrix = False
    if s.startswith("Type: "):
        g["tree_type"] = s[6:]
    elif s.startswith("Min value: "):
        g["min_printed"] = s[11:]
    elif s.startswith("Max value: "):
        g["max_printed"] = s[11:]
    elif s.startswith("Number of active voxels:"):
        g["active_voxels"] = int(s.split(":")[1].replace(",", "").strip())
    elif s.startswith("Bounding box of active voxels:"):
        a, b = s.split(":", 1)[1].split("->")
        g["index_bbox"] = [[int(x) for x in re.findall(r"-?\d+", a)],
                           [int(x) for x in re.findall(r"-?\d+", b)]]
    elif s.startswith("voxel size: "):
        g["voxel_printed"] = [s[12:]] * 3
    elif s.startswith("voxel dimensions: "):
        g["voxel_printed"] = re.findall(NUM, s[18:])
    elif s.startswith("index to world:"):
        in_matrix = True

if not grids:
    sys.exit("no grids found")
result = []
for g in grids:
    for key in ("tree_type", "active_voxels", "voxel_printed"):
        if key not in g:
            sys.exit("grid %s: no %s in vdb_print output" % (g["name"], key))
    if len(g["matrix"]) != 4 or any(len(r) != 4 for r in g["matrix"]):
        sys.exit("grid %s: no 4x4 index to world matrix" % g["name"])
    mt = re.match(r"Tree_(\w+?)_(\d+(?:_\d+)*)$", g["tree_type"])
    value_type = mt.group(1) if mt else g["tree_type"]
    leaf_log2 = int(mt.group(2).split("_")[-1]) if mt else 3
    # Transform::print uses std::setprecision(3); the tree statistics use 6 digits.
    A = [[float(x) for x in r] for r in g["matrix"]]
    AT = [[half_ulp(x, 3) for x in r] for r in g["matrix"]]
    e = {
        "name": g["name"], "tree_type": g["tree_type"], "value_type": value_type,
        "leaf_dim": 2 ** leaf_log2, "active_voxels": g["active_voxels"],
        "voxel_size": [float(x) for x in g["voxel_printed"]],
        "voxel_size_tol": [half_ulp(x, 3) for x in g["voxel_printed"]],
        "index_to_world": A, "index_to_world_tol": AT,
        # vdb_print prints the transform with 3 digits only: the exact voxel size
        # nebgen was asked for (--size / --res) sharpens the voxel size check.
        "nominal_voxel_size": nominal,
    }
    if g["active_voxels"] > 0:
        if "index_bbox" not in g:
            sys.exit("grid %s: no active voxel bbox" % g["name"])
        e["index_bbox"] = g["index_bbox"]
        # World bbox of the active voxel centres (row vectors: p * A), and how far
        # vdb_print's rounding of A can move it.
        corners = [[g["index_bbox"][(c >> k) & 1][k] for k in range(3)] for c in range(8)]
        world = [[sum(p[r] * A[r][c] for r in range(3)) + A[3][c] for c in range(3)] for p in corners]
        wtol = [max(sum(abs(p[r]) * AT[r][c] for r in range(3)) + AT[3][c] for p in corners)
                for c in range(3)]
        e["world_bbox"] = [[min(w[c] for w in world) for c in range(3)],
                           [max(w[c] for w in world) for c in range(3)]]
        e["world_bbox_tol"] = wtol
        if value_type == "float":
            for key in ("min", "max"):
                p = g.get(key + "_printed")
                if p is None:
                    sys.exit("grid %s: no %s value" % (g["name"], key))
                e[key] = float(p)
                e[key + "_printed"] = p
                e[key + "_tol"] = half_ulp(p, 6)
    result.append(e)

json.dump({"file": vdb, "source": "vdb_print -l -m", "required_names": required,
           "grids": result}, open(out, "w"), indent=1)
for e in result:
    print("   %-10s %-18s %6d active voxels, index bbox %s, voxel %s, values [%s, %s]" % (
        e["name"], e["tree_type"], e["active_voxels"], e.get("index_bbox"),
        e["voxel_size"][0], e.get("min_printed"), e.get("max_printed")))
PY
}

# run_blender VDB EXPECTED.json LOG: the checker's exit status.
run_blender() {
    "$BLENDER" -b --factory-startup -noaudio --python-exit-code 2 \
        --python "$CHECKER" -- "$1" "$2" >"$3" 2>&1
}

failures=0
for f in nebula lit spectral ionised; do
    vdb=$WORK/$f.vdb
    case $f in
        nebula) required=(density emission) ;;
        lit) required=(density emission 'tau.*') ;;
        spectral) required=(density emission emission.oiii temperature velocity) ;;
        ionised) required=(density emission ionization.hii ionization.oiii emission.oiii
                           emission.nii emission.sii) ;;
    esac
    echo "== $f.vdb: OpenVDB (vdb_print -l -m) says"
    expected_json "$vdb" "$WORK/$f.expected.json" "$(python3 -c "print($SIZE / $RES)")" "${required[@]}"
    echo "== $f.vdb: Blender says"
    t0=$(now_ms)
    run_blender "$vdb" "$WORK/$f.expected.json" "$WORK/$f.blender.log"
    rc=$?
    t1=$(now_ms)
    grep -E '^(check_grids.py|  (ok|FAIL|note) |RESULT|  MISMATCH)' "$WORK/$f.blender.log"
    echo "   (blender run: $(secs $((t1 - t0)))s, exit status $rc)"
    if [ $rc -eq 0 ] && ! grep -q '^RESULT: PASS' "$WORK/$f.blender.log"; then
        rc=99  # Blender exited 0 without running the checks
    fi
    if [ $rc -ne 0 ]; then
        failures=$((failures + 1))
        if ! grep -q '^RESULT: FAIL' "$WORK/$f.blender.log"; then
            echo "---- Blender did not finish the checks (exit $rc); its output:"
            cat "$WORK/$f.blender.log"
            echo "----"
        fi
    fi
done

# Negative controls: a wrong expectation must make Blender exit 1 with a clear
# message, or the checks above prove nothing.
echo "== negative controls (wrong expectations must fail)"
python3 - "$WORK/lit.expected.json" "$WORK" <<'PY' || fail "cannot write the negative-control expectations"
import json, sys
src, work = sys.argv[1], sys.argv[2]
e = json.load(open(src))
e["grids"][0]["voxel_size"] = [v * 1.05 for v in e["grids"][0]["voxel_size"]]
json.dump(e, open(work + "/wrong_voxel_size.json", "w"), indent=1)
e = json.load(open(src))
g = next(g for g in e["grids"] if "max" in g)
g["max"] *= 1.001
json.dump(e, open(work + "/wrong_max.json", "w"), indent=1)
e = json.load(open(src))
e["grids"][-1]["index_bbox"][1][0] += 1
json.dump(e, open(work + "/wrong_bbox.json", "w"), indent=1)
PY
for control in "wrong_voxel_size:voxel size" "wrong_max:max value" "wrong_bbox:active voxel index bbox"; do
    name=${control%%:*}
    want=${control#*:}
    run_blender "$WORK/lit.vdb" "$WORK/$name.json" "$WORK/$name.blender.log"
    rc=$?
    if [ $rc -eq 1 ] && grep -q "^  MISMATCH .*$want" "$WORK/$name.blender.log"; then
        echo "   ok    $name.json is rejected (exit 1): $(grep -m1 "^  MISMATCH .*$want" "$WORK/$name.blender.log" | sed 's/^  MISMATCH //')"
    else
        echo "   FAIL  $name.json was not rejected with a '$want' mismatch (exit $rc); see $WORK/$name.blender.log"
        failures=$((failures + 1))
    fi
done

T_END=$(now_ms)
echo "== total $(secs $((T_END - T_START)))s"
if [ $failures -ne 0 ]; then
    echo "FAIL: $failures Blender check run(s) failed (logs in $WORK)"
    exit 1
fi
echo "PASS: Blender sees the same grids, voxel size, bounding boxes and value ranges as OpenVDB"
exit 0
