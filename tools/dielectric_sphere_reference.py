#!/usr/bin/env python3
# dielectric_sphere_reference.py: a smooth black dielectric sphere under a uniform white sky, as a glTF file and as its analytic image (Schlick's Fresnel curve).
"""Usage: python3 tools/dielectric_sphere_reference.py [--gltf OUT.gltf] [--out REF.exr] [--roughness R]
                                                       [--size N] [--mitsuba] [--window] [--mask OUT.exr]

The scene: a unit sphere (make_scenes' uv_sphere, 96 segments) of baseColor 0, metallic 0,
roughness 0 (glTF's dielectric: F0 0.04 from ior 1.5, Schlick's Fresnel), seen by an orthographic
camera (xmag = ymag = 1.1) along -Z; pmview renders it with `--sky white` (radiance 1).

The reference: under a uniform sky of radiance 1 a black dielectric reflects, toward the camera,
its directional albedo, which for a smooth lobe is Schlick's F(cos) = 0.04 + 0.96 (1 - cos)^5
with cos = n . v the true sphere's. Each pixel is the mean of 16 x 16 stratified points; pixels
not wholly inside radius 0.97 (the mesh's silhouette and its interpolated normals differ from the
sphere's there) are NaN, which pmview --reference leaves out of its measures. The EXR is written
through Mitsuba's Bitmap (an image writer here). With --mitsuba the script also renders the scene
with Mitsuba 3's smooth `plastic` (exact Fresnel at ior 1.5, black diffuse) for comparison, and
prints both image means over the same pixels: the exact Fresnel curve reflects more than
Schlick's, which glTF's BRDF specifies.

--window adds a "window" behind the camera: an emitter of radiance 1 over x, y in [-3, 3] at z = 5
facing the sphere (render without a sky), which the sphere's middle reflects. --mask writes an
image of 1 over the pixels wholly within radius 0.15 of the middle and NaN elsewhere: pmview
--reference with it prints the mean over those pixels as its mean ratio."""
import argparse
import json
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes"))
import make_scenes as ms  # noqa: E402

MAG = 1.1
INSIDE = 0.97


def scene(roughness, window=False):
    sphere = ms.mesh("sphere", ms.uv_sphere(96, 48), {"kind": "dielectric", "color": (0.0, 0.0, 0.0), "roughness": roughness})
    camera = {"eye": (0.0, 0.0, 3.0), "target": (0.0, 0.0, 0.0), "yfov": 0.8, "aspect": 1.0}
    meshes = [sphere]
    if window:
        meshes.append(ms.mesh("window", ms.quad([(3, -3, 5), (-3, -3, 5), (-3, 3, 5), (3, 3, 5)], (0, 0, -1)),
                              {"kind": "emitter", "color": (1.0, 1.0, 1.0), "strength": 1.0}))
    return {"meshes": meshes, "camera": camera, "lights": []}


def gltf(roughness, window=False):
    doc = ms.to_gltf(scene(roughness, window))
    doc["cameras"] = [{"type": "orthographic", "orthographic": {"xmag": MAG, "ymag": MAG, "znear": 0.01, "zfar": 100.0}}]
    return doc


def schlick(c):
    return 0.04 + 0.96 * (1.0 - c) ** 5


def analytic(size, sub=16):
    """Rows top to bottom, RGB per pixel; NaN where the pixel is not wholly on the sphere."""
    out = []
    for py in range(size):
        for px in range(size):
            corners = [(MAG * (2.0 * (px + a) / size - 1.0), MAG * (1.0 - 2.0 * (py + b) / size)) for a in (0, 1) for b in (0, 1)]
            if max(x * x + y * y for x, y in corners) > INSIDE * INSIDE:
                out.append(float("nan"))
                continue
            total = 0.0
            for i in range(sub):
                for j in range(sub):
                    x = MAG * (2.0 * (px + (i + 0.5) / sub) / size - 1.0)
                    y = MAG * (1.0 - 2.0 * (py + (j + 0.5) / sub) / size)
                    total += schlick(math.sqrt(max(0.0, 1.0 - x * x - y * y)))
            out.append(total / (sub * sub))
    return out


def write_exr(path, values, size):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    data = [v for v in values for _ in range(3)]
    mi.Bitmap(mi.TensorXf(data, shape=(size, size, 3))).write(path)


def mitsuba_plastic_mean(gltf_doc, values, size, spp):
    """Mitsuba 3's smooth black plastic (exact Fresnel) under a constant sky: its mean over the reference's pixels."""
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    sphere = ms.uv_sphere(96, 48)
    pos, nrm, idx = sphere["positions"], sphere["normals"], sphere["indices"]
    mesh = mi.Mesh("sphere", len(pos), len(idx) // 3, has_vertex_normals=True)
    params = mi.traverse(mesh)
    params["vertex_positions"] = [c for p in pos for c in p]
    params["vertex_normals"] = [c for n in nrm for c in n]
    params["faces"] = idx
    params.update()
    mesh.set_bsdf(mi.load_dict({"type": "plastic", "diffuse_reflectance": {"type": "rgb", "value": [0, 0, 0]},
                                "int_ior": 1.5, "ext_ior": 1.0, "nonlinear": False}))
    sc = mi.load_dict({"type": "scene", "integrator": {"type": "path", "max_depth": 8},
                       "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [1, 1, 1]}},
                       "sphere": mesh,
                       "camera": {"type": "orthographic",
                                  "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 3], target=[0, 0, 0], up=[0, 1, 0])
                                  @ mi.ScalarTransform4f().scale([MAG, MAG, 1]),
                                  "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "box"}},
                                  "sampler": {"type": "independent", "sample_count": spp}}})
    img = mi.render(sc)
    flat = list(img.array)  # rows top to bottom, 3 channels a pixel
    keep = [i for i, v in enumerate(values) if not math.isnan(v)]
    return sum(float(flat[3 * i]) for i in keep) / len(keep)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gltf")
    ap.add_argument("--out")
    ap.add_argument("--roughness", type=float, default=0.0)
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--mitsuba", action="store_true")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--window", action="store_true")
    ap.add_argument("--mask")
    a = ap.parse_args()
    if a.gltf:
        with open(a.gltf, "w") as f:
            json.dump(gltf(a.roughness, a.window), f, separators=(",", ":"))
            f.write("\n")
    if a.mask:
        values = []
        for py in range(a.size):
            for px in range(a.size):
                corners = [(MAG * (2.0 * (px + u) / a.size - 1.0), MAG * (1.0 - 2.0 * (py + v) / a.size)) for u in (0, 1) for v in (0, 1)]
                values.append(1.0 if max(x * x + y * y for x, y in corners) <= 0.15 * 0.15 else float("nan"))
        write_exr(a.mask, values, a.size)
    if a.out or a.mitsuba:
        values = analytic(a.size)
        kept = [v for v in values if not math.isnan(v)]
        print("analytic Schlick mean over %d pixels: %.6f" % (len(kept), sum(kept) / len(kept)))
        if a.out:
            write_exr(a.out, values, a.size)
        if a.mitsuba:
            print("Mitsuba smooth plastic (exact Fresnel) over the same pixels: %.6f" % mitsuba_plastic_mean(None, values, a.size, a.spp))


if __name__ == "__main__":
    main()
