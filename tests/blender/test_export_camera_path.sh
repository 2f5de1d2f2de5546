#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Tests examples/blender/export_camera_path.py in headless Blender.
#
#   test_export_camera_path.sh WORK_DIR
#
# Blender builds a scene (fps 24, frames 1..49, 1920x1080): a camera "Cam"
# keyframed at frames 1, 25 and 49 (location, rotation, lens 35/50/80 mm), a
# camera "TrackCam" with a Track To constraint on a moving empty (also its DOF
# focus object), a VERTICAL sensor-fit camera and an orthographic camera, and
# saves it as WORK_DIR/scene.blend (and as portrait.blend with a portrait
# render size). The exporter runs on it; python3 checks the JSON against the
# keyed values (and Blender's own evaluation, saved by the builder in
# truth.json). WORK_DIR is created if needed and this script's files in it are
# replaced. BLENDER may name another executable. Exit 0 only if every check
# passed. A missing blender is a failure, not a skip.
set -euo pipefail

if [ $# -ne 1 ]; then
    echo "usage: $0 WORK_DIR" >&2
    exit 2
fi
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
EXPORTER=$(cd "$HERE/../../examples/blender" && pwd)/export_camera_path.py
BLENDER=${BLENDER:-blender}

fail() {
    echo "FAIL: $*" >&2
    exit 1
}

command -v "$BLENDER" >/dev/null 2>&1 ||
    fail "blender not found (BLENDER=$BLENDER). This test needs Blender: install it (Debian 12: apt-get install blender) -- the project's test command installs it."
command -v python3 >/dev/null 2>&1 || fail "python3 not found (needed to check the JSON)."
[ -f "$EXPORTER" ] || fail "$EXPORTER is missing."

mkdir -p "$1" || fail "cannot create $1"
WORK=$(cd "$1" && pwd)
rm -rf "$WORK/blender-user"
rm -f "$WORK"/*.blend "$WORK"/*.blend1 "$WORK"/*.json "$WORK"/*.log "$WORK"/.*.tmp "$WORK"/build_scene.py
# Keep Blender away from the user's own configuration and scripts.
export BLENDER_USER_CONFIG=$WORK/blender-user/config
export BLENDER_USER_SCRIPTS=$WORK/blender-user/scripts
export BLENDER_USER_DATAFILES=$WORK/blender-user/datafiles

now_ms() { echo $(($(date +%s%N) / 1000000)); }
secs() { printf '%d.%d' $(($1 / 1000)) $(($1 % 1000 / 100)); }
T_START=$(now_ms)

# ---------------------------------------------------------------------------
# 1. Build the scenes. truth.json holds the keyed values and what Blender itself
#    evaluates (positions between keys, calc_matrix_camera's field of view).
cat >"$WORK/build_scene.py" <<'PY'
import json, math, sys
import bpy

work = sys.argv[sys.argv.index("--") + 1]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.fps, scene.render.fps_base = 24, 1.0
scene.frame_start, scene.frame_end = 1, 49
scene.render.resolution_x, scene.render.resolution_y = 1920, 1080
scene.render.pixel_aspect_x = scene.render.pixel_aspect_y = 1.0

def camera(name, **data):
    cd = bpy.data.cameras.new(name)
    for k, v in data.items():
        setattr(cd, k, v)
    ob = bpy.data.objects.new(name, cd)
    scene.collection.objects.link(ob)
    return ob

# The keyed camera: location, rotation (XYZ Euler) and lens at frames 1, 25, 49.
cam = camera("Cam", sensor_fit='AUTO', sensor_width=36.0)
keys = {1: ((0.0, -12.0, 3.0), (70.0, 0.0, 0.0), 35.0),
        25: ((8.5, -6.0, 4.25), (80.0, 10.0, 45.0), 50.0),
        49: ((10.0, 5.0, 2.0), (95.0, -20.0, 150.0), 80.0)}
for f, (loc, rot, lens) in keys.items():
    cam.location = loc
    cam.rotation_euler = [math.radians(a) for a in rot]
    cam.data.lens = lens
    cam.keyframe_insert("location", frame=f)
    cam.keyframe_insert("rotation_euler", frame=f)
    cam.data.keyframe_insert("lens", frame=f)
scene.camera = cam

# A camera tracking a moving empty (Track To), the empty also its DOF focus object.
target = bpy.data.objects.new("Target", None)
scene.collection.objects.link(target)
for f, loc in ((1, (1.0, 2.0, 0.5)), (49, (-3.0, 6.0, 1.5))):
    target.location = loc
    target.keyframe_insert("location", frame=f)
track = camera("TrackCam", lens=40.0)
for f, loc in ((1, (6.0, -8.0, 5.0)), (49, (-9.0, -4.0, 7.0))):
    track.location = loc
    track.keyframe_insert("location", frame=f)
con = track.constraints.new('TRACK_TO')
con.target, con.track_axis, con.up_axis = target, 'TRACK_NEGATIVE_Z', 'UP_Y'
track.data.dof.focus_object = target

vert = camera("VertCam", sensor_fit='VERTICAL', sensor_height=24.0, lens=30.0)
vert.rotation_euler = (math.radians(90.0), 0.0, 0.0)
ortho = camera("OrthoCam", type='ORTHO', ortho_scale=10.0)

def hfov(ob):
    """Blender's own horizontal field of view, from its projection matrix."""
    r = scene.render
    p = ob.calc_matrix_camera(bpy.context.evaluated_depsgraph_get(), x=r.resolution_x,
                              y=r.resolution_y, scale_x=r.pixel_aspect_x, scale_y=r.pixel_aspect_y)
    return math.degrees(2.0 * math.atan(1.0 / p[0][0]))

def render_size():
    """The render aspect as Blender stores it (pixel_aspect_x 1.2 is a float32)."""
    r = scene.render
    return [r.resolution_x * r.pixel_aspect_x, r.resolution_y * r.pixel_aspect_y]

def world(ob):
    return list(ob.matrix_world.translation)

truth = {"cam_keys": {}, "cam_eval": {}, "track": {}}
for f in keys:
    scene.frame_set(f)
    truth["cam_keys"][f] = {"location": list(cam.location), "rotation_euler": list(cam.rotation_euler),
                            "lens": cam.data.lens, "sensor_width": cam.data.sensor_width,
                            "angle_x_deg": math.degrees(cam.data.angle_x), "blender_hfov": hfov(cam)}
for f in range(1, 50, 6):
    scene.frame_set(f)
    truth["cam_eval"][f] = world(cam)
    truth["track"][f] = {"eye": world(track), "target": world(target)}
truth["vert"] = {"lens": vert.data.lens, "sensor_height": vert.data.sensor_height,
                 "angle_y_deg": math.degrees(vert.data.angle_y), "blender_hfov": hfov(vert),
                 "size": render_size()}
scene.frame_set(1)
bpy.ops.wm.save_as_mainfile(filepath=work + "/scene.blend")

# The same scene with a portrait render (1000x1500, pixel aspect 1.2:1 -> 1200x1500):
# sensor_fit AUTO fits sensor_width to the image height.
scene.render.resolution_x, scene.render.resolution_y = 1000, 1500
scene.render.pixel_aspect_x = 1.2
scene.frame_set(25)
truth["portrait"] = {"lens": cam.data.lens, "sensor_width": cam.data.sensor_width,
                     "size": render_size(), "blender_hfov": hfov(cam)}
scene.frame_set(1)
bpy.ops.wm.save_as_mainfile(filepath=work + "/portrait.blend")
json.dump(truth, open(work + "/truth.json", "w"), indent=1)
print("build_scene: done")
PY

echo "== building the test scenes in $WORK"
t0=$(now_ms)
"$BLENDER" -b --factory-startup -noaudio --python-exit-code 1 \
    --python "$WORK/build_scene.py" -- "$WORK" >"$WORK/build.log" 2>&1 ||
    { cat "$WORK/build.log"; fail "Blender could not build the test scene (log above)"; }
grep -q '^build_scene: done' "$WORK/build.log" || { cat "$WORK/build.log"; fail "the scene builder did not finish"; }
echo "   ($(secs $(($(now_ms) - t0)))s)"

# ---------------------------------------------------------------------------
# 2. Run the exporter. export NAME BLEND ARGS...: writes NAME.json and NAME.log,
#    returns Blender's exit status.
export_path() {
    local name=$1 blend=$2
    shift 2
    local rc=0 t0
    t0=$(now_ms)
    "$BLENDER" -b --factory-startup -noaudio --python-exit-code 1 "$WORK/$blend" \
        --python "$EXPORTER" -- -o "$WORK/$name.json" "$@" >"$WORK/$name.log" 2>&1 || rc=$?
    echo "   $name: export_camera_path.py -- -o $name.json${*:+ $*} ($blend): exit $rc, $(secs $(($(now_ms) - t0)))s"
    return $rc
}

echo "== exporting"
failures=0
for run in "step12:scene.blend:--step 12" \
           "default:scene.blend:" \
           "track:scene.blend:--camera TrackCam --step 6 --scale 0.5" \
           "vert:scene.blend:--camera VertCam --frame-end 1" \
           "portrait:portrait.blend:--frame-start 25 --frame-end 25"; do
    IFS=: read -r name blend args <<<"$run"
    # shellcheck disable=SC2086  # args is a list of words
    if ! export_path "$name" "$blend" $args; then
        echo "   FAIL  the $name export failed; its output:"
        sed 's/^/      /' "$WORK/$name.log"
        failures=$((failures + 1))
    fi
done

# Refusals: a non-zero exit, a clear message, and no output file.
refuse() {
    local name=$1 want=$2
    shift 2
    local rc=0
    export_path "$name" scene.blend "$@" || rc=$?
    if [ $rc -ne 0 ] && grep -q -- "$want" "$WORK/$name.log" && [ ! -e "$WORK/$name.json" ]; then
        echo "   ok    refused (exit $rc): $(grep -m1 -- "$want" "$WORK/$name.log")"
    else
        echo "   FAIL  $name: expected a non-zero exit, no $name.json and a message matching '$want'; got exit $rc:"
        sed 's/^/      /' "$WORK/$name.log"
        failures=$((failures + 1))
    fi
}
refuse ortho "camera 'OrthoCam' is orthographic" --camera OrthoCam
refuse nocam "no object 'NoSuchCam'.*Cam" --camera NoSuchCam

# ---------------------------------------------------------------------------
# 3. Check the JSON files.
echo "== checking the camera paths"
python3 - "$WORK" <<'PY' || failures=$((failures + 1))
import json, math, os, sys

work = sys.argv[1]
bad = 0

def check(ok, what):
    global bad
    print("   %s  %s" % ("ok  " if ok else "FAIL", what))
    bad += not ok

def load(name):
    path = os.path.join(work, name + ".json")
    if not os.path.exists(path):
        check(False, "%s.json exists" % name)
        return None
    return json.load(open(path))

def sub(a, b): return [x - y for x, y in zip(a, b)]
def dot(a, b): return sum(x * y for x, y in zip(a, b))
def norm(a):
    n = math.sqrt(dot(a, a))
    return [x / n for x in a]
def cross(a, b): return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
def dist(a, b): return math.sqrt(dot(sub(a, b), sub(a, b)))

def euler_xyz(rx, ry, rz):
    """Blender's XYZ Euler rotation matrix, R = Rz Ry Rx (rows)."""
    cx, sx = math.cos(rx), math.sin(rx)
    cy, sy = math.cos(ry), math.sin(ry)
    cz, sz = math.cos(rz), math.sin(rz)
    return [[cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx],
            [sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx],
            [-sy, cy * sx, cy * cx]]

def hfov_vertical_fit(sensor, lens, size):
    return math.degrees(2.0 * math.atan(math.tan(math.atan(sensor / (2.0 * lens))) * size[0] / size[1]))

def well_formed(name, p, n_expected):
    """The format: keys, types, unit up, time order, 9 significant digits."""
    ok = set(p) == {"fps", "keyframes"} and isinstance(p["keyframes"], list)
    ok = ok and len(p["keyframes"]) == n_expected
    nums = []
    for k in p.get("keyframes", []):
        ok = ok and set(k) == {"time", "eye", "look_at", "up", "fov"}
        ok = ok and all(len(k[v]) == 3 for v in ("eye", "look_at", "up"))
        if not ok:
            break
        nums += [k["time"], k["fov"]] + k["eye"] + k["look_at"] + k["up"]
        ok = ok and abs(math.sqrt(dot(k["up"], k["up"])) - 1.0) < 1e-6
        ok = ok and abs(dot(k["up"], norm(sub(k["look_at"], k["eye"])))) < 1e-6
    times = [k["time"] for k in p.get("keyframes", [])] if ok else []
    ok = ok and all(a < b for a, b in zip(times, times[1:]))
    ok = ok and all(isinstance(x, (int, float)) and float("%.9g" % x) == x for x in nums)
    check(ok, "%s.json: %d keyframes with exactly time/eye/look_at/up/fov, unit up orthogonal "
          "to the view, times increasing, 9 significant digits" % (name, n_expected))
    return ok

truth = json.load(open(os.path.join(work, "truth.json")))
keys = {int(f): v for f, v in truth["cam_keys"].items()}

# --- step 12 (frames 1, 13, 25, 37, 49) ---
p = load("step12")
if p and well_formed("step12", p, 5):
    check(p["fps"] == 24, "step12.json: fps 24 (got %r)" % p["fps"])
    times = [k["time"] for k in p["keyframes"]]
    check(all(abs(t - e) < 1e-9 for t, e in zip(times, [0, 0.5, 1, 1.5, 2])),
          "step12.json: times 0, 0.5, 1, 1.5, 2 (got %s)" % times)
    by_frame = {1 + 12 * i: k for i, k in enumerate(p["keyframes"])}  # the times are checked above
    for f, key in sorted(keys.items()):
        k = by_frame[f]
        R = euler_xyz(*key["rotation_euler"])
        fwd_exp = [-R[i][2] for i in range(3)]
        up_exp = [R[i][1] for i in range(3)]
        fwd = norm(sub(k["look_at"], k["eye"]))
        e = dist(k["eye"], key["location"])
        check(e < 1e-6, "frame %d: eye %s = keyed location %s (error %.1e)"
              % (f, k["eye"], key["location"], e))
        e = dist(fwd, fwd_exp)
        check(e < 1e-6, "frame %d: view direction = keyed rotation's -Z (error %.1e)" % (f, e))
        e = dist(k["up"], up_exp)
        check(e < 1e-6, "frame %d: up = keyed rotation's +Y (error %.1e)" % (f, e))
        fov_exp = math.degrees(2.0 * math.atan(key["sensor_width"] / (2.0 * key["lens"])))
        check(abs(k["fov"] - fov_exp) < 1e-6,
              "frame %d: fov %.7f = 2 atan(%g / (2 * %g mm)) = %.7f"
              % (f, k["fov"], key["sensor_width"], key["lens"], fov_exp))
        check(abs(k["fov"] - key["angle_x_deg"]) < 1e-4 and abs(k["fov"] - key["blender_hfov"]) < 1e-4,
              "frame %d: fov = Blender's angle_x %.5f and projection matrix %.5f"
              % (f, key["angle_x_deg"], key["blender_hfov"]))

# --- defaults (every frame 1..49) ---
d = load("default")
if d and well_formed("default", d, 49):
    times = [k["time"] for k in d["keyframes"]]
    e = max(abs(t - i / 24.0) for i, t in enumerate(times))
    check(e < 1e-8, "default.json: times (f - 1) / 24 for frames 1..49 (error %.1e)" % e)
    ev = {int(f): v for f, v in truth["cam_eval"].items()}
    e = max(dist(d["keyframes"][f - 1]["eye"], loc) for f, loc in ev.items())
    check(e < 1e-5, "default.json: eye = Blender's interpolated position at frames %s (error %.1e)"
          % (sorted(ev), e))
    if p and len(p["keyframes"]) == 5:
        check(all(d["keyframes"][12 * i] == p["keyframes"][i] for i in range(5)),
              "default.json: frames 1, 13, 25, 37, 49 are identical to step12.json")

# --- Track To, --step 6 --scale 0.5 ---
t = load("track")
if t and well_formed("track", t, 9):
    scale = 0.5
    tr = {int(f): v for f, v in truth["track"].items()}
    e_eye = e_line = e_up = e_focus = 0.0
    for i, k in enumerate(t["keyframes"]):
        f = 1 + 6 * i
        eye, target = tr[f]["eye"], tr[f]["target"]
        e_eye = max(e_eye, dist(k["eye"], [x / scale for x in eye]))
        fwd = norm(sub(k["look_at"], k["eye"]))
        e_line = max(e_line, dist(fwd, norm(sub(target, eye))))
        # Track To with up axis Y: up lies in the plane of the view direction and world +Z.
        e_up = max(e_up, abs(dot(k["up"], norm(cross(fwd, [0, 0, 1])))), 0.0 if k["up"][2] > 0 else 1.0)
        # The empty is the DOF focus object: look_at is the empty itself.
        e_focus = max(e_focus, dist([x * scale for x in k["look_at"]], target))
    check(e_eye < 1e-6, "track.json: eye = camera position / 0.5 (--scale; error %.1e)" % e_eye)
    check(e_line < 1e-6, "track.json: look_at lies on the line from the eye to the tracked empty "
          "(error %.1e)" % e_line)
    check(e_up < 1e-6, "track.json: up is in the plane of the view and world +Z, upwards "
          "(error %.1e)" % e_up)
    check(e_focus < 1e-5, "track.json: look_at = the DOF focus empty (error %.1e)" % e_focus)

# --- VERTICAL sensor fit, landscape ---
v = load("vert")
if v and well_formed("vert", v, 1):
    tv = truth["vert"]
    exp = hfov_vertical_fit(tv["sensor_height"], tv["lens"], tv["size"])
    half_y = math.radians(tv["angle_y_deg"]) / 2.0  # Blender's vertical half-angle
    from_angle_y = math.degrees(2.0 * math.atan(math.tan(half_y) * tv["size"][0] / tv["size"][1]))
    fov = v["keyframes"][0]["fov"]
    check(abs(fov - exp) < 1e-6 and abs(fov - from_angle_y) < 1e-4 and abs(fov - tv["blender_hfov"]) < 1e-4,
          "vert.json: sensor_fit VERTICAL, %gx%g: fov %.7f = %.7f (formula), %.5f (from angle_y), "
          "%.5f (Blender)"
          % (tv["size"][0], tv["size"][1], fov, exp, from_angle_y, tv["blender_hfov"]))

# --- AUTO sensor fit, portrait render with a pixel aspect ---
q = load("portrait")
if q and well_formed("portrait", q, 1):
    tp = truth["portrait"]
    exp = hfov_vertical_fit(tp["sensor_width"], tp["lens"], tp["size"])
    k = q["keyframes"][0]
    check(k["time"] == 0 and dist(k["eye"], keys[25]["location"]) < 1e-6,
          "portrait.json: --frame-start 25 --frame-end 25 gives frame 25 at time 0")
    check(abs(k["fov"] - exp) < 1e-6 and abs(k["fov"] - tp["blender_hfov"]) < 1e-4,
          "portrait.json: AUTO fit, 1000x1500 with pixel aspect 1.2: fov %.7f = %.7f (formula), "
          "%.5f (Blender)"
          % (k["fov"], exp, tp["blender_hfov"]))

leftovers = [n for n in os.listdir(work) if n.endswith(".tmp")]
check(not leftovers, "no temporary files left behind %s" % (leftovers or ""))
sys.exit(1 if bad else 0)
PY

echo "== total $(secs $(($(now_ms) - T_START)))s"
if [ $failures -ne 0 ]; then
    echo "FAIL: $failures part(s) of the camera path export test failed (files in $WORK)"
    exit 1
fi
echo "PASS: the exported camera paths match the keyed and Blender-evaluated cameras"
exit 0
