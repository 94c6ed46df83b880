#!/usr/bin/env python3
# mitsuba_mirror_box.py: the independent reference of tests/test_mirror_box.c: a closed box of emissive 0.99 mirrors rendered by Mitsuba 3 (scalar_rgb), written to tests/ref/mirror_box.txt.
"""Mitsuba 3 reference for the mirror box of tests/test_mirror_box.c.

    python3 tools/mitsuba_mirror_box.py --out tests/ref/mirror_box.txt

The box is [-1, 1]^3; its six walls face inward, emit radiance LE (one-sided, toward the inside)
and are perfect mirrors of constant reflectance 0.99: Mitsuba's ideal conductor (material
'none') scaled by specular_reflectance. pmview's glTF mirror (metallic 1, roughness 0, baseColor
0.99) follows Schlick's curve instead; tests/test_mirror_box.c sums the same chains in double,
checks that sum at a constant 0.99 against this file, and takes it with Schlick's curve as the
reference pmview must meet. A ray from the camera then bounces forever inside, every wall adding LE times the
reflectance so far: L = LE (1 + R + R^2 + ...) = LE / (1 - R) = 100 LE in every direction.

Mitsuba's path integrator is run to max_depth MAX_DEPTH with Russian roulette switched off
(rr_depth past max_depth): each camera path is then the whole mirror chain, deterministic, so the
image is the series truncated after MAX_DEPTH terms (R^MAX_DEPTH = 1e-13 of it missing), with no
noise. The file holds the image's mean R G B and, for comparison, the series' closed form.
Mitsuba is a tool for making this file only; pmview never links or imports it.
"""
import argparse
import time

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

LE = (0.01, 0.02, 0.005)   # emitted radiance per channel; the test builds the same box
R = 0.99                   # baseColor, the mirror's reflectance
MAX_DEPTH = 3000
WIDTH = HEIGHT = 16


def render(spp):
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": MAX_DEPTH, "rr_depth": MAX_DEPTH + 1},
        "sensor": {
            "type": "perspective", "fov": 60.0, "fov_axis": "y",
            # the test's camera: at (0, 0, 0.5) looking toward (0.3, -0.2, -1), y up
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 0.5], target=[0.3, -0.2, -1.0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": WIDTH, "height": HEIGHT, "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "box": {
            "type": "cube",            # [-1, 1]^3
            "flip_normals": True,      # the walls face inward: the mirrors' and the emitters' front
            "bsdf": {"type": "conductor", "material": "none", "specular_reflectance": {"type": "rgb", "value": [R, R, R]}},
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": list(LE)}},
        },
    })
    image = mi.render(scene)
    return mi.Bitmap(image)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--out", default="tests/ref/mirror_box.txt")
    args = ap.parse_args()
    start = time.time()
    bitmap = render(args.spp)
    pixels = np.array(bitmap, copy=False).reshape(-1, 3)
    mean = pixels.mean(axis=0)
    spread = (pixels.max(axis=0) - pixels.min(axis=0)) / mean
    series = [le / (1.0 - R) for le in LE]
    seconds = time.time() - start
    with open(args.out, "w") as f:
        f.write("# mirror box (tools/mitsuba_mirror_box.py): Mitsuba %s scalar_rgb, path integrator max_depth %d, no roulette, "
                "%dx%d, %d spp, %.0f s\n" % (mi.__version__, MAX_DEPTH, WIDTH, HEIGHT, args.spp, seconds))
        f.write("# emission %g %g %g, mirror reflectance %g; the series LE / (1 - R) gives %.6f %.6f %.6f\n"
                % (LE + (R,) + tuple(series)))
        f.write("# pixel spread (max - min) / mean: %.2e %.2e %.2e\n" % tuple(spread))
        f.write("# mean radiance R G B:\n%.6f %.6f %.6f\n" % tuple(mean))
    print("mean %.6f %.6f %.6f (series %.6f %.6f %.6f), spread %.1e, %.0f s" % (tuple(mean) + tuple(series) + (spread.max(), seconds)))


if __name__ == "__main__":
    main()
