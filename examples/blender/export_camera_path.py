# SPDX-License-Identifier: Apache-2.0
"""Export a Blender camera's animation as a nebula camera path (nebrender --camera-path).

Runs INSIDE Blender (tested with Debian 12's Blender 3.4.1):

    blender -b scene.blend --python-exit-code 1 \
        --python examples/blender/export_camera_path.py -- \
        [--camera NAME] -o flight.json [--frame-start A] [--frame-end B] \
        [--step K] [--scale S]

  --camera NAME     camera object to export (default: the scene's active camera)
  -o, --output F    the JSON file to write (replaced atomically; a path starting
                    with // is relative to the .blend file, as in Blender)
  --frame-start A   first frame (default: the scene's frame_start)
  --frame-end B     last frame (default: the scene's frame_end)
  --step K          sample every K-th frame (default 1); the last frame B is
                    always written, even when B - A is not a multiple of K
  --scale S         divide all positions by S (default 1: 1 Blender unit = 1 pc,
                    the units of a nebula .vdb imported into Blender)

Exit status: 0 on success, 1 on an error (a message on stderr), 2 on a usage
error. Blender's `-b --python` exits 0 even when the script raises an
exception; pass `--python-exit-code 1` (before --python) so that a crash is
seen as a failure too. This script itself exits with sys.exit(1).

What it writes:

    {"fps": 24,
     "keyframes": [
       {"time": 0.0, "eye": [x, y, z], "look_at": [x, y, z], "up": [x, y, z],
        "fov": 40.0},
       ...]}

Conventions:
  * The camera is sampled at every K-th frame f from A to B: scene.frame_set(f),
    then the evaluated camera object's matrix_world. Blender's interpolation,
    drivers, constraints (Track To, Follow Path, ...) and parenting are thus
    baked in; nebrender interpolates between the written keyframes.
  * time = (f - A) / fps in seconds, fps = scene.render.fps / fps_base: the
    first exported frame is at time 0. Keyframes are in time order.
  * Positions are Blender world coordinates divided by --scale.
  * Blender cameras look along their local -Z axis with local +Y up. With R the
    rotation of matrix_world (its columns normalised, so object scale is
    ignored, as Blender's renderer does), the view direction is R @ (0, 0, -1)
    and up is R @ (0, 1, 0), made exactly orthogonal to the view direction and
    of unit length.
  * look_at = eye + view direction * D. D is the camera's depth-of-field focus
    distance (the distance along the view axis to the DOF focus object if one
    is set, else the DOF focus distance), or 10 units if that is not positive.
    Any point on the view line gives the same view; D only keeps look_at at a
    sensible place.
  * fov is the HORIZONTAL field of view in degrees of the rendered image,
    computed from the lens, the sensor size and sensor_fit (AUTO, HORIZONTAL or
    VERTICAL) with the render aspect ratio (resolution_x * pixel_aspect_x
    against resolution_y * pixel_aspect_y), as Blender does. A lens shift
    (shift_x/shift_y) cannot be expressed and only gets a warning.
    Orthographic and panoramic cameras are refused.
  * No "roll" key is written: the up vector carries the roll.
  * Numbers are rounded to 9 significant digits.
"""

import argparse
import json
import math
import os
import sys
import tempfile

import bpy

PROG = "export_camera_path.py"
DEFAULT_LOOK_DISTANCE = 10.0  # Blender units, when the camera has no usable focus distance


class ExportError(Exception):
    """An error the user can fix: printed as one line, exit status 1."""


def parse_args(argv):
    # Blender passes everything after "--" on to the script.
    args = argv[argv.index("--") + 1:] if "--" in argv else []
    p = argparse.ArgumentParser(
        prog=PROG,
        usage="blender -b FILE.blend --python-exit-code 1 --python %(prog)s -- "
              "[--camera NAME] -o FILE.json [--frame-start A] [--frame-end B] [--step K] [--scale S]",
        description="Export a camera's animation as a nebula camera path JSON file.")
    p.add_argument("--camera", metavar="NAME",
                   help="camera object (default: the scene's active camera)")
    p.add_argument("-o", "--output", required=True, metavar="FILE.json",
                   help="the camera path file to write")
    p.add_argument("--frame-start", type=int, metavar="A",
                   help="first frame (default: the scene's start frame)")
    p.add_argument("--frame-end", type=int, metavar="B",
                   help="last frame (default: the scene's end frame)")
    p.add_argument("--step", type=int, default=1, metavar="K",
                   help="export every K-th frame (default 1; the last frame is always written)")
    p.add_argument("--scale", type=float, default=1.0, metavar="S",
                   help="divide positions by S (default 1)")
    o = p.parse_args(args)
    if o.step < 1:
        p.error("--step must be at least 1, not %d" % o.step)
    if not (math.isfinite(o.scale) and o.scale > 0.0):
        p.error("--scale must be a positive number, not %r" % o.scale)
    return o


def find_camera(scene, name):
    if name is None:
        cam = scene.camera
        if cam is None:
            raise ExportError("scene '%s' has no active camera; name one with --camera" % scene.name)
    else:
        cam = bpy.data.objects.get(name)
        if cam is None or cam.type != 'CAMERA':
            cams = ", ".join(sorted(o.name for o in bpy.data.objects if o.type == 'CAMERA'))
            what = ("there is no object '%s'" % name if cam is None
                    else "object '%s' is of type %s, not a camera" % (name, cam.type))
            raise ExportError("%s; camera objects in this file: %s" % (what, cams or "none"))
    check_projection(cam, cam.data)
    return cam


def check_projection(cam, data):
    if data.type != 'PERSP':
        kind = {"ORTHO": "orthographic", "PANO": "panoramic"}.get(data.type, data.type)
        raise ExportError("camera '%s' is %s (type %s): nebula camera paths need a perspective "
                          "camera (type PERSP)" % (cam.name, kind, data.type))


def frames(start, end, step):
    """start, start+step, ... and always end."""
    fs = list(range(start, end + 1, step))
    if fs[-1] != end:
        fs.append(end)
    return fs


def horizontal_fov(data, render):
    """Horizontal field of view (degrees) of the rendered image, as Blender computes it
    (BKE_camera_sensor_fit / BKE_camera_params_compute_viewplane)."""
    size_x = render.resolution_x * render.pixel_aspect_x
    size_y = render.resolution_y * render.pixel_aspect_y
    fit = data.sensor_fit
    if fit == 'AUTO':
        # AUTO fits sensor_width to the larger side of the image.
        sensor = data.sensor_width
        fit = 'HORIZONTAL' if size_x >= size_y else 'VERTICAL'
    elif fit == 'HORIZONTAL':
        sensor = data.sensor_width
    else:
        sensor = data.sensor_height
    half = math.atan(sensor / (2.0 * data.lens))  # half-angle along the fitted side
    if fit == 'VERTICAL':
        half = math.atan(math.tan(half) * size_x / size_y)
    return math.degrees(2.0 * half)


def normalized(v):
    n = math.sqrt(sum(c * c for c in v))
    if not n > 0.0:
        raise ValueError("zero vector")
    return [c / n for c in v]


def look_distance(data, eye, forward):
    """The camera's focus distance along the view axis (Blender units), or the default."""
    d = 0.0
    if data.dof.focus_object is not None:
        # As BKE_camera_object_dof_distance: the focus object's distance along the
        # view axis. data is the evaluated camera data, so focus_object is the
        # evaluated object at this frame.
        t = data.dof.focus_object.matrix_world.translation
        d = abs(sum((t[i] - eye[i]) * forward[i] for i in range(3)))
    elif data.dof.focus_distance > 0.0:
        d = data.dof.focus_distance
    return d if d > 1e-6 else DEFAULT_LOOK_DISTANCE


def round9(x):
    """9 significant digits; -0.0 becomes 0.0."""
    return float("%.9g" % x) + 0.0


def sample(scene, cam, frame_list, frame_start, fps, scale):
    keys = []
    shift_warned = False
    for f in frame_list:
        scene.frame_set(f)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        cam_eval = cam.evaluated_get(depsgraph)
        data = cam_eval.data  # evaluated: animated lens, sensor, focus distance
        check_projection(cam, data)
        if (data.shift_x != 0.0 or data.shift_y != 0.0) and not shift_warned:
            print("%s: warning: camera '%s' has a lens shift (%g, %g) at frame %d; a nebula "
                  "camera path cannot express it, the exported view is unshifted"
                  % (PROG, cam.name, data.shift_x, data.shift_y, f), file=sys.stderr)
            shift_warned = True
        m = cam_eval.matrix_world
        eye = [m[i][3] for i in range(3)]
        try:
            # Columns of the 3x3 part: local X, Y, Z axes in world space (scale ignored).
            forward = normalized([-m[i][2] for i in range(3)])
            up = [m[i][1] for i in range(3)]
            # Make up orthogonal to the view direction (a no-op unless the
            # matrix is sheared by a non-uniformly scaled parent).
            d = sum(up[i] * forward[i] for i in range(3))
            up = normalized([up[i] - d * forward[i] for i in range(3)])
        except ValueError:
            raise ExportError("camera '%s' has a degenerate (zero-scale) matrix at frame %d"
                              % (cam.name, f))
        if data.lens <= 0.0:
            raise ExportError("camera '%s' has lens %g mm at frame %d" % (cam.name, data.lens, f))
        dist = look_distance(data, eye, forward)
        look_at = [eye[i] + forward[i] * dist for i in range(3)]
        fov = horizontal_fov(data, scene.render)
        if not 0.0 < fov < 180.0:
            raise ExportError("camera '%s' has a horizontal field of view of %g degrees at frame %d"
                              % (cam.name, fov, f))
        keys.append({
            "time": round9((f - frame_start) / fps),
            "eye": [round9(c / scale) for c in eye],
            "look_at": [round9(c / scale) for c in look_at],
            "up": [round9(c) for c in up],
            "fov": round9(fov),
        })
    return keys


def write_atomically(path, text):
    """Write text to path via a temporary file in the same folder and os.replace."""
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise ExportError("cannot write %s: folder %s does not exist" % (path, folder))
    fd, tmp = tempfile.mkstemp(dir=folder, prefix="." + os.path.basename(path) + ".", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        # mkstemp makes the file private (0600); give it the usual permissions.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def to_json(fps, keys):
    # One keyframe per line: readable and diff-friendly.
    fps_out = int(fps) if float(fps).is_integer() else round9(fps)
    lines = ['{"fps": %s,' % json.dumps(fps_out), ' "keyframes": [']
    lines += ["  " + json.dumps(k) + ("," if i + 1 < len(keys) else "") for i, k in enumerate(keys)]
    lines.append(" ]}")
    return "\n".join(lines) + "\n"


def main():
    opts = parse_args(sys.argv)
    scene = bpy.context.scene
    cam = find_camera(scene, opts.camera)
    start = scene.frame_start if opts.frame_start is None else opts.frame_start
    end = scene.frame_end if opts.frame_end is None else opts.frame_end
    if end < start:
        raise ExportError("frame range %d..%d is empty (end before start)" % (start, end))
    fps = scene.render.fps / scene.render.fps_base
    if not fps > 0.0:
        raise ExportError("scene '%s' has a frame rate of %g" % (scene.name, fps))
    output = bpy.path.abspath(opts.output) if opts.output.startswith("//") else opts.output

    old_frame = scene.frame_current
    try:
        keys = sample(scene, cam, frames(start, end, opts.step), start, fps, opts.scale)
    finally:
        scene.frame_set(old_frame)
    keys.sort(key=lambda k: k["time"])  # already in order; keep the promise explicit
    try:
        write_atomically(output, to_json(fps, keys))
    except OSError as e:
        raise ExportError("cannot write %s: %s" % (output, e))
    print("%s: wrote %s: camera '%s', frames %d..%d step %d, %d keyframes, %.6g fps"
          % (PROG, output, cam.name, start, end, opts.step, len(keys), fps))


if __name__ == "__main__":
    try:
        main()
    except ExportError as e:
        print("%s: error: %s" % (PROG, e), file=sys.stderr)
        sys.exit(1)
