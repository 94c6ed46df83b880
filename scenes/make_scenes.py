#!/usr/bin/env python3
# make_scenes.py: writes pmview's shipped glTF scenes (cornell-box.gltf, caustic.gltf, glossy-spheres.gltf, layered-spheres.gltf, dielectric-spheres.gltf, mirror-caustic.gltf, point-room.gltf, window-room.gltf, window-hollow.gltf) and exposes them as Python data.
"""Scene generator for pmview (standard library only, deterministic).

    python3 scenes/make_scenes.py            # rewrites scenes/cornell-box.gltf, caustic.gltf, glossy-spheres.gltf, layered-spheres.gltf, dielectric-spheres.gltf, mirror-caustic.gltf,
                                             # point-room.gltf, window-room.gltf, window-hollow.gltf
    python3 scenes/make_scenes.py --segments 96 --light-strength 40 --out /tmp

Each scene is a dict: {"meshes": [mesh], "camera": camera, "lights": [light]} where a mesh is
{"name", "positions" (local), "normals", "indices", "material", "translation", "scale"}, a
material is {"kind": "diffuse"|"mirror"|"glass"|"emitter"|"metal"|"dielectric"|"layered", "color", "strength", "roughness"}
("diffuse" and "emitter" are Lambert and black: they turn glTF's dielectric specular lobe off with
KHR_materials_specular specularFactor 0)
(a layered one also "metallic" and its "extensions" object, written as they are)
and a light is {"type": "point", "position", "color", "intensity" (W/sr)} or {"type": "directional",
"direction" (unit, the way the light travels), "color", "intensity" (W/m^2 across the beam)}. The glTF
writer and tools/mitsuba_reference.py both read these dicts, so the reference renders see the
very same triangles. Units are metres, +Y up, the camera looks down -Z.
"""
import argparse
import base64
import json
import math
import os
import struct

WHITE = (0.73, 0.73, 0.73)
RED = (0.63, 0.065, 0.05)
GREEN = (0.14, 0.45, 0.091)


def quad(corners, normal):
    """Two triangles of a quad given counter-clockwise as seen from its front (normal side)."""
    return {"positions": list(corners), "normals": [normal] * 4, "indices": [0, 1, 2, 0, 2, 3]}


def box(lo, hi):
    """A closed axis-aligned box from corner lo to corner hi: six quads, each facing outward."""
    geometry = {"positions": [], "normals": [], "indices": []}
    for k in range(3):
        u, v = (k + 1) % 3, (k + 2) % 3  # e_u x e_v = e_k
        for sign in (-1, 1):
            def corner(a, b):
                p = [0.0, 0.0, 0.0]
                p[k] = float(hi[k] if sign > 0 else lo[k])
                p[u] = float(hi[u] if a else lo[u])
                p[v] = float(hi[v] if b else lo[v])
                return tuple(p)
            # counter-clockwise seen from outside: u then v on the + face, v then u on the - face
            order = [(0, 0), (1, 0), (1, 1), (0, 1)] if sign > 0 else [(0, 0), (0, 1), (1, 1), (1, 0)]
            normal = [0.0, 0.0, 0.0]
            normal[k] = float(sign)
            face = quad([corner(a, b) for a, b in order], tuple(normal))
            base = len(geometry["positions"])
            geometry["positions"] += face["positions"]
            geometry["normals"] += face["normals"]
            geometry["indices"] += [base + i for i in face["indices"]]
    return geometry


def uv_sphere(segments, rings):
    """Unit sphere, outward counter-clockwise winding, smooth normals."""
    positions, indices = [], []
    for i in range(rings + 1):
        theta = math.pi * i / rings
        for j in range(segments + 1):
            phi = 2.0 * math.pi * j / segments
            positions.append((math.sin(theta) * math.cos(phi), math.cos(theta), -math.sin(theta) * math.sin(phi)))
    row = segments + 1
    for i in range(rings):
        for j in range(segments):
            a, b = i * row + j, (i + 1) * row + j
            if i != 0:
                indices += [a, b, a + 1]
            if i != rings - 1:
                indices += [a + 1, b, b + 1]
    return {"positions": positions, "normals": list(positions), "indices": indices}


def mesh(name, geometry, material, translation=(0.0, 0.0, 0.0), scale=1.0):
    m = dict(geometry)
    m.update(name=name, material=material, translation=translation, scale=scale)
    return m


def look_at_rotation(eye, target):
    """Unit quaternion (x, y, z, w) turning -Z toward target with +Y kept up."""
    f = [t - e for t, e in zip(target, eye)]
    n = math.sqrt(sum(c * c for c in f))
    f = [c / n for c in f]
    r = [-f[2], 0.0, f[0]]  # cross(f, up) with up = +Y
    rn = math.sqrt(sum(c * c for c in r))
    r = [c / rn for c in r]
    u = [r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]]
    # rotation matrix columns: right, up, back (-f)
    m = [[r[0], u[0], -f[0]], [r[1], u[1], -f[1]], [r[2], u[2], -f[2]]]
    trace = m[0][0] + m[1][1] + m[2][2]
    if trace > 0:
        s = 0.5 / math.sqrt(trace + 1.0)
        return ((m[2][1] - m[1][2]) * s, (m[0][2] - m[2][0]) * s, (m[1][0] - m[0][1]) * s, 0.25 / s)
    if m[0][0] > m[1][1] and m[0][0] > m[2][2]:
        s = 2.0 * math.sqrt(1.0 + m[0][0] - m[1][1] - m[2][2])
        return (0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s, (m[2][1] - m[1][2]) / s)
    if m[1][1] > m[2][2]:
        s = 2.0 * math.sqrt(1.0 + m[1][1] - m[0][0] - m[2][2])
        return ((m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s, (m[0][2] - m[2][0]) / s)
    s = 2.0 * math.sqrt(1.0 + m[2][2] - m[0][0] - m[1][1])
    return ((m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s, (m[1][0] - m[0][1]) / s)


def cornell_box(segments=48, light_strength=25.0, light_size=0.5):
    """The classic box, 2 m wide ([-1,1] x [0,2] x [-1,1], open at +Z), a square ceiling lamp,
    a mirror ball and a glass ball."""
    diffuse = lambda c: {"kind": "diffuse", "color": c}
    h = light_size / 2.0
    y = 1.999  # just under the ceiling, facing down
    meshes = [
        mesh("floor", quad([(-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1)], (0, 1, 0)), diffuse(WHITE)),
        mesh("ceiling", quad([(-1, 2, -1), (1, 2, -1), (1, 2, 1), (-1, 2, 1)], (0, -1, 0)), diffuse(WHITE)),
        mesh("back", quad([(-1, 0, -1), (1, 0, -1), (1, 2, -1), (-1, 2, -1)], (0, 0, 1)), diffuse(WHITE)),
        mesh("left", quad([(-1, 0, 1), (-1, 0, -1), (-1, 2, -1), (-1, 2, 1)], (1, 0, 0)), diffuse(RED)),
        mesh("right", quad([(1, 0, -1), (1, 0, 1), (1, 2, 1), (1, 2, -1)], (-1, 0, 0)), diffuse(GREEN)),
        mesh("lamp", quad([(-h, y, -h), (h, y, -h), (h, y, h), (-h, y, h)], (0, -1, 0)),
             {"kind": "emitter", "color": (1.0, 0.85, 0.6), "strength": light_strength}),
        mesh("mirror_ball", uv_sphere(segments, segments // 2), {"kind": "mirror", "color": (0.9, 0.9, 0.9)},
             translation=(-0.45, 0.35, -0.35), scale=0.35),
        mesh("glass_ball", uv_sphere(segments, segments // 2), {"kind": "glass", "color": (1.0, 1.0, 1.0), "ior": 1.5},
             translation=(0.45, 0.35, 0.25), scale=0.35),
    ]
    eye, target = (0.0, 1.0, 3.9), (0.0, 1.0, 0.0)
    camera = {"eye": eye, "target": target, "yfov": math.radians(39.3), "aspect": 1.0}
    return {"meshes": meshes, "camera": camera, "lights": []}


def caustic(segments=64, intensity=50.0):
    """A point light above and behind a glass ball on a large white floor, placed so that the
    ball focuses its light onto floor the camera can see, beside the ball rather than under it."""
    meshes = [
        mesh("floor", quad([(-3, 0, 3), (3, 0, 3), (3, 0, -3), (-3, 0, -3)], (0, 1, 0)), {"kind": "diffuse", "color": (0.8, 0.8, 0.8)}),
        mesh("glass_ball", uv_sphere(segments, segments // 2), {"kind": "glass", "color": (1.0, 1.0, 1.0), "ior": 1.5},
             translation=(0.0, 0.35, 0.0), scale=0.3),
    ]
    camera = {"eye": (0.0, 2.0, 2.2), "target": (0.0, 0.1, 0.0), "yfov": math.radians(40.0), "aspect": 1.0}
    lights = [{"type": "point", "position": (-1.2, 1.6, -0.6), "color": (1.0, 1.0, 1.0), "intensity": intensity}]
    return {"meshes": meshes, "camera": camera, "lights": lights}


def glossy_spheres(segments=48, light_strength=12.0):
    """Two rough white metal spheres (roughness 0.3 and 0.7: GGX alpha 0.09 and 0.49) on a tinted
    diffuse floor under a square lamp. White metal has Schlick F = 1 at every angle, the same as
    an ideal conductor, so an independent renderer's rough conductor sees the same material."""
    h = 0.5
    meshes = [
        mesh("floor", quad([(-3, 0, 3), (3, 0, 3), (3, 0, -3), (-3, 0, -3)], (0, 1, 0)),
             {"kind": "diffuse", "color": (0.7, 0.6, 0.5)}),
        mesh("smooth_metal", uv_sphere(segments, segments // 2), {"kind": "metal", "color": (1.0, 1.0, 1.0), "roughness": 0.3},
             translation=(-0.6, 0.5, 0.0), scale=0.5),
        mesh("rough_metal", uv_sphere(segments, segments // 2), {"kind": "metal", "color": (1.0, 1.0, 1.0), "roughness": 0.7},
             translation=(0.6, 0.5, 0.0), scale=0.5),
        mesh("lamp", quad([(-h, 2.5, -h - 0.5), (h, 2.5, -h - 0.5), (h, 2.5, h - 0.5), (-h, 2.5, h - 0.5)], (0, -1, 0)),
             {"kind": "emitter", "color": (1.0, 0.95, 0.9), "strength": light_strength}),
    ]
    camera = {"eye": (0.0, 1.3, 3.2), "target": (0.0, 0.45, 0.0), "yfov": math.radians(40.0), "aspect": 1.0}
    return {"meshes": meshes, "camera": camera, "lights": []}


def layered_spheres(segments=48, light_strength=12.0):
    """The layer extensions on three spheres on a grey floor under a square lamp: red paint under a
    smooth clearcoat (KHR_materials_clearcoat), blue velvet with a warm sheen (KHR_materials_sheen),
    and a half-metal whose dielectric share reflects a tinted, stronger F0 (KHR_materials_specular)."""
    h = 0.5
    meshes = [
        mesh("floor", quad([(-3, 0, 3), (3, 0, 3), (3, 0, -3), (-3, 0, -3)], (0, 1, 0)),
             {"kind": "diffuse", "color": (0.5, 0.5, 0.5)}),
        mesh("clearcoat_paint", uv_sphere(segments, segments // 2),
             {"kind": "layered", "color": (0.6, 0.05, 0.05), "metallic": 0.0, "roughness": 0.6,
              "extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.05}}},
             translation=(-1.1, 0.5, 0.0), scale=0.5),
        mesh("sheen_velvet", uv_sphere(segments, segments // 2),
             {"kind": "layered", "color": (0.05, 0.08, 0.4), "metallic": 0.0, "roughness": 1.0,
              "extensions": {"KHR_materials_sheen": {"sheenColorFactor": [1.0, 0.8, 0.6], "sheenRoughnessFactor": 0.4}}},
             translation=(0.0, 0.5, 0.0), scale=0.5),
        mesh("specular_tint", uv_sphere(segments, segments // 2),
             {"kind": "layered", "color": (0.8, 0.8, 0.8), "metallic": 0.5, "roughness": 0.35,
              "extensions": {"KHR_materials_specular": {"specularFactor": 1.0, "specularColorFactor": [4.0, 2.0, 1.0]}}},
             translation=(1.1, 0.5, 0.0), scale=0.5),
        mesh("lamp", quad([(-h, 2.5, -h - 0.5), (h, 2.5, -h - 0.5), (h, 2.5, h - 0.5), (-h, 2.5, h - 0.5)], (0, -1, 0)),
             {"kind": "emitter", "color": (1.0, 0.95, 0.9), "strength": light_strength}),
    ]
    camera = {"eye": (0.0, 1.3, 3.6), "target": (0.0, 0.45, 0.0), "yfov": math.radians(40.0), "aspect": 1.0}
    return {"meshes": meshes, "camera": camera, "lights": []}


def dielectric_spheres(segments=48, light_strength=12.0):
    """glTF's plain dielectric (metallic 0, no extension: a diffuse base under a GGX lobe of F0
    0.04) on three spheres of roughness 0.05, 0.3 and 0.6 (black, red, white) before a grey back
    wall, on a grey floor under a square lamp: glossy reflections of the lamp, the floor and each
    other, which photons and paths must both carry."""
    h = 0.5
    meshes = [
        mesh("floor", quad([(-3, 0, 3), (3, 0, 3), (3, 0, -3), (-3, 0, -3)], (0, 1, 0)),
             {"kind": "diffuse", "color": (0.5, 0.5, 0.5)}),
        mesh("back", quad([(-3, 0, -1.5), (3, 0, -1.5), (3, 3, -1.5), (-3, 3, -1.5)], (0, 0, 1)),
             {"kind": "diffuse", "color": (0.6, 0.6, 0.6)}),
        mesh("black_plastic", uv_sphere(segments, segments // 2), {"kind": "dielectric", "color": (0.02, 0.02, 0.02), "roughness": 0.05},
             translation=(-1.1, 0.5, 0.0), scale=0.5),
        mesh("red_plastic", uv_sphere(segments, segments // 2), {"kind": "dielectric", "color": (0.6, 0.08, 0.05), "roughness": 0.3},
             translation=(0.0, 0.5, 0.0), scale=0.5),
        mesh("white_ceramic", uv_sphere(segments, segments // 2), {"kind": "dielectric", "color": (0.8, 0.8, 0.8), "roughness": 0.6},
             translation=(1.1, 0.5, 0.0), scale=0.5),
        mesh("lamp", quad([(-h, 2.5, -h - 0.5), (h, 2.5, -h - 0.5), (h, 2.5, h - 0.5), (-h, 2.5, h - 0.5)], (0, -1, 0)),
             {"kind": "emitter", "color": (1.0, 0.95, 0.9), "strength": light_strength}),
    ]
    camera = {"eye": (0.0, 1.3, 3.6), "target": (0.0, 0.45, 0.0), "yfov": math.radians(40.0), "aspect": 1.0}
    return {"meshes": meshes, "camera": camera, "lights": []}


def mirror_caustic(segments=64, light_strength=50.0, light_radius=0.2):
    """A glass ball's caustic seen directly and in a mirror wall, lit by a small emissive sphere:
    the path eye -> mirror -> floor -> glass -> glass -> lamp is hard for a path tracer (only a
    direction sampled at the floor can find the lamp through the ball, and it rarely does), easy
    for photons. The lamp is an area light so that an independent path tracer can converge it."""
    meshes = [
        mesh("floor", quad([(-3, 0, 3), (3, 0, 3), (3, 0, -3), (-3, 0, -3)], (0, 1, 0)), {"kind": "diffuse", "color": (0.8, 0.8, 0.8)}),
        mesh("mirror", quad([(-1.6, 0, -1.2), (1.6, 0, -1.2), (1.6, 1.6, -1.2), (-1.6, 1.6, -1.2)], (0, 0, 1)),
             {"kind": "mirror", "color": (0.9, 0.9, 0.9)}),
        mesh("glass_ball", uv_sphere(segments, segments // 2), {"kind": "glass", "color": (1.0, 1.0, 1.0), "ior": 1.5},
             translation=(0.0, 0.35, 0.0), scale=0.3),
        mesh("lamp", uv_sphere(16, 8), {"kind": "emitter", "color": (1.0, 0.9, 0.75), "strength": light_strength},
             translation=(1.0, 1.1, -0.7), scale=light_radius),
    ]
    camera = {"eye": (0.3, 1.4, 2.6), "target": (-0.1, 0.3, -0.6), "yfov": math.radians(40.0), "aspect": 1.0}
    return {"meshes": meshes, "camera": camera, "lights": []}


def point_room(segments=48):
    """A closed room lit only by a point light near the ceiling, with a rough metal ball (roughness
    0.4) and a diffuse ball: a path tracer's best case (its next-event estimate of a point light
    has no sampling noise), the room where photon mapping must still keep up."""
    diffuse = lambda c: {"kind": "diffuse", "color": c}
    meshes = [
        mesh("floor", quad([(-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1)], (0, 1, 0)), diffuse((0.75, 0.75, 0.7))),
        mesh("ceiling", quad([(-1, 2, -1), (1, 2, -1), (1, 2, 1), (-1, 2, 1)], (0, -1, 0)), diffuse((0.8, 0.8, 0.8))),
        mesh("back", quad([(-1, 0, -1), (1, 0, -1), (1, 2, -1), (-1, 2, -1)], (0, 0, 1)), diffuse((0.6, 0.65, 0.8))),
        mesh("left", quad([(-1, 0, 1), (-1, 0, -1), (-1, 2, -1), (-1, 2, 1)], (1, 0, 0)), diffuse((0.7, 0.3, 0.2))),
        mesh("right", quad([(1, 0, -1), (1, 0, 1), (1, 2, 1), (1, 2, -1)], (-1, 0, 0)), diffuse((0.3, 0.6, 0.3))),
        mesh("front", quad([(1, 0, 1), (-1, 0, 1), (-1, 2, 1), (1, 2, 1)], (0, 0, -1)), diffuse((0.7, 0.7, 0.7))),
        mesh("metal_ball", uv_sphere(segments, segments // 2), {"kind": "metal", "color": (1, 1, 1), "roughness": 0.4},
             translation=(-0.4, 0.4, -0.3), scale=0.4),
        mesh("white_ball", uv_sphere(segments, segments // 2), diffuse((0.85, 0.85, 0.85)),
             translation=(0.5, 0.3, 0.3), scale=0.3),
    ]
    camera = {"eye": (0.0, 1.0, 0.95), "target": (0.0, 0.8, -1.0), "yfov": math.radians(70.0), "aspect": 1.0}
    lights = [{"type": "point", "position": (0.4, 1.6, -0.5), "color": (1.0, 0.9, 0.8), "intensity": 2.0}]
    return {"meshes": meshes, "camera": camera, "lights": lights}


def window_room(sun_elevation=40.0, sun_azimuth=20.0, sun_irradiance=5.0):
    """A room 4 m x 2.6 m x 4 m inside (x, z in [-2, 2], floor top y = 0) with solid walls, floor and
    ceiling slabs (closed boxes 15 cm thick, outside faces included), one unglazed window 1.4 m x
    1.2 m (sill at 0.8 m) in the +z wall, standing on a large blue-grey ground 2 cm below the floor
    top that continues under the room. The sun (a directional light, sun_elevation degrees above
    the horizon, its travel turned sun_azimuth degrees from -z toward +x) shines in through the
    window onto the floor the camera sees; the sky is not in the file (pmview --sky white, radiance 1).
    The boxes meet face to face without overlapping (walls stand on the floor slab, the ceiling slab
    rests on them, the side walls end against the back and window walls); the ground plane passes
    through the floor slab's inside."""
    diffuse = lambda c: {"kind": "diffuse", "color": c}
    wall, floor = diffuse((0.7, 0.7, 0.7)), diffuse((0.6, 0.45, 0.3))
    t, w, h = 0.15, 2.0, 2.6  # thickness, interior half width (x and z), interior height
    wx, sill, top = 0.7, 0.8, 2.0  # window half width, sill and head heights
    meshes = [
        mesh("ground", quad([(-60, -0.02, 60), (60, -0.02, 60), (60, -0.02, -60), (-60, -0.02, -60)], (0, 1, 0)),
             diffuse((0.30, 0.35, 0.55))),
        mesh("floor_slab", box((-w - t, -t, -w - t), (w + t, 0.0, w + t)), floor),
        mesh("ceiling_slab", box((-w - t, h, -w - t), (w + t, h + t, w + t)), wall),
        mesh("back_wall", box((-w - t, 0.0, -w - t), (w + t, h, -w)), wall),
        mesh("left_wall", box((-w - t, 0.0, -w), (-w, h, w)), wall),
        mesh("right_wall", box((w, 0.0, -w), (w + t, h, w)), wall),
        # the +z wall, around the window opening
        mesh("window_wall_left", box((-w - t, 0.0, w), (-wx, h, w + t)), wall),
        mesh("window_wall_right", box((wx, 0.0, w), (w + t, h, w + t)), wall),
        mesh("window_wall_below", box((-wx, 0.0, w), (wx, sill, w + t)), wall),
        mesh("window_wall_above", box((-wx, top, w), (wx, h, w + t)), wall),
    ]
    el, az = math.radians(sun_elevation), math.radians(sun_azimuth)
    sun = (math.cos(el) * math.sin(az), -math.sin(el), -math.cos(el) * math.cos(az))
    camera = {"eye": (1.4, 1.5, -1.6), "target": (0.2, 0.1, 1.2), "yfov": math.radians(70.0), "aspect": 1.0}
    lights = [{"type": "directional", "direction": sun, "color": (1.0, 1.0, 1.0), "intensity": sun_irradiance}]
    return {"meshes": meshes, "camera": camera, "lights": lights}


def rect(k, at, u_range, v_range, sign):
    """One single-sided axis-aligned rectangle in the plane where axis k is `at`, facing +k (sign 1)
    or -k (sign -1); u_range and v_range span axes (k+1)%3 and (k+2)%3, as box() orders them."""
    u, v = (k + 1) % 3, (k + 2) % 3

    def corner(a, b):
        p = [0.0, 0.0, 0.0]
        p[k], p[u], p[v] = float(at), float(u_range[a]), float(v_range[b])
        return tuple(p)
    order = [(0, 0), (1, 0), (1, 1), (0, 1)] if sign > 0 else [(0, 0), (0, 1), (1, 1), (1, 0)]
    normal = [0.0, 0.0, 0.0]
    normal[k] = float(sign)
    return quad([corner(a, b) for a, b in order], tuple(normal))


def panels(*rects):
    """Several rectangles as one mesh."""
    geometry = {"positions": [], "normals": [], "indices": []}
    for r in rects:
        base = len(geometry["positions"])
        geometry["positions"] += r["positions"]
        geometry["normals"] += r["normals"]
        geometry["indices"] += [base + i for i in r["indices"]]
    return geometry


def window_room_hollow(sun_elevation=40.0, sun_azimuth=20.0, sun_irradiance=8.0):
    """The window room as many architectural exports write it: every wall, the floor and the ceiling
    are single-sided rectangles (doubleSided false), inner faces facing into the room, outer faces
    facing out, a hollow 15 cm between them that the window's reveals close; the outer walls stand
    on a ground plane 60 m wide 2 cm below the floor, which runs on under the room (a crawl space
    2 cm high). The room is 4 m x 2.6 m x 4 m inside with one unglazed window 1.4 m x 1.2 m (sill at
    0.8 m) in the +z wall; the sun (directional, sun_irradiance W/m^2) shines through it onto the
    floor the camera sees; the sky is not in the file (pmview --sky white, radiance 1)."""
    diffuse = lambda c: {"kind": "diffuse", "color": c}
    wall, floor = diffuse((0.7, 0.7, 0.7)), diffuse((0.6, 0.45, 0.3))
    t, w, h, g = 0.15, 2.0, 2.6, -0.02  # hollow, interior half width (x and z), interior height, ground
    wx, sill, top = 0.7, 0.8, 2.0  # window half width, sill and head heights
    o = w + t  # the outer faces' half width
    X, Y, Z = 0, 1, 2  # rect(k, ...) spans (u, v) = (y, z) for X, (z, x) for Y, (x, y) for Z
    inner = panels(
        rect(X, -w, (0.0, h), (-w, w), 1), rect(X, w, (0.0, h), (-w, w), -1),  # left, right
        rect(Z, -w, (-w, w), (0.0, h), 1),  # back
        rect(Z, w, (-w, -wx), (0.0, h), -1), rect(Z, w, (wx, w), (0.0, h), -1),  # window wall beside the opening
        rect(Z, w, (-wx, wx), (0.0, sill), -1), rect(Z, w, (-wx, wx), (top, h), -1))  # below and above it
    outer = panels(
        rect(X, -o, (g, h + t), (-o, o), -1), rect(X, o, (g, h + t), (-o, o), 1),
        rect(Z, -o, (-o, o), (g, h + t), -1),
        rect(Z, o, (-o, -wx), (g, h + t), 1), rect(Z, o, (wx, o), (g, h + t), 1),
        rect(Z, o, (-wx, wx), (g, sill), 1), rect(Z, o, (-wx, wx), (top, h + t), 1))
    reveals = panels(
        rect(Y, sill, (w, o), (-wx, wx), 1), rect(Y, top, (w, o), (-wx, wx), -1),  # sill, head
        rect(X, -wx, (sill, top), (w, o), 1), rect(X, wx, (sill, top), (w, o), -1))  # jambs
    meshes = [
        mesh("ground", rect(Y, g, (-30.0, 30.0), (-30.0, 30.0), 1), diffuse((0.30, 0.35, 0.55))),
        mesh("floor", rect(Y, 0.0, (-w, w), (-w, w), 1), floor),
        mesh("ceiling", rect(Y, h, (-w, w), (-w, w), -1), wall),
        mesh("roof", rect(Y, h + t, (-o, o), (-o, o), 1), wall),
        mesh("inner_walls", inner, wall),
        mesh("outer_walls", outer, wall),
        mesh("window_reveals", reveals, wall),
    ]
    el, az = math.radians(sun_elevation), math.radians(sun_azimuth)
    sun = (math.cos(el) * math.sin(az), -math.sin(el), -math.cos(el) * math.cos(az))
    camera = {"eye": (1.4, 1.5, -1.6), "target": (0.2, 0.1, 1.2), "yfov": math.radians(70.0), "aspect": 1.0}
    lights = [{"type": "directional", "direction": sun, "color": (1.0, 1.0, 1.0), "intensity": sun_irradiance}]
    return {"meshes": meshes, "camera": camera, "lights": lights}


def gltf_material(m):
    out = {"name": m["kind"], "pbrMetallicRoughness": {"baseColorFactor": list(m.get("color", (1, 1, 1))) + [1.0]}}
    pbr = out["pbrMetallicRoughness"]
    if m["kind"] == "diffuse":
        # Lambert: glTF gives every dielectric a specular lobe; specularFactor 0 turns it off
        pbr.update(metallicFactor=0.0, roughnessFactor=1.0)
        out["extensions"] = {"KHR_materials_specular": {"specularFactor": 0.0}}
    elif m["kind"] == "mirror":
        pbr.update(metallicFactor=1.0, roughnessFactor=0.0)
    elif m["kind"] == "metal":
        pbr.update(metallicFactor=1.0, roughnessFactor=m["roughness"])
    elif m["kind"] == "dielectric":
        # glTF's plain dielectric: the diffuse base under a GGX specular lobe of F0 0.04
        pbr.update(metallicFactor=0.0, roughnessFactor=m["roughness"])
    elif m["kind"] == "glass":
        pbr.update(metallicFactor=0.0, roughnessFactor=0.0)
        # solid glass: without KHR_materials_volume, transmission is a thin wall that bends nothing.
        # thicknessFactor > 0 is what says so; its value is for rasterizers (a ray tracer measures
        # the path inside), and no attenuationDistance leaves the glass clear
        out["extensions"] = {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                             "KHR_materials_ior": {"ior": m.get("ior", 1.5)},
                             "KHR_materials_volume": {"thicknessFactor": 1.0}}
    elif m["kind"] == "layered":
        pbr.update(metallicFactor=m["metallic"], roughnessFactor=m["roughness"])
        out["extensions"] = m["extensions"]
    elif m["kind"] == "emitter":
        pbr.update(baseColorFactor=[0.0, 0.0, 0.0, 1.0], metallicFactor=0.0, roughnessFactor=1.0)
        out["emissiveFactor"] = list(m["color"])
        # a black lamp that reflects nothing, as the references' emitters on a black diffuse BSDF
        out["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": m["strength"]},
                             "KHR_materials_specular": {"specularFactor": 0.0}}
    return out


def to_gltf(scene):
    """A single-file glTF 2.0 document (buffer embedded as base64)."""
    blob = bytearray()
    views, accessors, meshes, nodes, materials = [], [], [], [], []

    def add_view(data, target):
        while len(blob) % 4:
            blob.append(0)
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data), "target": target})
        blob.extend(data)
        return len(views) - 1

    geometry_cache = {}
    for m in scene["meshes"]:
        key = id(m["positions"])
        if key not in geometry_cache:
            pos = m["positions"]
            pv = add_view(struct.pack("<%df" % (3 * len(pos)), *[c for p in pos for c in p]), 34962)
            lo = [min(p[i] for p in pos) for i in range(3)]
            hi = [max(p[i] for p in pos) for i in range(3)]
            accessors.append({"bufferView": pv, "componentType": 5126, "count": len(pos), "type": "VEC3", "min": lo, "max": hi})
            pa = len(accessors) - 1
            nrm = m["normals"]
            nv = add_view(struct.pack("<%df" % (3 * len(nrm)), *[c for n in nrm for c in n]), 34962)
            accessors.append({"bufferView": nv, "componentType": 5126, "count": len(nrm), "type": "VEC3"})
            na = len(accessors) - 1
            idx = m["indices"]
            wide = max(idx) > 65535
            iv = add_view(struct.pack("<%d%s" % (len(idx), "I" if wide else "H"), *idx), 34963)
            accessors.append({"bufferView": iv, "componentType": 5125 if wide else 5123, "count": len(idx), "type": "SCALAR"})
            geometry_cache[key] = (pa, na, len(accessors) - 1)
        pa, na, ia = geometry_cache[key]
        materials.append(gltf_material(m["material"]))
        meshes.append({"name": m["name"], "primitives": [{"attributes": {"POSITION": pa, "NORMAL": na}, "indices": ia,
                                                         "material": len(materials) - 1}]})
        node = {"name": m["name"], "mesh": len(meshes) - 1}
        if m["translation"] != (0.0, 0.0, 0.0):
            node["translation"] = list(m["translation"])
        if m["scale"] != 1.0:
            node["scale"] = [m["scale"]] * 3
        nodes.append(node)

    cam = scene["camera"]
    nodes.append({"name": "camera", "camera": 0, "translation": list(cam["eye"]),
                  "rotation": list(look_at_rotation(cam["eye"], cam["target"]))})
    extensions_used = sorted({e for mat in materials for e in mat.get("extensions", {})})
    doc = {
        "asset": {"version": "2.0", "generator": "pmview scenes/make_scenes.py"},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "cameras": [{"type": "perspective", "perspective": {"yfov": cam["yfov"], "aspectRatio": cam["aspect"], "znear": 0.01}}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode()}],
    }
    if scene["lights"]:
        doc["extensions"] = {"KHR_lights_punctual": {"lights": [
            {"type": l["type"], "color": list(l["color"]), "intensity": l["intensity"]} for l in scene["lights"]]}}
        for i, l in enumerate(scene["lights"]):
            node = {"name": "light%d" % i}
            if "position" in l:
                node["translation"] = list(l["position"])
            if "direction" in l:
                # the node's rotation turns the light's local -Z into the direction it travels
                node["rotation"] = list(look_at_rotation((0.0, 0.0, 0.0), l["direction"]))
            node["extensions"] = {"KHR_lights_punctual": {"light": i}}
            doc["nodes"].append(node)
            doc["scenes"][0]["nodes"].append(len(doc["nodes"]) - 1)
        extensions_used.append("KHR_lights_punctual")
    if extensions_used:
        doc["extensionsUsed"] = sorted(set(extensions_used))
    return doc


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.dirname(os.path.abspath(__file__)))
    ap.add_argument("--segments", type=int, default=48, help="sphere segments around (rings = half)")
    ap.add_argument("--light-strength", type=float, default=25.0, help="Cornell lamp emissive strength")
    ap.add_argument("--point-intensity", type=float, default=50.0, help="caustic scene point light, W/sr")
    args = ap.parse_args()
    for name, scene in (("cornell-box.gltf", cornell_box(args.segments, args.light_strength)),
                        ("caustic.gltf", caustic(max(args.segments, 64), args.point_intensity)),
                        ("glossy-spheres.gltf", glossy_spheres(args.segments)),
                        ("layered-spheres.gltf", layered_spheres(args.segments)),
                        ("dielectric-spheres.gltf", dielectric_spheres(args.segments)),
                        ("mirror-caustic.gltf", mirror_caustic(max(args.segments, 64))),
                        ("point-room.gltf", point_room(args.segments)),
                        ("window-room.gltf", window_room()),
                        ("window-hollow.gltf", window_room_hollow())):
        path = os.path.join(args.out, name)
        with open(path, "w") as f:
            json.dump(to_gltf(scene), f, separators=(",", ":"))
            f.write("\n")
        print("wrote", path)


if __name__ == "__main__":
    main()
