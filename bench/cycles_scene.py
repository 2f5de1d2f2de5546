# SPDX-License-Identifier: Apache-2.0
"""Blender Cycles version of a nebrender scene, and image statistics, for
bench/cycles_vs_path.sh.

Render:  blender -b --factory-startup --python-exit-code 1 --python bench/cycles_scene.py -- \
             --vdb n.vdb -o out.exr --light X,Y,Z --sigma-t 1.5e-3 --samples 64 --seed 1 [options]
Compare: blender -b --factory-startup --python-exit-code 1 --python bench/cycles_scene.py -- \
             --noise REF.exr A.exr B.exr [--threshold 0.01] [--png FILE]   (see noise_main)

The render builds, from an empty factory scene:
  * a Volume object holding the VDB file (grid "density": n_H [cm^-3]) with the identity
    transform plus --offset (world units = the file's units, parsecs), render precision
    FULL (not the default HALF), clipping 0 (no density threshold), automatic step size
    (the voxel size).  Cycles' NanoVDB trilinear lookup reads index coordinate p - 0.5
    (intern/cycles/kernel/device/cpu/image.h, NanoVDBInterpolator::interp_3d_linear), so it
    draws every voxel half a voxel towards +x+y+z of OpenVDB's voxel centre; pass
    --offset=-h,-h,-h (h = half the voxel size) to put the values where OpenVDB has them;
  * a Principled Volume material.  Cycles' svm_node_principled_volume computes
        sigma_s = Color * Density * attr(density)
        sigma_t = (Color + (1 - Color) (1 - sqrt(AbsorptionColor))) * Density * attr(density)
    so with Absorption Color black: sigma_t = Density * attr, albedo = Color; hence
    Density = --sigma-t (extinction per unit of the grid per world unit: kappa_V times the
    extinction ratio), Color = --albedo (grey, linear), Anisotropy = --g (Henyey-Greenstein);
    no emission, no blackbody; with --ratios (coloured dust: A/A_V per channel) Color and
    Absorption Color per channel give each channel its own sigma_t and the same albedo (see
    build_scene);
  * a point light (radius 0) at --light of power --power [W] and linear colour
    --light-color.  Its irradiance is power * colour / (4 pi r^2) (a white Lambertian plane
    at 1 m from a 1000 W light renders at 1000 / (4 pi^2)), so --power L [L_sun] gives
    radiances in nebrender's units, L_sun pc^-2 sr^-1;
  * a perspective camera at --eye looking at --look-at with --up (right = forward x up, as
    nebrender), horizontal field of view --fov (sensor fit HORIZONTAL), --res WxH pixels;
  * black world, opaque film, no denoising, fixed sample count (no adaptive sampling, no
    time limit), the given seed, no clamping, --bounces for max/volume/transparent bounces,
    a 0.01-pixel Gaussian filter (pixel-centre sampling, like nebrender), --step-rate for the
    volume ray marching (scene.cycles.volume_step_rate; material step rate 1), --max-steps,
    --volume-sampling (default MULTIPLE_IMPORTANCE: distance + equiangular), path guiding
    off unless --guiding, all CPU threads unless --threads.
It writes a single-layer 32-bit float OpenEXR (R,G,B,A, linear) to -o, with --png also a PNG
(Standard view transform, --exposure stops), and prints one line
    cycles: render S s, cpu C s, samples N, res WxH, threads T, step rate R
S and C: wall and process CPU time of bpy.ops.render.render (scene sync and rendering, no
file output, no Blender start-up).
"""

import argparse
import math
import sys
import time

import bpy
from mathutils import Matrix, Vector


def vec3(text):
    parts = [float(x) for x in text.split(",")]
    if len(parts) != 3:
        raise argparse.ArgumentTypeError(f"expected X,Y,Z, got {text!r}")
    return Vector(parts)


def resolution(text):
    w, h = (int(x) for x in text.lower().split("x"))
    return w, h


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="cycles_scene.py")
    p.add_argument("--vdb", required=True, help="VDB file with a 'density' grid")
    p.add_argument("-o", "--output", required=True, help="output EXR")
    p.add_argument("--png", help="also write this PNG")
    p.add_argument("--exposure", type=float, default=0.0, help="PNG exposure [stops]")
    p.add_argument("--samples", type=int, default=64)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--res", type=resolution, default=(256, 256))
    p.add_argument("--eye", type=vec3, default=vec3("4,3,-19"))
    p.add_argument("--look-at", type=vec3, default=vec3("0,0,0"))
    p.add_argument("--up", type=vec3, default=vec3("0,1,0"))
    p.add_argument("--fov", type=float, default=36.0, help="horizontal field of view [deg]")
    p.add_argument("--offset", type=vec3, default=vec3("0,0,0"),
                   help="translation of the volume object [world units]")
    p.add_argument("--light", type=vec3, required=True, help="point light position")
    p.add_argument("--power", type=float, default=1000.0, help="point light power [W]")
    p.add_argument("--light-color", type=vec3, default=vec3("1,1,1"))
    p.add_argument("--sigma-t", type=float, required=True,
                   help="extinction per unit of the density grid per world unit")
    p.add_argument("--ratios", type=vec3, default=vec3("1,1,1"),
                   help="extinction ratio A/A_V per channel R,G,B (coloured dust)")
    p.add_argument("--albedo", type=float, default=0.6)
    p.add_argument("--g", type=float, default=0.6)
    p.add_argument("--step-rate", type=float, default=1.0,
                   help="scene.cycles.volume_step_rate (step = rate * voxel size)")
    p.add_argument("--max-steps", type=int, default=4096, help="scene.cycles.volume_max_steps")
    p.add_argument("--bounces", type=int, default=128)
    p.add_argument("--volume-sampling", default="MULTIPLE_IMPORTANCE",
                   choices=["DISTANCE", "EQUIANGULAR", "MULTIPLE_IMPORTANCE"])
    p.add_argument("--interpolation", default="LINEAR", choices=["LINEAR", "CUBIC"])
    p.add_argument("--guiding", action="store_true", help="path guiding (CPU, Cycles 3.4+)")
    p.add_argument("--threads", type=int, default=0, help="0: all cores")
    return p.parse_args(argv)


def clear_scene():
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj, do_unlink=True)
    for coll in (bpy.data.meshes, bpy.data.materials, bpy.data.lights, bpy.data.cameras,
                 bpy.data.volumes):
        for block in list(coll):
            coll.remove(block)


def look_at_matrix(eye, target, up):
    """World matrix of a Blender camera (looks down its -Z, +Y up) at eye looking at target."""
    f = (target - eye).normalized()
    r = f.cross(up).normalized()  # nebrender: right = forward x up
    u = r.cross(f)
    m = Matrix.Identity(4)
    for i in range(3):
        m[i][0], m[i][1], m[i][2], m[i][3] = r[i], u[i], -f[i], eye[i]
    return m


def read_exr(path):
    """Every channel of a scanline OpenEXR file (single part, NONE/ZIPS/ZIP compression,
    HALF/FLOAT/UINT channels: what nebrender and Blender write) as {name: float64 array of
    the pixels, rows top to bottom}, and (width, height).  A few lines of numpy, since
    Blender's image API gives no pixels of a multi-layer EXR such as nebrender's."""
    import struct
    import zlib

    import numpy as np

    def fail(msg):
        sys.exit(f"cycles_scene.py: error: {path}: {msg}")

    with open(path, "rb") as f:
        data = f.read()
    if data[:4] != b"\x76\x2f\x31\x01":
        fail("not an OpenEXR file")
    if data[5] & 0x1a:  # tiled, deep or multi-part (0x04, long names, is fine)
        fail("only single-part scanline EXR files are supported")
    pos, attrs = 8, {}
    while data[pos] != 0:
        name_end = data.index(b"\0", pos)
        type_end = data.index(b"\0", name_end + 1)
        name = data[pos:name_end].decode()
        size = struct.unpack_from("<i", data, type_end + 1)[0]
        attrs[name] = data[type_end + 5:type_end + 5 + size]
        pos = type_end + 5 + size
    pos += 1
    channels, c = [], 0
    cl = attrs["channels"]
    while cl[c] != 0:
        end = cl.index(b"\0", c)
        ptype = struct.unpack_from("<i", cl, end + 1)[0]
        channels.append((cl[c:end].decode(), ptype))
        c = end + 1 + 16
    xmin, ymin, xmax, ymax = struct.unpack("<4i", attrs["dataWindow"])
    w, h = xmax - xmin + 1, ymax - ymin + 1
    comp = attrs["compression"][0]
    lines = {0: 1, 2: 1, 3: 16}.get(comp)
    if lines is None:
        fail(f"compression {comp} not supported (NONE, ZIPS or ZIP only)")
    nbytes = {0: 4, 1: 2, 2: 4}
    dtypes = {0: "<u4", 1: "<f2", 2: "<f4"}
    line_bytes = sum(w * nbytes[t] for _, t in channels)
    chunks = (h + lines - 1) // lines
    offsets = struct.unpack_from(f"<{chunks}Q", data, pos)
    out = {name: np.zeros((h, w)) for name, _ in channels}
    for off in offsets:
        y, size = struct.unpack_from("<ii", data, off)
        n = min(lines, ymax - y + 1)
        raw = data[off + 8:off + 8 + size]
        if size < n * line_bytes:  # compressed (stored raw when that is not smaller)
            t = np.frombuffer(zlib.decompress(raw), dtype=np.uint8).astype(np.int64)
            t[1:] -= 128
            t = np.cumsum(t) & 0xFF  # undo the predictor
            half = (len(t) + 1) // 2
            u = np.empty(len(t), dtype=np.uint8)
            u[0::2], u[1::2] = t[:half], t[half:]  # undo the byte split
            raw = u.tobytes()
        p = 0
        for row in range(y - ymin, y - ymin + n):
            for name, ptype in channels:
                k = w * nbytes[ptype]
                out[name][row] = np.frombuffer(raw, dtype=dtypes[ptype], count=w, offset=p)
                p += k
    for name in "RGB":
        if name not in out:
            fail(f"no channel {name!r}")
    return (w, h), {name: v.ravel() for name, v in out.items()}


def noise_main(argv):
    """--noise REF A B [--threshold F] [--png FILE]: A and B are renders of the same scene
    with different seeds, REF a converged render (of either renderer: it is first scaled, per
    channel, to the mean flux of A and B).  Prints, for R, G, B and luminance Y (Rec. 709),
        noise CH N flux_ratio F shape S shape_noise E pixels P
    N = RMS of (A - B) / REF / sqrt(2): the relative noise of one render; F = sum(A + B) /
    (2 sum(REF)); S = RMS of ((A + B) / 2 / F - REF) / REF, the shape difference of the mean
    of A and B from REF; E = the S that noise alone gives: sqrt(N^2 / 2 + REF's own relative
    noise^2), the latter from REF's variance.R/G/B layer (nebrender --integrator path), 0
    without one; EN ("enoise", printed last) = sqrt(sum (A - B)^2 / 2 / sum (F REF)^2), an
    energy-weighted relative noise that faint pixels (and fireflies on them) sway less.  All
    over the pixels where REF is above F (default 0.01) of its maximum in that channel.
    A == B (one file twice) gives noise 0 and the flux ratio and shape of that one image.
    --png: REF | A | B side by side (luminance, each scaled to
    REF's flux, REF's 99.5th percentile white, sRGB)."""
    import numpy as np

    p = argparse.ArgumentParser(prog="cycles_scene.py --noise")
    p.add_argument("ref")
    p.add_argument("a")
    p.add_argument("b")
    p.add_argument("--threshold", type=float, default=0.01)
    p.add_argument("--png")
    n = p.parse_args(argv)
    size, ref = read_exr(n.ref)
    images = []
    for path in (n.a, n.b):
        s, img = read_exr(path)
        if s != size:
            sys.exit(f"cycles_scene.py: error: {path} is {s[0]}x{s[1]}, {n.ref} {size[0]}x{size[1]}")
        images.append(img)
    wts = {"R": 0.2126, "G": 0.7152, "B": 0.0722}

    def chan(img, c, prefix=""):
        if c != "Y":
            return img[prefix + c]
        return sum(w * img[prefix + k] for k, w in wts.items())

    has_var = all(f"variance.{k}" in ref for k in "RGB")
    for c in "RGBY":
        r = chan(ref, c)
        x, y = chan(images[0], c), chan(images[1], c)
        if has_var:
            var = (sum(w * w * ref[f"variance.{k}"] for k, w in wts.items()) if c == "Y"
                   else ref[f"variance.{c}"])
        else:
            var = np.zeros_like(r)
        mask = r > n.threshold * r.max()
        ratio = (x.sum() + y.sum()) / (2.0 * r.sum())
        rm = r[mask]
        noise = np.sqrt(np.mean(((x - y)[mask] / (ratio * rm)) ** 2) / 2.0)
        shape = np.sqrt(np.mean((((x + y)[mask] / (2.0 * ratio) - rm) / rm) ** 2))
        ref_noise2 = np.mean(var[mask] / rm ** 2)
        expected = np.sqrt(noise ** 2 / 2.0 + ref_noise2)
        # Energy-weighted: sqrt(sum (A - B)^2 / 2 / sum REF^2), which faint pixels and
        # fireflies on them sway far less than the per-pixel relative RMS.
        enoise = np.sqrt(np.sum((x - y)[mask] ** 2) / 2.0 / np.sum((ratio * rm) ** 2))
        print(f"noise {c} {noise:.6f} flux_ratio {ratio:.6f} shape {shape:.6f} "
              f"shape_noise {expected:.6f} pixels {mask.sum()} enoise {enoise:.6f}")
    if n.png:
        from PIL import Image
        w, h = size
        y_ref = chan(ref, "Y")
        panels = [y_ref] + [chan(x, "Y") * (y_ref.sum() / chan(x, "Y").sum()) for x in images]
        white = np.percentile(y_ref, 99.5)
        row = np.concatenate([np.clip(q.reshape(h, w) / white, 0.0, 1.0) for q in panels], axis=1)
        srgb = np.where(row <= 0.0031308, 12.92 * row, 1.055 * row ** (1 / 2.4) - 0.055)
        Image.fromarray((255 * srgb + 0.5).astype(np.uint8)).save(n.png)


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if argv and argv[0] == "--noise":
        noise_main(argv[1:])
        return
    a = parse_args()
    clear_scene()
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    cy = scene.cycles
    cy.device = "CPU"

    # Volume object.
    vol = bpy.data.volumes.new("nebula")
    vol.filepath = bpy.path.abspath(a.vdb)
    if not vol.grids.load():
        sys.exit(f"cycles_scene.py: error: {a.vdb}: {vol.grids.error_message or 'cannot load'}")
    names = [g.name for g in vol.grids]
    if "density" not in names:
        sys.exit(f"cycles_scene.py: error: {a.vdb}: no grid 'density' (grids: {names})")
    vol.render.precision = "FULL"
    vol.render.clipping = 0.0
    vol.render.space = "OBJECT"
    vol.render.step_size = 0.0  # automatic: the voxel size
    obj = bpy.data.objects.new("nebula", vol)
    obj.location = a.offset
    scene.collection.objects.link(obj)

    mat = bpy.data.materials.new("dust")
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    pv = nt.nodes.new("ShaderNodeVolumePrincipled")
    # Coloured dust (--ratios r_c): Density = sigma_t r_max, Color_c = a r_c / r_max gives
    # sigma_s,c = a sigma_t r_c attr; the Absorption Color with
    # 1 - sqrt(Abs_c) = q (1 - a) / (1 - a q), q = r_c / r_max, makes sigma_t,c =
    # (Color_c + (1 - Color_c)(1 - sqrt(Abs_c))) Density attr = sigma_t r_c attr. Grey dust
    # (all r_c = 1): Color = a, Absorption Color black, as above.
    rmax = max(a.ratios)
    colour, absorption = [], []
    for r in a.ratios:
        q = r / rmax
        colour.append(a.albedo * q)
        absorption.append((1.0 - q * (1.0 - a.albedo) / (1.0 - a.albedo * q)) ** 2)
    pv.inputs["Color"].default_value = (*colour, 1.0)
    pv.inputs["Density"].default_value = a.sigma_t * rmax
    pv.inputs["Density Attribute"].default_value = "density"
    pv.inputs["Anisotropy"].default_value = a.g
    pv.inputs["Absorption Color"].default_value = (*absorption, 1.0)
    pv.inputs["Emission Strength"].default_value = 0.0
    pv.inputs["Blackbody Intensity"].default_value = 0.0
    nt.links.new(pv.outputs["Volume"], out.inputs["Volume"])
    mat.cycles.volume_sampling = a.volume_sampling
    mat.cycles.volume_interpolation = a.interpolation
    mat.cycles.homogeneous_volume = False
    mat.cycles.volume_step_rate = 1.0
    vol.materials.append(mat)

    # Point light, radius 0.
    light = bpy.data.lights.new("star", type="POINT")
    light.energy = a.power
    light.color = a.light_color
    light.shadow_soft_size = 0.0
    light.cycles.cast_shadow = True
    light_obj = bpy.data.objects.new("star", light)
    light_obj.location = a.light
    scene.collection.objects.link(light_obj)

    # Camera: horizontal fov on a 36 mm wide sensor.
    cam = bpy.data.cameras.new("cam")
    cam.type = "PERSP"
    cam.sensor_fit = "HORIZONTAL"
    cam.sensor_width = 36.0
    cam.lens = 18.0 / math.tan(math.radians(a.fov) / 2.0)
    cam.shift_x = cam.shift_y = 0.0
    cam.clip_start = 1e-3
    cam.clip_end = 1e4
    cam_obj = bpy.data.objects.new("cam", cam)
    cam_obj.matrix_world = look_at_matrix(a.eye, a.look_at, a.up)
    scene.collection.objects.link(cam_obj)
    scene.camera = cam_obj

    # World: black.
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world

    # Render settings.
    r = scene.render
    r.resolution_x, r.resolution_y = a.res
    r.resolution_percentage = 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.film_transparent = False
    r.use_persistent_data = False
    r.threads_mode = "FIXED" if a.threads > 0 else "AUTO"
    if a.threads > 0:
        r.threads = a.threads
    cy.samples = a.samples
    cy.use_adaptive_sampling = False
    cy.time_limit = 0.0
    cy.seed = a.seed
    cy.use_animated_seed = False
    cy.sample_offset = 0
    cy.use_denoising = False
    cy.pixel_filter_type = "GAUSSIAN"
    cy.filter_width = 0.01
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.max_bounces = a.bounces
    cy.volume_bounces = a.bounces
    cy.transparent_max_bounces = a.bounces
    cy.diffuse_bounces = cy.glossy_bounces = cy.transmission_bounces = 0
    cy.caustics_reflective = cy.caustics_refractive = True
    cy.blur_glossy = 0.0
    cy.volume_step_rate = a.step_rate
    cy.volume_preview_step_rate = a.step_rate
    cy.volume_max_steps = a.max_steps
    cy.use_guiding = a.guiding
    if a.guiding:
        cy.use_volume_guiding = True
        cy.use_surface_guiding = False
    if hasattr(cy, "use_light_tree"):
        cy.use_light_tree = False
    scene.view_layers[0].cycles.denoising_store_passes = False
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = a.exposure
    scene.view_settings.gamma = 1.0

    t0, c0 = time.perf_counter(), time.process_time()
    bpy.ops.render.render()
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0

    img = bpy.data.images["Render Result"]
    s = r.image_settings
    s.file_format = "OPEN_EXR"
    s.color_mode = "RGBA"
    s.color_depth = "32"
    s.exr_codec = "ZIP"
    img.save_render(bpy.path.abspath(a.output), scene=scene)
    if a.png:
        s.file_format = "PNG"
        s.color_mode = "RGB"
        s.color_depth = "8"
        img.save_render(bpy.path.abspath(a.png), scene=scene)
    threads = r.threads if r.threads_mode == "FIXED" else "auto"
    print(f"cycles: render {seconds:.3f} s, cpu {cpu:.3f} s, samples {a.samples}, res {a.res[0]}x{a.res[1]}, "
          f"threads {threads}, step rate {a.step_rate}", flush=True)


main()
