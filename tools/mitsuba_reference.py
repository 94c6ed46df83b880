#!/usr/bin/env python3
# mitsuba_reference.py: renders pmview's shipped scenes with Mitsuba 3 (scalar_rgb) into the reference EXRs of tests/ref/.
"""Independent Mitsuba 3 reference renders of the scenes built by scenes/make_scenes.py.

    python3 tools/mitsuba_reference.py --scene cornell --integrator path --width 64 --height 64 \
        --spp 16384 --halves --out tests/ref/cornell_path_64.exr

Mitsuba is a tool for making references only; pmview never links or imports it. The scene is
taken from make_scenes.py's Python dicts rather than from the .gltf files so that no glTF
importer of ours (or Mitsuba's lack of one) can disagree with pmview about the triangles.
See tests/ref/README.md for the files this produced and the material/light mapping.
"""
import argparse
import math
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "scenes"))

import make_scenes  # noqa: E402

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

# The LLVM variants crash on the machine these were made on, and a 64x64 reference does not need them.
mi.set_variant("scalar_rgb")

SCENES = {"cornell": make_scenes.cornell_box, "caustic": make_scenes.caustic, "glossy": make_scenes.glossy_spheres,
          "mirror": make_scenes.mirror_caustic, "point_room": make_scenes.point_room,
          "window_room": make_scenes.window_room, "window_hollow": make_scenes.window_room_hollow}


def rgb(c):
    return {"type": "rgb", "value": [float(x) for x in c]}


def bsdf_and_emitter(material):
    """The Mitsuba counterpart of a make_scenes material, mirroring what pmview's loader makes of
    the glTF material that make_scenes.gltf_material() writes for it."""
    kind, color = material["kind"], material.get("color", (1.0, 1.0, 1.0))
    if kind == "diffuse":
        # pmview reflects off both faces of any non-emissive surface (it flips the normal toward
        # the viewer), so a one-sided Mitsuba diffuse would go black from behind where pmview does not.
        return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": rgb(color)}}, None
    if kind == "mirror":
        # metallic 1 / roughness 0 with baseColor c: pmview makes a perfect mirror of constant
        # reflectance c, no Fresnel falloff; material 'none' is Mitsuba's ideal conductor.
        return {"type": "conductor", "material": "none", "specular_reflectance": rgb(color)}, None
    if kind == "metal":
        # metallic 1 with roughness r: pmview's glTF lobe is GGX with alpha = r^2 and Schlick F with
        # F0 = baseColor. make_scenes' metals are white, where Schlick is 1 at every angle, exactly
        # the ideal conductor ('none') here; visible-normal sampling is Mitsuba's default. Mitsuba's
        # Smith term is the separable G1(wi) G1(wo), pmview's the height-correlated one (see
        # tests/ref/README.md for the difference this leaves).
        return {"type": "roughconductor", "material": "none", "distribution": "ggx",
                "alpha": float(material["roughness"]) ** 2, "specular_reflectance": rgb(color)}, None
    if kind == "glass":
        ior = float(material.get("ior", 1.5))
        return {"type": "dielectric", "int_ior": ior, "ext_ior": 1.0,
                "specular_reflectance": rgb(color), "specular_transmittance": rgb(color)}, None
    if kind == "emitter":
        # gltf_material() writes the lamp with baseColor 0: it emits but reflects nothing. Mitsuba's
        # default BSDF would be a 0.5 grey, so the black diffuse is needed, not decoration.
        radiance = [c * material["strength"] for c in color]
        # 'area' emits from the front of the shading frame only, which is the vertex normal;
        # make_scenes gives the lamp both a downward normal and a winding whose cross product
        # points down, so Mitsuba's front and pmview's glTF front are the same face.
        return {"type": "diffuse", "reflectance": rgb((0.0, 0.0, 0.0))}, {"type": "area", "radiance": rgb(radiance)}
    raise ValueError("unknown material kind %r" % kind)


def build_mesh(m):
    """A Mitsuba mesh in world space: glTF node scale then translation, as pmview applies them."""
    s, t = float(m["scale"]), m["translation"]
    positions = [p[i] * s + t[i] for p in m["positions"] for i in range(3)]
    # A uniform scale leaves normal directions unchanged; renormalise only against rounding.
    normals = []
    for n in m["normals"]:
        ln = math.sqrt(sum(c * c for c in n)) or 1.0
        normals += [c / ln for c in n]
    bsdf, emitter = bsdf_and_emitter(m["material"])
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(bsdf)
    if emitter is not None:
        props["emitter"] = mi.load_dict(emitter)
    mesh = mi.Mesh(m["name"], len(m["positions"]), len(m["indices"]) // 3, props=props, has_vertex_normals=True)
    params = mi.traverse(mesh)
    params["vertex_positions"] = dr.scalar.ArrayXf(positions)
    params["faces"] = dr.scalar.ArrayXu(m["indices"])
    params["vertex_normals"] = dr.scalar.ArrayXf(normals)
    params.update()
    return mesh


def camera_to_world(cam):
    """pmview reads the glTF camera node: rotation look_at_rotation(eye, target), looking down its
    local -Z with +Y up and +X to the right of the image. Mitsuba's camera looks down +Z with +X to
    the image's left, so its local X and Z axes are the glTF ones negated."""
    x, y, z, w = make_scenes.look_at_rotation(cam["eye"], cam["target"])
    r = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    e = cam["eye"]
    rows = [[-r[i][0], r[i][1], -r[i][2], float(e[i])] for i in range(3)] + [[0.0, 0.0, 0.0, 1.0]]
    return mi.ScalarTransform4f(rows)


def build_scene(name, width, height, integrator, spp, segments=None, sky="none"):
    scene = SCENES[name]() if segments is None else SCENES[name](segments=segments)
    d = {"type": "scene"}
    for i, m in enumerate(scene["meshes"]):
        d["mesh_%02d_%s" % (i, m["name"])] = build_mesh(m)
    for i, light in enumerate(scene["lights"]):
        if light["type"] == "point":
            # KHR_lights_punctual point intensity is candela-like W/sr, which is what Mitsuba's
            # 'intensity' means too; pmview multiplies color by it the same way.
            d["light_%d" % i] = {"type": "point", "position": [float(c) for c in light["position"]],
                                 "intensity": rgb([c * light["intensity"] for c in light["color"]])}
        elif light["type"] == "directional":
            # KHR_lights_punctual directional intensity is W/m^2 on a surface facing the light, and
            # so is Mitsuba's 'irradiance'; Mitsuba's 'direction' is the way the light travels, the
            # glTF node's -Z (make_scenes' "direction").
            d["light_%d" % i] = {"type": "directional", "direction": [float(c) for c in light["direction"]],
                                 "irradiance": rgb([c * light["intensity"] for c in light["color"]])}
        else:
            raise ValueError("only point and directional lights are mapped (got %r)" % light["type"])
    if sky == "white":
        # pmview --sky white: radiance 1 from every direction, no geometry (the file has no sky)
        d["sky"] = {"type": "constant", "radiance": 1.0}
    elif sky != "none":
        raise ValueError("unknown sky %r" % sky)
    cam = scene["camera"]
    d["sensor"] = {
        "type": "perspective",
        "fov_axis": "y",
        "fov": math.degrees(cam["yfov"]),
        "near_clip": 0.01,
        "to_world": camera_to_world(cam),
        "sampler": {"type": "independent", "sample_count": spp},
        "film": {"type": "hdrfilm", "width": width, "height": height, "pixel_format": "rgb",
                 "component_format": "float32", "rfilter": {"type": "box"}},
    }
    d["integrator"] = integrator
    return mi.load_dict(d)


def integrator_dict(kind, rr_depth):
    if kind == "direct":
        # one emitter sample and one BSDF sample per pixel sample, MIS-weighted (Mitsuba's default)
        return {"type": "direct"}
    if kind == "path":
        # Russian roulette is unbiased; rr_depth only trades variance for time.
        return {"type": "path", "max_depth": -1, "rr_depth": rr_depth}
    if kind == "ptracer":
        # Light tracing is the only Mitsuba integrator that can see a point light's caustic
        # (light -> glass -> floor -> camera has no path-tracing sample with non-zero pdf).
        return {"type": "ptracer", "max_depth": -1, "rr_depth": rr_depth}
    raise ValueError(kind)


def halves_relmse(a, b, mean):
    """mean over pixels and channels of (a - b)^2 / (mean^2 + 0.01): tests/test_reference.c's relMSE
    with the two halves' mean standing in for the unknown converged image in the denominator."""
    aa, ba, ma = a.array, b.array, mean.array
    return float(dr.sum((aa - ba) * (aa - ba) / (ma * ma + 0.01))) / len(ma)


def channel_means(img):
    """The image's mean per channel (R, G, B) of an (height, width, 3) image."""
    flat = list(img.array)
    n = len(flat) // 3
    return [sum(flat[c::3]) / n for c in range(3)]


def halves_mean_error(a, b):
    """Per channel: the standard error of the mean image's channel mean, from the pixels' own
    spread between the halves: a pixel of (a + b) / 2 has variance E[(a - b)^2] / 4, pixels are
    independent, so var(channel mean) = sum (a - b)^2 / 4 / n^2."""
    fa, fb = list(a.array), list(b.array)
    n = len(fa) // 3
    return [math.sqrt(sum((x - y) ** 2 for x, y in zip(fa[c::3], fb[c::3])) / 4.0) / n for c in range(3)]


def box_downsample(img, width, height, factor):
    """Average factor x factor pixel blocks of an (height, width, 3) image."""
    if width % factor or height % factor:
        raise ValueError("--box-downsample: %dx%d is not a multiple of %d" % (width, height, factor))
    flat = list(img.array)
    sw, sh = width // factor, height // factor
    out = [0.0] * (sw * sh * 3)
    for y in range(height):
        row = (y // factor) * sw
        for x in range(width):
            o, i = (row + x // factor) * 3, (y * width + x) * 3
            for c in range(3):
                out[o + c] += flat[i + c]
    scale = 1.0 / (factor * factor)
    return mi.TensorXf([v * scale for v in out], shape=(sh, sw, 3))


def write_exr(img, path):
    """An (height, width, 3) image as an RGB float32 EXR; Mitsuba writes it as lossless PIZ, which
    pmview reads with OpenEXRCore."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    mi.Bitmap(img, pixel_format=mi.Bitmap.PixelFormat.RGB).write(path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", choices=sorted(SCENES), default="cornell")
    ap.add_argument("--integrator", choices=["direct", "path", "ptracer"], default="path")
    ap.add_argument("--width", type=int, default=64)
    ap.add_argument("--height", type=int, default=64)
    ap.add_argument("--spp", type=int, default=1024, help="samples per pixel in total (ptracer: light paths per pixel)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--rr-depth", type=int, default=5, help="path length where Russian roulette starts")
    ap.add_argument("--segments", type=int, default=None, help="sphere tessellation (default: make_scenes' default)")
    ap.add_argument("--sky", choices=["none", "white"], default="none",
                    help="environment: none, or white (a constant emitter of radiance 1, as pmview --sky white)")
    ap.add_argument("--threads", type=int, default=None, help="Mitsuba's render threads (default: all cores)")
    ap.add_argument("--halves", action="store_true",
                    help="render spp/2 twice with seeds seed and seed+1, write their mean and print relMSE(half1, half2)/4, "
                         "an estimate of the written image's own relMSE against the converged image")
    ap.add_argument("--chunks", type=int, default=2,
                    help="with --halves: render spp in this many equal chunks (seeds seed, seed+1, ...; even chunks make "
                         "one half, odd ones the other), writing the image so far after every pair (default 2: the halves)")
    ap.add_argument("--max-seconds", type=float, default=None,
                    help="with --halves: start no new pair of chunks after this many seconds; the file then holds the "
                         "pairs done, and the line 'spp done' gives the --spp and --chunks that render it again")
    ap.add_argument("--out", required=True)
    ap.add_argument("--box-downsample", nargs=2, metavar=("FACTOR", "OUT"), default=None,
                    help="also write the image averaged over FACTORxFACTOR blocks: with pmview's box pixel filter that is "
                         "exactly the image at 1/FACTOR resolution, with FACTOR^2 times the samples per pixel")
    args = ap.parse_args()
    all_threads = dr.thread_count()
    if args.threads is not None:
        dr.set_thread_count(args.threads)  # the pool mi.render's scalar variants render blocks on

    scene = build_scene(args.scene, args.width, args.height, integrator_dict(args.integrator, args.rr_depth), args.spp,
                        args.segments, args.sky)
    t0 = time.time()
    if args.halves:
        if args.chunks < 2 or args.chunks % 2:
            sys.exit("mitsuba_reference: --chunks must be even and at least 2 (got %d)" % args.chunks)
        chunk = max(1, args.spp // args.chunks)
        sum_a = sum_b = None
        pairs = 0
        # chunks 2k and 2k+1 (seeds seed+2k, seed+2k+1) go to halves a and b; with 2 chunks this is
        # one render of spp/2 per half, seeds seed and seed+1.
        while 2 * pairs < args.chunks:
            ca = mi.render(scene, seed=args.seed + 2 * pairs, spp=chunk)
            cb = mi.render(scene, seed=args.seed + 2 * pairs + 1, spp=chunk)
            sum_a = ca if sum_a is None else sum_a + ca
            sum_b = cb if sum_b is None else sum_b + cb
            pairs += 1
            a, b = sum_a / pairs, sum_b / pairs
            img = (a + b) * 0.5
            if 2 * pairs < args.chunks:
                # the image so far, so that a run stopped from outside still leaves a usable file
                # (written on the full pool: see below)
                dr.set_thread_count(all_threads)
                write_exr(img, args.out)
                if args.threads is not None:
                    dr.set_thread_count(args.threads)
                print("chunks %d of %d, %d spp, %.1f s, estimated relMSE %.3g" % (
                    2 * pairs, args.chunks, 2 * pairs * chunk, time.time() - t0, halves_relmse(a, b, img) / 4.0),
                    flush=True)
                if args.max_seconds is not None and time.time() - t0 > args.max_seconds:
                    break
        # E[(a-b)^2] = 2 var(half) = 4 var(mean): the divide by 4 makes it the mean's own error.
        noise = halves_relmse(a, b, img) / 4.0
        mean_a, mean_b, mean_se = channel_means(a), channel_means(b), halves_mean_error(a, b)
        spp = 2 * pairs * chunk
        print("spp done: --spp %d --chunks %d" % (spp, 2 * pairs))
    else:
        img = mi.render(scene, seed=args.seed, spp=args.spp)
        noise, spp = None, args.spp
    seconds = time.time() - t0
    # Mitsuba 3.9.1's EXR writer never returns when the pool has a single thread (seen here: it
    # waits on OpenEXR's own thread pool forever), so writing gets the default pool back.
    dr.set_thread_count(all_threads)

    write_exr(img, args.out)
    print("wrote %s: %s %s %dx%d, %d spp, seed %d, sky %s, %.1f s, mitsuba %s" % (
        args.out, args.scene, args.integrator, args.width, args.height, spp, args.seed, args.sky, seconds,
        mi.__version__))
    means = channel_means(img)
    print("channel means (R, G, B): %.6g %.6g %.6g" % tuple(means))
    if noise is not None:
        print("estimated relMSE of the written image (independent halves): %.3g" % noise)
        print("halves' channel means: %.6g %.6g %.6g and %.6g %.6g %.6g; relative difference %s" % (
            tuple(mean_a) + tuple(mean_b) + (" ".join("%+.2e" % ((x - y) / m) for x, y, m in zip(mean_a, mean_b, means)),)))
        print("estimated relative standard error of the channel means (pixel spread between halves): %s" %
              " ".join("%.2e" % (e / m) for e, m in zip(mean_se, means)))
    if args.box_downsample:
        factor, small_path = int(args.box_downsample[0]), args.box_downsample[1]
        small = box_downsample(img, args.width, args.height, factor)
        mi.Bitmap(small, pixel_format=mi.Bitmap.PixelFormat.RGB).write(small_path)
        print("wrote %s: %dx%d box average of the above, %d spp per pixel" % (
            small_path, args.width // factor, args.height // factor, spp * factor * factor))


if __name__ == "__main__":
    main()
