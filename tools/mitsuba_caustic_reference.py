#!/usr/bin/env python3
# mitsuba_caustic_reference.py: the Mitsuba 3 particle tracer's image of scenes/caustic.gltf with the pixels the glass ball touches marked unknown (NaN), for whole-image comparisons.
"""    python3 tools/mitsuba_caustic_reference.py --ptracer tests/ref/caustic_ptracer_64.exr \\
        --out tests/ref/caustic_floor_64.exr

The particle tracer (tools/mitsuba_reference.py --integrator ptracer) is the only Mitsuba
integrator that renders a point light's caustic, and it renders every pixel where the camera sees
the floor, caustic included. It cannot connect to the camera through the glass ball, so its ball
pixels are black. Nor can Mitsuba's path tracer fill them: what the eye sees through the ball
includes the caustic seen through the glass (eye -> glass -> floor -> glass -> point light), which
no path from the eye finds; at the ball's lower edge, where the caustic focuses next to it, that
light is most of the pixel. So this script keeps the particle tracer's pixels and writes NaN into
every pixel the ball touches at all: pmview --reference (and tools/error_map) leave NaN pixels
out of their measures. Which pixels the ball touches is rendered too: the ball alone as an
emitter of radiance 1 seen by the same camera and box filter, so a pixel's value is the fraction
of it the ball covers; any fraction above zero marks it.
"""
import argparse
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import mitsuba_reference as mr  # noqa: E402  (sets the scalar_rgb variant, puts scenes/ on the path)
import make_scenes  # noqa: E402

import mitsuba as mi  # noqa: E402


def ball_coverage(width, height, spp):
    """Per pixel, the fraction the glass ball covers: the ball as a unit emitter, nothing else."""
    scene = make_scenes.caustic()
    d = {"type": "scene"}
    for m in scene["meshes"]:
        if m["material"]["kind"] == "glass":
            ball = dict(m)
            ball["material"] = {"kind": "emitter", "color": (1.0, 1.0, 1.0), "strength": 1.0}
            d["ball"] = mr.build_mesh(ball)
    cam = scene["camera"]
    d["sensor"] = {
        "type": "perspective", "fov_axis": "y", "fov": mr.math.degrees(cam["yfov"]), "near_clip": 0.01,
        "to_world": mr.camera_to_world(cam),
        "sampler": {"type": "independent", "sample_count": spp},
        "film": {"type": "hdrfilm", "width": width, "height": height, "pixel_format": "rgb",
                 "component_format": "float32", "rfilter": {"type": "box"}},
    }
    # max_depth 1: only emitters the camera ray meets, so the pixel value is the covered fraction.
    d["integrator"] = {"type": "path", "max_depth": 1}
    return mi.render(mi.load_dict(d), seed=0, spp=spp)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ptracer", required=True, help="the particle tracer's image of the scene")
    ap.add_argument("--mask-spp", type=int, default=4096, help="camera samples per pixel for the ball's coverage")
    ap.add_argument("--out", required=True)
    args = ap.parse_args()

    ptracer = mi.TensorXf(mi.Bitmap(args.ptracer))
    height, width = ptracer.shape[0], ptracer.shape[1]
    coverage = list(ball_coverage(width, height, args.mask_spp).array)
    out = list(ptracer.array)
    unknown = 0
    for p in range(width * height):
        if coverage[3 * p] > 0.0:
            unknown += 1
            out[3 * p:3 * p + 3] = [float("nan")] * 3
    mi.Bitmap(mi.TensorXf(out, shape=(height, width, 3)), pixel_format=mi.Bitmap.PixelFormat.RGB).write(args.out)
    print("wrote %s: %s with the %d of %d pixels the ball touches (coverage > 0 at %d spp) set to NaN"
          % (args.out, args.ptracer, unknown, width * height, args.mask_spp))


if __name__ == "__main__":
    main()
