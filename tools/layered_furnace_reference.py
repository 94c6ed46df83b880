#!/usr/bin/env python3
# layered_furnace_reference.py: the layered furnace of tests/test_layered_furnace.c solved by a numpy path tracer with its own BRDF, written from brdf.h's formulas, for tests/ref/layered_furnace.txt.
#
# The answer is independent of pmview's code: the layered lobe (GGX base, Charlie sheen, GGX coat, each as
# brdf.h states it), the sheen's albedo table (integrated here by quadrature), the camera's rays and the
# walk through the box are all written below. Directions are sampled by cosine, so no importance
# sampler is shared either. Usage:
#     python3 tools/layered_furnace_reference.py --paths 600000 --chunk 100000 > tests/ref/layered_furnace.txt
import argparse
import math

import numpy as np

LE = 0.5                                   # the walls' emitted radiance
BASE = np.array([0.6, 0.6, 0.6])           # base colour, metallic 0, roughness 1 (alpha 1)
BASE_ALPHA = 1.0
SHEEN = np.array([0.9, 0.7, 0.5])          # sheenColorFactor
SHEEN_R = 0.5                              # sheenRoughnessFactor
SHEEN_ALPHA = SHEEN_R * SHEEN_R            # KHR_materials_sheen: alphaG = sheenRoughness^2
COAT = 1.0                                 # clearcoatFactor
COAT_ALPHA = 0.4 * 0.4                     # clearcoatRoughness^2
CAM_POS = np.array([0.0, 0.0, 0.5])        # sb_camera(position, target, up, yfov 60 degrees), 16x16
CAM_TARGET = np.array([0.3, -0.2, -1.0])
YFOV = math.radians(60.0)


def schlick(f0, f90, c):
    return f0 + (f90 - f0) * (1.0 - c) ** 5


def ggx_d(alpha, ch):
    a2 = alpha * alpha
    t = ch * ch * (a2 - 1.0) + 1.0
    return a2 / (math.pi * t * t)


def smith_lambda(alpha, c):
    c2 = c * c
    return 0.5 * (np.sqrt(1.0 + alpha * alpha * (1.0 - c2) / c2) - 1.0)


def ggx_dv(alpha, co, ci, ch):
    """D(h) G2(wo, wi) / (4 cos_o cos_i), height-correlated Smith G2."""
    g2 = 1.0 / (1.0 + smith_lambda(alpha, co) + smith_lambda(alpha, ci))
    return ggx_d(alpha, ch) * g2 / (4.0 * co * ci)


def charlie_lambda(c, r):
    """Conty Estevez and Kulla's fit of the sheen's Lambda, blended in (1 - r)^2 between their r = 0 and r = 1 fits."""
    t = (1.0 - r) ** 2
    a, b = 21.5473 + (25.3245 - 21.5473) * t, 3.82987 + (3.32435 - 3.82987) * t
    cc, d = 0.19823 + (0.16801 - 0.19823) * t, -1.97760 + (-1.27393 + 1.97760) * t
    e = -4.32054 + (-4.85967 + 4.32054) * t

    def fit(x):
        return a / (1.0 + b * np.power(x, cc)) + d * x + e

    return np.where(c < 0.5, np.exp(fit(np.minimum(c, 0.5))), np.exp(2.0 * fit(0.5) - fit(np.maximum(1.0 - c, 1e-9))))


def charlie_dv(r, co, ci, ch):
    sin2h = np.maximum(0.0, 1.0 - ch * ch)
    d = (2.0 + 1.0 / r) * np.power(sin2h, 0.5 / r) / (2.0 * math.pi)
    return d / ((1.0 + charlie_lambda(co, r) + charlie_lambda(ci, r)) * 4.0 * co * ci)


def sheen_albedo_table(r, steps=256, quad=256):
    """E(cos_o) of the sheen lobe of colour 1 on a grid of cosines, by midpoint quadrature in (cos_i, phi)."""
    cos_grid = np.linspace(0.0, 1.0, steps + 1)
    cos_grid[0] = 1e-3
    ci = (np.arange(quad) + 0.5) / quad
    phi = (np.arange(2 * quad) + 0.5) / (2 * quad) * 2.0 * math.pi
    CI, PHI = np.meshgrid(ci, phi, indexing="ij")
    SI = np.sqrt(1.0 - CI * CI)
    table = np.empty_like(cos_grid)
    for k, co in enumerate(cos_grid):
        so = math.sqrt(max(0.0, 1.0 - co * co))
        # h = (wo + wi) / |wo + wi| with wo = (so, 0, co), wi = (SI cos phi, SI sin phi, CI)
        hx, hy, hz = so + SI * np.cos(PHI), SI * np.sin(PHI), co + CI
        ch = hz / np.sqrt(hx * hx + hy * hy + hz * hz)
        f = charlie_dv(r, np.full_like(CI, co), CI, ch)
        table[k] = np.sum(f * CI) * (1.0 / quad) * (2.0 * math.pi / (2 * quad))
    return cos_grid, table


def layered_f(co, ci, ch, oh, e_o, e_i):
    """The layered lobe (n, 3): coat on top of (sheen over the GGX base), brdf.h's rules."""
    f0 = 0.04
    spec = schlick(f0, 1.0, oh) * ggx_dv(BASE_ALPHA, co, ci, ch)
    diffuse = (1.0 - schlick(0.04, 1.0, co)) * (1.0 - schlick(0.04, 1.0, ci))
    base = spec[:, None] + diffuse[:, None] * BASE[None, :] / math.pi
    m = SHEEN.max()
    scale = np.maximum(0.0, np.minimum(1.0 - m * e_o, 1.0 - m * e_i))
    below = scale[:, None] * base + SHEEN[None, :] * charlie_dv(SHEEN_ALPHA, co, ci, ch)[:, None]
    coat = COAT * schlick(0.04, 1.0, oh) * ggx_dv(COAT_ALPHA, co, ci, ch)
    dim = (1.0 - COAT * schlick(0.04, 1.0, co)) * (1.0 - COAT * schlick(0.04, 1.0, ci))
    return coat[:, None] + dim[:, None] * below


def frame(n):
    """Two unit tangents perpendicular to each unit row of n."""
    a = np.where(np.abs(n[:, 0:1]) > 0.9, np.array([[0.0, 1.0, 0.0]]), np.array([[1.0, 0.0, 0.0]]))
    t = np.cross(n, a)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    return t, np.cross(n, t)


def trace(count, rng, cos_grid, table, bounces):
    """The mean over `count` camera paths of the radiance they bring back (3 channels)."""
    fwd = CAM_TARGET - CAM_POS
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    half = math.tan(0.5 * YFOV)
    # the image mean: a uniform point of the square image plane (every pixel's box filter together)
    sx, sy = rng.uniform(-1, 1, count) * half, rng.uniform(-1, 1, count) * half
    d = fwd[None, :] + sx[:, None] * right[None, :] + sy[:, None] * up[None, :]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.tile(CAM_POS, (count, 1))
    throughput = np.ones((count, 3))
    radiance = np.zeros((count, 3))

    def albedo(c):
        return np.interp(c, cos_grid, table)

    for _ in range(bounces):
        with np.errstate(divide="ignore"):
            t = np.where(d > 0, (1.0 - o) / d, np.where(d < 0, (-1.0 - o) / d, np.inf))
        axis = np.argmin(t, axis=1)
        tmin = t[np.arange(count), axis]
        p = o + tmin[:, None] * d
        n = np.zeros_like(d)
        n[np.arange(count), axis] = -np.sign(d[np.arange(count), axis])
        radiance += throughput * LE
        wo = -d
        co = np.clip(np.sum(wo * n, axis=1), 1e-6, 1.0)
        # cosine-weighted wi about n: f cos / pdf = pi f
        u1, u2 = rng.random(count), rng.random(count)
        rr, phi = np.sqrt(u1), 2.0 * math.pi * u2
        t1, t2 = frame(n)
        wi = (rr * np.cos(phi))[:, None] * t1 + (rr * np.sin(phi))[:, None] * t2 + np.sqrt(np.maximum(0.0, 1.0 - u1))[:, None] * n
        ci = np.clip(np.sum(wi * n, axis=1), 1e-6, 1.0)
        h = wo + wi
        h /= np.linalg.norm(h, axis=1, keepdims=True)
        ch = np.clip(np.sum(h * n, axis=1), 0.0, 1.0)
        oh = np.clip(np.sum(wo * h, axis=1), 0.0, 1.0)
        f = layered_f(co, ci, ch, oh, albedo(co), albedo(ci))
        throughput = throughput * f * math.pi
        o, d = p, wi
    return radiance.mean(axis=0), radiance.mean(axis=1)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--paths", type=int, default=600_000)
    ap.add_argument("--chunk", type=int, default=250_000)
    ap.add_argument("--bounces", type=int, default=120)
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    cos_grid, table = sheen_albedo_table(SHEEN_ALPHA)
    means, per_path = [], []
    done = 0
    while done < args.paths:
        n = min(args.chunk, args.paths - done)
        m, each = trace(n, rng, cos_grid, table, args.bounces)
        means.append(m * n)
        per_path.append((np.sum(each), np.sum(each * each), n))
        done += n
    rgb = np.sum(means, axis=0) / done
    s1 = sum(a for a, _, _ in per_path)
    s2 = sum(b for _, b, _ in per_path)
    mean = s1 / done
    stderr = math.sqrt(max(0.0, s2 / done - mean * mean) / done)
    print("# the layered furnace's image mean (R+G+B)/3 from tools/layered_furnace_reference.py "
          f"--paths {args.paths} --bounces {args.bounces} --seed {args.seed}")
    print(f"# R G B: {rgb[0]:.5f} {rgb[1]:.5f} {rgb[2]:.5f}; sheen albedo at cos 1, 0.5, 0.1: "
          f"{np.interp(1.0, cos_grid, table):.4f} {np.interp(0.5, cos_grid, table):.4f} {np.interp(0.1, cos_grid, table):.4f}")
    print(f"mean {mean:.6f} stderr {stderr:.6f}")


if __name__ == "__main__":
    main()
