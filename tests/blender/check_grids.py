# SPDX-License-Identifier: Apache-2.0
"""Check what Blender sees in a .vdb file against OpenVDB's own numbers.

Runs INSIDE Blender (tested with Debian 12's Blender 3.4.1):

    blender -b --factory-startup -noaudio --python-exit-code 2 \
        --python check_grids.py -- FILE.vdb EXPECTED.json

EXPECTED.json is written by run_blender_test.sh from `vdb_print -l -m FILE.vdb`.
Exit status: 0 all checks passed, 1 at least one mismatch ("FAIL" lines),
2 usage error or crash (--python-exit-code 2).

What is checked, per grid, with what Blender 3.4 itself computes:
  * names and value types (Volume.grids after volume.grids.load());
  * voxel size and the whole index->object transform (VolumeGrid.matrix_object;
    1 pc = 1 Blender unit, so the column lengths are the voxel size in pc).
    vdb_print prints the transform to 3 digits only, so the voxel size is also
    compared (to 1e-6) with nebgen's --size/--res when the JSON gives it;
  * the active voxels: a Geometry Nodes "Distribute Points in Volume" node in
    Grid mode, spacing = voxel size, threshold -1e30, puts one point on every
    active voxel of every float grid, grid after grid in Blender's grid order.
    The points are split per grid with OpenVDB's active-voxel counts and mapped
    back to index space with matrix_object: index bbox must be equal, world
    bbox (voxel centres) within half a voxel of OpenVDB's;
  * the maximum value: a mesh object with a "Volume to Mesh" modifier on that
    grid alone (grid_name), Grid resolution, threshold just below OpenVDB's max
    must give a non-empty mesh, threshold just above it an empty one;
  * the minimum (and again the maximum) with the Distribute node's threshold
    (value >= threshold keeps the voxel): no active voxel of any grid lies below
    the smallest OpenVDB min, and for every grid some active voxel lies within
    the print precision of its OpenVDB min and max. The Distribute node merges
    all float grids (Blender 3.4 geometry nodes cannot pick one grid), so the
    per-grid min test is a test on the file's voxels, not on that grid alone;
  * the volume object's bound_box contains every active voxel (Blender 3.4
    computes it from leaf nodes, so it may be up to a leaf (8 voxels) larger).
"""

import fnmatch
import json
import math
import os
import sys
import time
from array import array

import bpy
from mathutils import Vector

# Blender's VolumeGrid.data_type for OpenVDB's value types (vdb_print "Type: Tree_<T>_5_4_3").
BLENDER_TYPE = {
    "float": "FLOAT", "double": "DOUBLE", "int32": "INT", "int64": "INT64",
    "bool": "BOOLEAN", "mask": "MASK", "vec3s": "VECTOR_FLOAT",
    "vec3d": "VECTOR_DOUBLE", "vec3i": "VECTOR_INT", "ptdataidx32": "POINTS",
}

LOW = -1.0e30  # threshold below every value: every active voxel


class Report:
    def __init__(self):
        self.failed = []
        self.passed = 0

    def check(self, ok, what, detail=""):
        line = what + (": " + detail if detail else "")
        if ok:
            self.passed += 1
            print("  ok    " + line, flush=True)
        else:
            self.failed.append(line)
            print("  FAIL  " + line, flush=True)
        return ok

    def note(self, text):
        print("  note  " + text, flush=True)


def fmt(v):
    if isinstance(v, (list, tuple, Vector)):
        return "(" + ", ".join(fmt(x) for x in v) + ")"
    return "%.6g" % v


def usage(msg):
    print("check_grids.py: " + msg, file=sys.stderr)
    print("usage: blender -b --python-exit-code 2 --python check_grids.py -- FILE.vdb EXPECTED.json",
          file=sys.stderr)
    sys.exit(2)


def step(v, tol):
    """A distance that is safely beyond OpenVDB's print precision (tol) of v."""
    return 2.0 * tol + 1e-6 * abs(v) + 1e-37


# ---------------------------------------------------------------- loading

def import_volume(path):
    """File > Import > OpenVDB, as a user would do it."""
    before = set(bpy.data.objects)
    result = bpy.ops.object.volume_import(
        filepath=path, directory=os.path.dirname(path),
        files=[{"name": os.path.basename(path)}])
    new = [o for o in bpy.data.objects if o not in before and o.type == 'VOLUME']
    if result != {'FINISHED'} or len(new) != 1:
        return None
    return new[0]


def evaluated_mesh_points(obj, want_coords):
    """Evaluate obj's modifiers; return (vertex count, flat coordinate array or None)."""
    dg = bpy.context.evaluated_depsgraph_get()
    dg.update()
    ev = obj.evaluated_get(dg)
    mesh = ev.to_mesh()
    n = len(mesh.vertices)
    co = None
    if want_coords:
        co = array('f', [0.0]) * (3 * n)
        mesh.vertices.foreach_get("co", co)
    ev.to_mesh_clear()
    return n, co


# ---------------------------------------------------------------- probes

class DistributeProbe:
    """Mesh object whose geometry nodes put a point on every active voxel >= threshold."""

    def __init__(self, vol_obj, spacing):
        tree = bpy.data.node_groups.new("nebula_distribute_probe", 'GeometryNodeTree')
        if hasattr(tree, "interface"):  # Blender >= 4.0
            tree.interface.new_socket("Geometry", in_out='OUTPUT', socket_type='NodeSocketGeometry')
        else:
            tree.outputs.new('NodeSocketGeometry', "Geometry")
        out = tree.nodes.new('NodeGroupOutput')
        info = tree.nodes.new('GeometryNodeObjectInfo')
        info.transform_space = 'ORIGINAL'
        info.inputs["Object"].default_value = vol_obj
        dist = tree.nodes.new('GeometryNodeDistributePointsInVolume')
        dist.mode = 'DENSITY_GRID'
        dist.inputs["Spacing"].default_value = spacing
        # A linked Value node: the socket itself would clamp thresholds to >= 0 in the UI.
        self.value = tree.nodes.new('ShaderNodeValue')
        to_vertices = tree.nodes.new('GeometryNodePointsToVertices')
        tree.links.new(info.outputs["Geometry"], dist.inputs["Volume"])
        tree.links.new(self.value.outputs[0], dist.inputs["Threshold"])
        tree.links.new(dist.outputs["Points"], to_vertices.inputs["Points"])
        tree.links.new(to_vertices.outputs["Mesh"], out.inputs[0])
        mesh = bpy.data.meshes.new("nebula_distribute_probe")
        self.obj = bpy.data.objects.new("nebula_distribute_probe", mesh)
        bpy.context.scene.collection.objects.link(self.obj)
        mod = self.obj.modifiers.new("distribute", 'NODES')
        mod.node_group = tree

    def count(self, threshold, want_coords=False):
        self.value.outputs[0].default_value = threshold
        return evaluated_mesh_points(self.obj, want_coords)


class VolumeToMeshProbe:
    """Mesh object with a Volume to Mesh modifier on one named grid."""

    def __init__(self, vol_obj):
        mesh = bpy.data.meshes.new("nebula_v2m_probe")
        self.obj = bpy.data.objects.new("nebula_v2m_probe", mesh)
        bpy.context.scene.collection.objects.link(self.obj)
        self.mod = self.obj.modifiers.new("v2m", 'VOLUME_TO_MESH')
        self.mod.object = vol_obj
        self.mod.resolution_mode = 'GRID'
        self.mod.adaptivity = 0.0

    def vertices(self, grid, threshold):
        self.mod.grid_name = grid
        self.mod.threshold = threshold
        if abs(self.mod.threshold - threshold) > 1e-6 * abs(threshold) + 1e-37:
            raise ValueError("Volume to Mesh threshold %g was clamped to %g"
                             % (threshold, self.mod.threshold))
        return evaluated_mesh_points(self.obj, False)[0]


# ---------------------------------------------------------------- checks

def check_transform(rep, grid, exp):
    name = grid.name
    M = grid.matrix_object  # index -> object, column vectors
    size = [M.col[i].to_3d().length for i in range(3)]
    ev, et = exp["voxel_size"], exp["voxel_size_tol"]
    rep.check(all(abs(size[i] - ev[i]) <= et[i] * 1.000001 for i in range(3)),
              "%s: voxel size [pc = Blender units]" % name,
              "Blender %s, OpenVDB %s +- %s (vdb_print's 3 digits)" % (fmt(size), fmt(ev), fmt(et)))
    nominal = exp.get("nominal_voxel_size")
    if nominal:
        rep.check(all(abs(s - nominal) <= 1e-6 * nominal for s in size),
                  "%s: voxel size = nebgen --size / --res" % name,
                  "Blender %s, nominal %.9g" % (fmt(size), nominal))
    # vdb_print writes the matrix for row vectors (translation in the last row).
    A, T = exp["index_to_world"], exp["index_to_world_tol"]
    worst = 0.0
    ok = True
    for r in range(4):
        for c in range(4):
            d = abs(M[c][r] - A[r][c])
            worst = max(worst, d)
            ok &= d <= T[r][c] * 1.000001
    rep.check(ok, "%s: index->object matrix (matrix_object)" % name,
              "max |Blender - OpenVDB| = %.3g, translation Blender %s, OpenVDB %s"
              % (worst, fmt(M.col[3].to_3d()), fmt(A[3][:3])))
    return size


def check_active_voxels(rep, vol_obj, grids, expected, probe):
    """Split the Distribute points per grid and compare active index/world bboxes."""
    float_grids = [g for g in grids if g.data_type == 'FLOAT']
    counts = []
    for g in float_grids:
        e = expected.get(g.name)
        if e is None:
            rep.check(False, "active voxels", "grid %s not in the expectation; cannot split points" % g.name)
            return
        counts.append(e["active_voxels"])
    t0 = time.time()
    n, co = probe.count(LOW, want_coords=True)
    rep.check(n == sum(counts), "active voxels of all float grids (Distribute Points in Volume, Grid mode)",
              "Blender %d points, OpenVDB %s = %d voxels (%.2fs)"
              % (n, " + ".join(str(c) for c in counts), sum(counts), time.time() - t0))
    if n != sum(counts):
        return
    start = 0
    offsets_seen = set()
    for g, c in zip(float_grids, counts):
        e = expected[g.name]
        seg = range(start, start + c)
        start += c
        if c == 0:
            rep.note("%s: no active voxels, no bbox to compare" % g.name)
            continue
        Minv = g.matrix_object.inverted()
        idx = [Minv @ Vector((co[3 * i], co[3 * i + 1], co[3 * i + 2])) for i in seg]
        # Blender 3.4 puts the grid point of voxel ijk at index ijk + 0.5 (later versions
        # at ijk): find the common fractional offset f0; voxel = round(index - f0).
        f0 = [idx[0][k] - math.floor(idx[0][k] + 1e-3) for k in range(3)]
        lattice_ok = True
        vox = set()
        for p in idx:
            ijk = tuple(round(p[k] - f0[k]) for k in range(3))
            if max(abs(p[k] - f0[k] - ijk[k]) for k in range(3)) > 1e-3:
                lattice_ok = False
            vox.add(ijk)
        offsets_seen.add(tuple(round(x, 3) for x in f0))
        rep.check(lattice_ok and len(vox) == c,
                  "%s: one point per active voxel on the index lattice" % g.name,
                  "%d distinct voxels of %d points, point offset %s voxel" % (len(vox), c, fmt(f0)))
        lo = [min(v[k] for v in vox) for k in range(3)]
        hi = [max(v[k] for v in vox) for k in range(3)]
        eb = e["index_bbox"]
        rep.check(lo == eb[0] and hi == eb[1], "%s: active voxel index bbox" % g.name,
                  "Blender %s -> %s, OpenVDB %s -> %s" % (lo, hi, eb[0], eb[1]))
        M = g.matrix_object
        wlo = (M @ Vector(lo + [1.0])).to_3d()
        whi = (M @ Vector(hi + [1.0])).to_3d()
        half = 0.5 * min(M.col[k].to_3d().length for k in range(3))
        ew, etol = e["world_bbox"], e["world_bbox_tol"]
        diff = [max(abs(wlo[k] - ew[0][k]), abs(whi[k] - ew[1][k])) for k in range(3)]
        rep.check(all(diff[k] <= half + etol[k] for k in range(3)),
                  "%s: world bbox of active voxel centres [pc]" % g.name,
                  "Blender %s -> %s, OpenVDB %s -> %s, worst difference %.3g <= half voxel %.3g "
                  "+ vdb_print rounding %.3g"
                  % (fmt(wlo), fmt(whi), fmt(ew[0]), fmt(ew[1]), max(diff), half, max(etol)))
    if offsets_seen and any(max(o) > 0.25 for o in offsets_seen):
        rep.note("Distribute Points in Volume (Grid) places voxel ijk's point at index ijk+0.5 "
                 "in this Blender (%s); the bbox above accounts for it" % bpy.app.version_string)


def check_object_bound_box(rep, vol_obj, expected_grids):
    """The object's bound_box must contain every active voxel (Blender 3.4: leaf nodes)."""
    boxes = [e for e in expected_grids if e["active_voxels"] > 0]
    if not boxes:
        return
    emin = [min(e["world_bbox"][0][k] for e in boxes) for k in range(3)]
    emax = [max(e["world_bbox"][1][k] for e in boxes) for k in range(3)]
    tol = [max(e["world_bbox_tol"][k] for e in boxes) for k in range(3)]
    vs = min(min(e["voxel_size"]) for e in boxes)
    leaf = max(e.get("leaf_dim", 8) for e in boxes)
    bb = [Vector(c) for c in vol_obj.bound_box]
    bmin = [min(c[k] for c in bb) for k in range(3)]
    bmax = [max(c[k] for c in bb) for k in range(3)]
    contains = all(bmin[k] <= emin[k] + tol[k] + 1e-5 and bmax[k] >= emax[k] - tol[k] - 1e-5
                   for k in range(3))
    slack = max(max(emin[k] - bmin[k], bmax[k] - emax[k]) for k in range(3))
    rep.check(contains and slack <= leaf * vs + max(tol) + 1e-5,
              "volume object bound_box contains all active voxels",
              "bound_box %s -> %s, active voxel centres %s -> %s, bound_box is up to %.3g "
              "larger (%.2f voxels; Blender 3.4 uses leaf-node bounds, so not within half a voxel)"
              % (fmt(bmin), fmt(bmax), fmt(emin), fmt(emax), slack, slack / vs))


def check_max_per_grid(rep, grid, e, v2m):
    """Volume to Mesh on this grid alone: non-empty just below max, empty just above."""
    if e["active_voxels"] == 0:
        return
    vmax, tol = e["max"], e["max_tol"]
    d = step(vmax, tol)
    lo, hi = vmax - d, vmax + d
    if hi <= 0.0:
        rep.note("%s: max %g <= 0; Volume to Mesh thresholds cannot go below 0, "
                 "max checked only with Distribute" % (grid.name, vmax))
        return
    n_hi = v2m.vertices(grid.name, hi)
    if lo > 0.0:
        n_lo = v2m.vertices(grid.name, lo)
        rep.check(n_lo > 0 and n_hi == 0, "%s: max value (Volume to Mesh on this grid)" % grid.name,
                  "OpenVDB max %s; mesh vertices at threshold %s: %d (want > 0), at %s: %d (want 0)"
                  % (fmt(vmax), fmt(lo), n_lo, fmt(hi), n_hi))
    else:
        rep.check(n_hi == 0, "%s: max value (Volume to Mesh on this grid)" % grid.name,
                  "OpenVDB max %s; mesh vertices at threshold %s: %d (want 0)"
                  % (fmt(vmax), fmt(hi), n_hi))


def check_value_windows(rep, expected_grids, probe):
    """Distribute threshold counts (value >= threshold) over all float grids."""
    gr = [e for e in expected_grids if e["value_type"] == "float" and e["active_voxels"] > 0]
    if not gr:
        return
    total = sum(e["active_voxels"] for e in gr)
    gmin = min(gr, key=lambda e: e["min"])
    gmax = max(gr, key=lambda e: e["max"])
    below = gmin["min"] - step(gmin["min"], gmin["min_tol"])
    above = gmax["max"] + step(gmax["max"], gmax["max_tol"])
    n_below = probe.count(below)[0]
    n_above = probe.count(above)[0]
    rep.check(n_below == total, "no active voxel below the smallest OpenVDB min (Distribute threshold)",
              "%d of %d voxels >= %s (min %s of %s)"
              % (n_below, total, fmt(below), fmt(gmin["min"]), gmin["name"]))
    rep.check(n_above == 0, "no active voxel above the largest OpenVDB max (Distribute threshold)",
              "%d voxels >= %s (max %s of %s)" % (n_above, fmt(above), fmt(gmax["max"]), gmax["name"]))
    for e in gr:
        for key in ("min", "max"):
            v, tol = e[key], e[key + "_tol"]
            d = step(v, tol)
            n_lo = probe.count(v - d)[0]
            n_hi = probe.count(v + d)[0]
            rep.check(n_lo > n_hi, "%s: an active voxel at its OpenVDB %s (Distribute, all float grids)"
                      % (e["name"], key),
                      "%d voxels in [%s, %s) around %s %s"
                      % (n_lo - n_hi, fmt(v - d), fmt(v + d), key, fmt(v)))


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(argv) != 2:
        usage("expected FILE.vdb EXPECTED.json after --")
    path, exp_path = os.path.abspath(argv[0]), argv[1]
    if not os.path.isfile(path):
        usage("no such file: " + path)
    with open(exp_path) as f:
        expected = json.load(f)
    exp_grids = expected["grids"]
    by_name = {e["name"]: e for e in exp_grids}

    print("check_grids.py: Blender %s reads %s" % (bpy.app.version_string, path), flush=True)
    rep = Report()
    t0 = time.time()

    vol_obj = import_volume(path)
    if not rep.check(vol_obj is not None, "bpy.ops.object.volume_import made one volume object"):
        return finish(rep)
    vol = vol_obj.data
    loaded = vol.grids.load()
    rep.check(loaded and vol.grids.is_loaded and not vol.grids.error_message,
              "volume.grids.load()", "error message: %r" % vol.grids.error_message)
    rep.check(not vol.is_sequence, "not read as an image sequence")
    ident = all(abs(vol_obj.matrix_world[r][c] - (1.0 if r == c else 0.0)) < 1e-9
                for r in range(4) for c in range(4))
    rep.check(ident, "volume object transform is identity (no Y-up rotation, no scale)",
              "matrix_world rows %s" % [fmt(vol_obj.matrix_world.row[r]) for r in range(3)])

    grids = list(vol.grids)
    names = [g.name for g in grids]
    rep.check(sorted(names) == sorted(by_name),
              "grid names", "Blender %s, OpenVDB %s" % (names, [e["name"] for e in exp_grids]))
    for pattern in expected.get("required_names", []):
        hits = fnmatch.filter(names, pattern)
        rep.check(bool(hits), "required grid %r present" % pattern, "found %s" % hits)

    for g in grids:
        e = by_name.get(g.name)
        if e is None:
            continue
        want = BLENDER_TYPE.get(e["value_type"])
        if want:
            rep.check(g.data_type == want, "%s: value type" % g.name,
                      "Blender %s, OpenVDB %s" % (g.data_type, e["tree_type"]))
        check_transform(rep, g, e)

    float_exp = [g for g in grids if g.data_type == 'FLOAT' and g.name in by_name]
    if float_exp:
        # Spacing = voxel size of the first float grid; all of nebula's grids share it.
        M = float_exp[0].matrix_object
        spacing = tuple(M.col[k].to_3d().length for k in range(3))
        probe = DistributeProbe(vol_obj, spacing)
        check_active_voxels(rep, vol_obj, grids, by_name, probe)
        check_object_bound_box(rep, vol_obj, exp_grids)
        v2m = VolumeToMeshProbe(vol_obj)
        for g in float_exp:
            check_max_per_grid(rep, g, by_name[g.name], v2m)
        check_value_windows(rep, [by_name[g.name] for g in float_exp], probe)
    for g in grids:
        if g.data_type != 'FLOAT':
            rep.note("%s: %s grid, bbox and value range not checked (Blender's nodes read float grids)"
                     % (g.name, g.data_type))
    print("check_grids.py: %.2fs inside Blender" % (time.time() - t0), flush=True)
    return finish(rep)


def finish(rep):
    if rep.failed:
        print("RESULT: FAIL, %d of %d checks failed:" % (len(rep.failed), len(rep.failed) + rep.passed),
              flush=True)
        for line in rep.failed:
            print("  MISMATCH " + line, flush=True)
        sys.exit(1)
    print("RESULT: PASS, %d checks" % rep.passed, flush=True)
    sys.exit(0)


main()
