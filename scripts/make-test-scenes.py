#!/usr/bin/env python3
"""Writes tests/scenes/*.gltf: scenes modelled the way third-party files
model them, for the tests of emissive fixtures, the default light and the
default camera (tests/third_party_scenes.rs, docs/accuracy.md). Run from the
repository root; standard library only. `--independent DIR` writes instead
the scenes of the check against an independent renderer (a helmet-like
shell, a bottle, a shader ball, normal maps turned towards image-up,
alpha-masked leaves under a sun, a spot light, a textured studio; scripts/mitsuba-reference.py; needs numpy and Pillow).

  fixture-thin-box    Cornell box lit only by a thin closed box under the
                      ceiling: glTF default white material (albedo 1),
                      doubleSided, emissive on every face.
  fixture-quad-gap    ... by a doubleSided emissive quad 1 cm under the ceiling.
  fixture-quad-flush  ... by a one-sided quad 1 mm under it (KHR_materials_
                      emissive_strength), facing down.
  closed-room         a closed room (all six walls) with spheres and boxes,
                      lit by a point light.
  glowing-label       a bottle whose only emission is an emissive texture that
                      is black except for a label band; no lights, no camera.
  emissive-floor      a 40 m emissive plane; no lights, no camera.
  slabs-*             rooms whose walls are closed slabs, lit only by a thin
                      closed emissive slab under the ceiling (issue 34): an
                      open-front box without camera and a closed room with
                      one, with fixtures 1 mm to 10 cm thick, touching the
                      ceiling or 1 cm under it, one- and double-sided walls.
  thin-*              visibility through thin walls (issue 61): an open-front
                      box of closed slabs 1 mm to 20 cm thick (albedo 1 white,
                      saturated red and green, one- or double-sided) lit by a
                      thin closed fixture under the ceiling, seen from outside
                      and from inside; two open-top rooms sharing one slab
                      wall, a point light in one of them (or a dimmer one in
                      the other too), seen from above.
"""
import base64, json, math, os, struct, sys, zlib

OUT_DIR = os.environ.get("SCENES_OUT", "tests/scenes")

def cross(a, b): return [a[1]*b[2]-a[2]*b[1], a[2]*b[0]-a[0]*b[2], a[0]*b[1]-a[1]*b[0]]
def dot(a, b): return sum(x * y for x, y in zip(a, b))
def add(a, b): return [x + y for x, y in zip(a, b)]
def scale(a, s): return [x * s for x in a]

def quad(corner, u, v):
    """Four vertices; the front (normal u x v) is where glTF's CCW winding faces."""
    n = cross(u, v); l = math.sqrt(dot(n, n)); n = [c / l for c in n]
    p = [corner, add(corner, u), add(add(corner, u), v), add(corner, v)]
    return {"pos": p, "nrm": [n] * 4, "uv": [[0, 0], [1, 0], [1, 1], [0, 1]], "idx": [0, 1, 2, 0, 2, 3]}

def merge(parts):
    out = {"pos": [], "nrm": [], "uv": [], "idx": []}
    for p in parts:
        base = len(out["pos"])
        for k in ("pos", "nrm", "uv"):
            out[k] += p[k]
        out["idx"] += [i + base for i in p["idx"]]
    return out

def box(lo, hi, angle=0.0, inward=False):
    """An axis-aligned box (turned by `angle` about Y through its centre), faces outward."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    sx, sy, sz = x1 - x0, y1 - y0, z1 - z0
    faces = [([x0, y0, z1], [sx, 0, 0], [0, sy, 0]),    # +z
             ([x1, y0, z0], [-sx, 0, 0], [0, sy, 0]),   # -z
             ([x1, y0, z1], [0, 0, -sz], [0, sy, 0]),   # +x
             ([x0, y0, z0], [0, 0, sz], [0, sy, 0]),    # -x
             ([x0, y1, z1], [sx, 0, 0], [0, 0, -sz]),   # +y
             ([x0, y0, z0], [sx, 0, 0], [0, 0, sz])]    # -y
    parts = [quad(c, v, u) if inward else quad(c, u, v) for c, u, v in faces]
    m = merge(parts)
    cx, cz = (x0 + x1) / 2, (z0 + z1) / 2
    co, si = math.cos(angle), math.sin(angle)
    rot = lambda p: [cx + co * (p[0] - cx) + si * (p[2] - cz), p[1], cz - si * (p[0] - cx) + co * (p[2] - cz)]
    m["pos"] = [rot(p) for p in m["pos"]]
    m["nrm"] = [[co * n[0] + si * n[2], n[1], -si * n[0] + co * n[2]] for n in m["nrm"]]
    return m

def sphere(c, r, nu=32, nv=16):
    pos, nrm, uv, idx = [], [], [], []
    for j in range(nv + 1):
        t = math.pi * j / nv
        for i in range(nu + 1):
            f = 2 * math.pi * i / nu
            n = [math.sin(t) * math.cos(f), math.cos(t), math.sin(t) * math.sin(f)]
            pos.append(add(c, scale(n, r))); nrm.append(n); uv.append([i / nu, j / nv])
    for j in range(nv):
        for i in range(nu):
            a, b = j * (nu + 1) + i, (j + 1) * (nu + 1) + i
            idx += [a, a + 1, b + 1, a, b + 1, b]
    return {"pos": pos, "nrm": nrm, "uv": uv, "idx": idx}

def cylinder(c, r, h, nu=32):
    """Side (u around, v up) and two caps, outward."""
    pos, nrm, uv, idx = [], [], [], []
    for j in range(2):
        for i in range(nu + 1):
            f = 2 * math.pi * i / nu
            n = [math.cos(f), 0, math.sin(f)]
            pos.append(add(c, [r * n[0], h * j, r * n[2]])); nrm.append(n); uv.append([i / nu, 1 - j])
    for i in range(nu):
        a, b = i, nu + 1 + i
        idx += [a, b, b + 1, a, b + 1, a + 1]
    for y, ny in ((0, -1), (h, 1)):
        base = len(pos)
        pos.append(add(c, [0, y, 0])); nrm.append([0, ny, 0]); uv.append([0.5, 0.0])
        for i in range(nu + 1):
            f = 2 * math.pi * i / nu
            pos.append(add(c, [r * math.cos(f), y, r * math.sin(f)])); nrm.append([0, ny, 0]); uv.append([0.5, 0.0])
        for i in range(nu):
            idx += [base, base + 2 + i, base + 1 + i] if ny > 0 else [base, base + 1 + i, base + 2 + i]
    return {"pos": pos, "nrm": nrm, "uv": uv, "idx": idx}

def cornell_walls():
    """The built-in Cornell box (src/scene/builtin.rs) without a front wall."""
    return {
        "white": merge([quad([-1, 0, 1], [2, 0, 0], [0, 0, -2]),     # floor
                        quad([-1, 2, -1], [2, 0, 0], [0, 0, 2]),     # ceiling
                        quad([-1, 0, -1], [2, 0, 0], [0, 2, 0]),     # back
                        box([0.03, 0, 0.07], [0.63, 0.6, 0.67], -0.29),
                        box([-0.65, 0, -0.6], [-0.05, 1.2, 0.0], 0.29)]),
        "red": quad([-1, 0, 1], [0, 0, -2], [0, 2, 0]),
        "green": quad([1, 0, -1], [0, 0, 2], [0, 2, 0]),
    }

WALLS = {"white": {"pbrMetallicRoughness": {"baseColorFactor": [0.73, 0.73, 0.73, 1], "metallicFactor": 0}},
         "red": {"pbrMetallicRoughness": {"baseColorFactor": [0.63, 0.065, 0.05, 1], "metallicFactor": 0}},
         "green": {"pbrMetallicRoughness": {"baseColorFactor": [0.14, 0.45, 0.091, 1], "metallicFactor": 0}}}
CORNELL_CAMERA = {"translation": [0, 1, 3.9], "yfov": math.radians(40)}

def png(width, height, rgb):
    raw = b"".join(b"\0" + bytes(c for x in range(width) for c in rgb(x, y)) for y in range(height))
    chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))

def write(name, meshes, materials, lights=(), camera=None, images=(), doc=""):
    """meshes: [(material name, geometry)]; materials: name -> glTF material."""
    blob, views, accessors = b"", [], []
    def view(data, target):
        nonlocal blob
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data), "target": target})
        blob += data + b"\0" * (-len(data) % 4)
        return len(views) - 1
    names = list(materials)
    gmeshes, nodes = [], []
    for mat, g in meshes:
        vp = view(b"".join(struct.pack("<3f", *p) for p in g["pos"]), 34962)
        vn = view(b"".join(struct.pack("<3f", *n) for n in g["nrm"]), 34962)
        vt = view(b"".join(struct.pack("<2f", *t) for t in g["uv"]), 34962)
        vi = view(struct.pack(f"<{len(g['idx'])}I", *g["idx"]), 34963)
        lo = [min(p[k] for p in g["pos"]) for k in range(3)]; hi = [max(p[k] for p in g["pos"]) for k in range(3)]
        a = len(accessors)
        accessors += [{"bufferView": vp, "componentType": 5126, "count": len(g["pos"]), "type": "VEC3", "min": lo, "max": hi},
                      {"bufferView": vn, "componentType": 5126, "count": len(g["nrm"]), "type": "VEC3"},
                      {"bufferView": vt, "componentType": 5126, "count": len(g["uv"]), "type": "VEC2"},
                      {"bufferView": vi, "componentType": 5125, "count": len(g["idx"]), "type": "SCALAR"}]
        gmeshes.append({"name": mat, "primitives": [{"attributes": {"POSITION": a, "NORMAL": a + 1, "TEXCOORD_0": a + 2},
                                                     "indices": a + 3, "material": names.index(mat)}]})
        nodes.append({"mesh": len(gmeshes) - 1, "name": mat})
    gltf = {"asset": {"version": "2.0", "generator": "scripts/make-test-scenes.py", "extras": {"description": doc}},
            "scene": 0, "meshes": gmeshes, "accessors": accessors, "bufferViews": views,
            "materials": [dict(materials[n], name=n) for n in names]}
    used = set()
    if any("KHR_materials_emissive_strength" in m.get("extensions", {}) for m in materials.values()):
        used.add("KHR_materials_emissive_strength")
    if lights:
        used.add("KHR_lights_punctual")
        gltf["extensions"] = {"KHR_lights_punctual": {"lights": [l[0] for l in lights]}}
        # (light, translation) or (light, translation, rotation quaternion)
        nodes += [dict({"name": "light", "translation": l[1], "extensions": {"KHR_lights_punctual": {"light": i}}},
                       **({"rotation": l[2]} if len(l) > 2 else {}))
                  for i, l in enumerate(lights)]
    if camera:
        gltf["cameras"] = [{"type": "perspective", "perspective": {"yfov": camera["yfov"], "znear": 0.01, "aspectRatio": 4 / 3}}]
        nodes.append(dict({"name": "camera", "translation": camera["translation"], "camera": 0},
                          **({"rotation": camera["rotation"]} if "rotation" in camera else {})))
    if images:
        gltf["images"] = [{"uri": "data:image/png;base64," + base64.b64encode(i).decode()} for i in images]
        gltf["textures"] = [{"source": k} for k in range(len(images))]
    if used:
        gltf["extensionsUsed"] = sorted(used)
    gltf["nodes"] = nodes
    gltf["scenes"] = [{"nodes": list(range(len(nodes)))}]
    gltf["buffers"] = [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}]
    with open(f"{OUT_DIR}/{name}.gltf", "w") as f:
        json.dump(gltf, f, indent=1)
        f.write("\n")
    print(f"wrote {OUT_DIR}/{name}.gltf ({len(blob)} bytes of geometry)")

def cornell_with(name, fixture, fixture_material, doc):
    walls = cornell_walls()
    meshes = [(k, g) for k, g in walls.items()] + [("fixture", fixture)]
    write(name, meshes, dict(WALLS, fixture=fixture_material), camera=CORNELL_CAMERA, doc=doc)

def box8(lo, hi):
    """A closed box of 12 triangles on 8 shared corners, normals averaged
    there (as exporters write an unsplit cube): smooth normals across its edges."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    pos = [[x, y, z] for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)]
    c = [(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2]
    nrm = []
    for p in pos:
        n = [1 if p[k] > c[k] else -1 for k in range(3)]
        nrm.append(scale(n, 1 / math.sqrt(3)))
    # Corner index: 4 * (x == x1) + 2 * (y == y1) + (z == z1); CCW seen from outside.
    faces = [(1, 5, 7, 3), (4, 0, 2, 6), (5, 4, 6, 7), (0, 1, 3, 2), (2, 3, 7, 6), (0, 4, 5, 1)]
    idx = []
    for a, b, c2, d in faces:
        idx += [a, b, c2, a, c2, d]
    return {"pos": pos, "nrm": nrm, "uv": [[0, 0]] * 8, "idx": idx}

def suzanne(c, r):
    """A head of interpenetrating closed parts (skull, ears, muzzle), as a
    monkey head is modelled: surfaces that run into each other."""
    return merge([sphere(c, r), sphere(add(c, [-0.95 * r, 0.55 * r, 0]), 0.45 * r, 16, 8),
                  sphere(add(c, [0.95 * r, 0.55 * r, 0]), 0.45 * r, 16, 8),
                  sphere(add(c, [0, -0.3 * r, 0.7 * r]), 0.55 * r, 16, 8)])

def slab_walls(lo, hi, t, sides, overlap):
    """Walls of thickness t around the inside lo..hi, each a closed box (a
    separate mesh): sides among floor, ceiling, back, left, right, front.
    Butt joints (slabs touching face to face) or overlapping at the corners."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    ox = t if overlap else 0
    walls = {"floor": ([x0 - t, y0 - t, z0 - t], [x1 + t, y0, z1 + t]),
             "ceiling": ([x0 - t, y1, z0 - t], [x1 + t, y1 + t, z1 + t]),
             "back": ([x0 - ox, y0 - ox, z0 - t], [x1 + ox, y1 + ox, z0]),
             "front": ([x0 - ox, y0 - ox, z1], [x1 + ox, y1 + ox, z1 + t]),
             "left": ([x0 - t, y0 - ox, z0 - ox], [x0, y1 + ox, z1 + ox]),
             "right": ([x1, y0 - ox, z0 - ox], [x1 + t, y1 + ox, z1 + ox])}
    return [(name, box(*walls[name])) for name in sides]

SLAB_COLOURS = {"floor": "white", "ceiling": "white", "back": "white", "front": "white", "left": "red", "right": "green"}

def slab_scene(name, kind, fixture_t, gap, slab_t, overlap, walls_double_sided, fixture8=False, size=1.0, doc=""):
    """The issue-34 family: rooms of closed slabs lit only by a thin closed
    emissive slab under the ceiling.
      kind "open-box": a 2 m box of five slabs (no front), a monkey head
        inside, no camera; the fixture 1 m x fixture_t x 1 m, emissiveFactor 1,
        baseColor 0.8.
      kind "room": a closed 4 x 2.6 x 3.5 m room of six slabs, two spheres,
        a camera inside; the fixture 1.2 m x fixture_t x 1.2 m, emissiveFactor 3.
    gap: between the fixture's top and the ceiling (0: touching); size
    scales the room, its contents and the fixture's width (not its thickness)."""
    mats = {k: dict(v, doubleSided=walls_double_sided) for k, v in WALLS.items()}
    if kind == "open-box":
        lo, hi = scale([-1, 0, -1], size), scale([1, 2, 1], size)
        sides = ["floor", "ceiling", "back", "left", "right"]
        half, emission, fixture_colour = 0.5 * size, 1, 0.8
        extra = [("grey", suzanne(scale([0.15, 0.45, -0.1], size), 0.3 * size))]
        camera = None
    else:
        lo, hi = scale([-2, 0, -1.75], size), scale([2, 2.6, 1.75], size)
        sides = ["floor", "ceiling", "back", "front", "left", "right"]
        half, emission, fixture_colour = 0.6 * size, 3, 0.8
        extra = [("grey", merge([sphere(scale([-0.9, 0.5, -0.6], size), 0.5 * size),
                                 sphere(scale([0.8, 0.35, 0.2], size), 0.35 * size)]))]
        camera = {"translation": scale([0.0, 1.3, 1.6], size), "yfov": math.radians(65)}
    mats["grey"] = {"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1], "metallicFactor": 0},
                    "doubleSided": walls_double_sided}
    top = hi[1] - gap
    flo, fhi = [-half, top - fixture_t, -half], [half, top, half]
    fixture = box8(flo, fhi) if fixture8 else box(flo, fhi)
    mats["fixture"] = {"emissiveFactor": [emission] * 3, "doubleSided": True,
                       "pbrMetallicRoughness": {"baseColorFactor": [fixture_colour] * 3 + [1], "metallicFactor": 0}}
    meshes = [(SLAB_COLOURS[n], g) for n, g in slab_walls(lo, hi, slab_t, sides, overlap)] + extra + [("fixture", fixture)]
    write(name, meshes, mats, camera=camera, doc=doc)

def look_at(eye, target):
    """A glTF camera node's rotation (quaternion x, y, z, w) looking from eye at target, +Y up."""
    f = [t - e for t, e in zip(target, eye)]; l = math.sqrt(dot(f, f)); f = [c / l for c in f]
    r = cross(f, [0, 1, 0]); l = math.sqrt(dot(r, r)); r = [c / l for c in r]
    u = cross(r, f)
    # Columns of the rotation: r, u, -f (the camera looks down its -Z).
    m = [[r[0], u[0], -f[0]], [r[1], u[1], -f[1]], [r[2], u[2], -f[2]]]
    tr = m[0][0] + m[1][1] + m[2][2]
    if tr > 0:
        s4 = math.sqrt(tr + 1.0) * 2
        return [(m[2][1] - m[1][2]) / s4, (m[0][2] - m[2][0]) / s4, (m[1][0] - m[0][1]) / s4, 0.25 * s4]
    i = max(range(3), key=lambda k: m[k][k])
    j, k = (i + 1) % 3, (i + 2) % 3
    s4 = math.sqrt(1.0 + m[i][i] - m[j][j] - m[k][k]) * 2
    q = [0.0, 0.0, 0.0, 0.0]
    q[i] = 0.25 * s4
    q[j] = (m[j][i] + m[i][j]) / s4
    q[k] = (m[k][i] + m[i][k]) / s4
    q[3] = (m[k][j] - m[j][k]) / s4
    return q

THIN_WALLS = {"white": {"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0}},
              "red": {"pbrMetallicRoughness": {"baseColorFactor": [1, 0, 0, 1], "metallicFactor": 0}},
              "green": {"pbrMetallicRoughness": {"baseColorFactor": [0, 1, 0, 1], "metallicFactor": 0}}}

def thin_box(name, slab_t, double, view, doc):
    """An open-front 2 m box of five closed slabs slab_t thick (albedo 1 white,
    saturated red and green), a grey block inside, lit only by a 6 mm closed
    emissive fixture touching the ceiling; the camera outside (front, left,
    above: the ceiling's and the left wall's outer faces in view) or inside."""
    lo, hi = [-1, 0, -1], [1, 2, 1]
    mats = {k: dict(v, doubleSided=double) for k, v in THIN_WALLS.items()}
    mats["grey"] = {"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1], "metallicFactor": 0},
                    "doubleSided": double}
    mats["fixture"] = {"emissiveFactor": [1, 1, 1], "doubleSided": True,
                       "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0}}
    walls = slab_walls(lo, hi, slab_t, ["floor", "ceiling", "back", "left", "right"], False)
    meshes = [(SLAB_COLOURS[n], g) for n, g in walls]
    meshes += [("grey", box([-0.5, 0, -0.6], [0.1, 0.9, 0.0], 0.3)),
               ("fixture", box([-0.5, 2 - 0.006, -0.5], [0.5, 2, 0.5]))]
    if view == "outside":
        eye, target = [-3.2, 3.6, 4.6], [0, 1.0, 0]
    else:
        eye, target = [0.5, 1.0, 0.9], [-0.3, 0.9, -1]
    camera = {"translation": eye, "rotation": look_at(eye, target), "yfov": math.radians(45)}
    write(name, meshes, mats, camera=camera, doc=doc)

def two_rooms(name, wall_t, double, doc, right_light=None):
    """Two open-top rooms (2 x 1.5 x 2 m each) of closed 10 cm slabs, side by
    side, sharing one slab wall_t thick; a 2 W/sr point light in the left
    room, seen from above: the right room is unlit in truth, or lit only by
    a point light of right_light W/sr of its own."""
    mats = {k: dict(v, doubleSided=double) for k, v in THIN_WALLS.items()}
    t, h = 0.10, 1.5
    half = wall_t / 2
    parts = {"white": [box([-2 - half - t, -t, -1 - t], [2 + half + t, 0, 1 + t]),            # floor
                       box([-2 - half - t, 0, -1 - t], [2 + half + t, h, -1]),               # back
                       box([-2 - half - t, 0, 1], [2 + half + t, h, 1 + t])],                # front
             "red": [box([-2 - half - t, 0, -1], [-2 - half, h, 1])],                        # left outer wall
             "green": [box([2 + half, 0, -1], [2 + half + t, h, 1])],                        # right outer wall
             "shared": [box([-half, 0, -1], [half, h, 1])]}
    mats["shared"] = dict(THIN_WALLS["white"], doubleSided=double)
    meshes = [(k, merge(v)) for k, v in parts.items()]
    light = ({"type": "point", "color": [1, 1, 1], "intensity": 2.0}, [-1.0, 1.0, 0.3])
    eye, target = [0.0, 5.5, 3.2], [0.0, 0.4, 0.0]
    camera = {"translation": eye, "rotation": look_at(eye, target), "yfov": math.radians(45)}
    lights = [light]
    if right_light is not None:
        lights.append(({"type": "point", "color": [1, 1, 1], "intensity": right_light}, [1.0, 1.0, 0.3]))
    write(name, meshes, mats, lights=lights, camera=camera, doc=doc)

if len(sys.argv) == 3 and sys.argv[1] == "--sweep":
    # The whole grid of proportions, for examples/fixture_sweep.rs (not committed).
    OUT_DIR = sys.argv[2]
    os.makedirs(OUT_DIR, exist_ok=True)
    for kind in ("open-box", "room"):
        for t in (0.001, 0.006, 0.05, 0.10):
            for gap in (0.0, 0.01):
                for overlap in (False, True):
                    for double in (False, True):
                        for size, fixture8 in ((1.0, False), (3.0, True)):
                            name = f"{kind}-t{t * 1000:g}mm-gap{gap * 100:g}cm-{'overlap' if overlap else 'butt'}-{'double' if double else 'single'}-x{size:g}{'-smooth' if fixture8 else ''}"
                            slab_scene(name, kind, t, gap, 0.13 if kind == "open-box" else 0.10, overlap, double,
                                       fixture8=fixture8, size=size)
    sys.exit(0)

if len(sys.argv) == 3 and sys.argv[1] == "--convergence":
    # The path tracer's convergence study (docs/accuracy.md; not committed):
    # a Cornell box as the nvpro-samples one is published, a small bright
    # emissive panel under the ceiling and materials that give only a base
    # colour, which glTF's defaults (metallic 1, roughness 1) make rough metal.
    OUT_DIR = sys.argv[2]
    os.makedirs(OUT_DIR, exist_ok=True)
    walls = cornell_walls()
    mats = {k: {"pbrMetallicRoughness": {"baseColorFactor": v["pbrMetallicRoughness"]["baseColorFactor"]}}
            for k, v in WALLS.items()}
    mats["panel"] = {"emissiveFactor": [1.0, 0.85, 0.6],
                     "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 17.0}},
                     "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0}}
    panel = quad([-0.25, 1.99, -0.2], [0.5, 0, 0], [0, 0, 0.4])  # facing down
    meshes = [(k, g) for k, g in walls.items()] + [("panel", panel)]
    write("nvpro-like-box", meshes, mats, camera=CORNELL_CAMERA,
          doc="Cornell box, base colours only (glTF defaults: rough metal), a 0.5 x 0.4 m emissive panel")
    sys.exit(0)

if len(sys.argv) == 3 and sys.argv[1] == "--independent":
    # Scenes for the check against an independent renderer
    # (scripts/mitsuba-reference.py, docs/accuracy.md; not committed): objects
    # as third-party assets model them, with textures (numpy and Pillow).
    import io
    import numpy as np
    from PIL import Image
    OUT_DIR = sys.argv[2]
    os.makedirs(OUT_DIR, exist_ok=True)

    def png_bytes(a):
        b = io.BytesIO()
        Image.fromarray(a).save(b, format="PNG")
        return b.getvalue()

    def srgb(x):
        return (np.clip(x, 0, 1) ** (1 / 2.2) * 255).astype(np.uint8)

    def normal_png(sx, sy):
        """A tangent-space normal map of slopes (sx, sy) (green: image-up)."""
        n = np.stack([-sx, -sy, np.ones_like(sx)], -1)
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        return png_bytes(((n * 0.5 + 0.5) * 255).astype(np.uint8))

    def tex(i, transform=None):
        return dict({"index": i}, **({"extensions": {"KHR_texture_transform": transform}} if transform else {}))

    def grooves(x, y, nx, ny, width, slope):
        """V-grooves at the edges of nx x ny panels (width in texture units)."""
        fx, fy = (x * nx) % 1.0, (y * ny) % 1.0
        sx = np.where(fx < width * nx, -slope, np.where(fx > 1 - width * nx, slope, 0.0))
        sy = np.where(fy < width * ny, -slope, np.where(fy > 1 - width * ny, slope, 0.0))
        return sx, sy

    rng = np.random.default_rng(5)
    yy, xx = np.mgrid[0:512, 0:512] / 512

    # A helmet-like shell: metal and painted panels of roughness 0.25-0.7,
    # grooved by a normal map, an emissive strip; a smooth metal visor.
    pu, pv = np.floor(xx * 8), np.floor(yy * 6)
    metal = ((pu + pv) % 3 == 0).astype(float)
    rough = 0.25 + 0.45 * ((pu * 7 + pv * 3) % 5) / 4
    base = np.where(metal[..., None] > 0, [0.9, 0.85, 0.75], [0.35, 0.4, 0.3]) * (0.85 + 0.15 * rng.random((512, 512, 1)))
    emission = np.where((np.abs(yy - 0.55) < 0.02) & ((xx * 8) % 1 < 0.7), 1.0, 0.0)[..., None] * [0.2, 0.8, 1.0]
    write("helmet", [("shell", sphere([0, 0, 0], 1.0, 96, 48)), ("visor", sphere([0, 0.1, 0.45], 0.62, 64, 32))],
          {"shell": {"pbrMetallicRoughness": {"baseColorTexture": tex(0), "metallicRoughnessTexture": tex(1)},
                     "normalTexture": tex(2), "emissiveTexture": tex(3), "emissiveFactor": [1, 1, 1],
                     "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}},
           "visor": {"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.45, 0.2, 1], "metallicFactor": 1,
                                              "roughnessFactor": 0.1}}},
          lights=[({"type": "point", "intensity": 30}, [-2.0, 2.5, 3.0])],
          camera={"translation": [0.0, 0.1, 3.6], "yfov": 0.7},
          images=[png_bytes(srgb(base)), png_bytes((np.stack([0 * rough, rough, metal], -1) * 255).astype(np.uint8)),
                  normal_png(*grooves(xx, yy, 8, 6, 4 / 512, 0.6)), png_bytes(srgb(emission))],
          doc="A helmet-like shell: metal and painted panels, grooves in a normal map, an emissive strip; a smooth metal visor")

    # A bottle-like metal body (roughness 0.3) with a painted label band, a
    # smooth black cap, on a rough grey ground.
    label = np.abs(yy - 0.5) < 0.2
    base = np.where(label[..., None], np.where(((xx * 10) % 1 < 0.5)[..., None], [0.8, 0.1, 0.1], [0.9, 0.9, 0.85]),
                    [0.55, 0.6, 0.65])
    mr = np.stack([0 * xx, np.where(label, 0.6, 0.3), np.where(label, 0.0, 1.0)], -1)
    write("bottle", [("body", cylinder([0, 0, 0], 0.35, 1.4, 64)), ("cap", cylinder([0, 1.4, 0], 0.18, 0.25, 48)),
                     ("ground", quad([-4, 0, 4], [8, 0, 0], [0, 0, -8]))],
          {"body": {"pbrMetallicRoughness": {"baseColorTexture": tex(0), "metallicRoughnessTexture": tex(1)}},
           "cap": {"pbrMetallicRoughness": {"baseColorFactor": [0.05, 0.05, 0.05, 1], "metallicFactor": 0,
                                            "roughnessFactor": 0.15}},
           "ground": {"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0,
                                               "roughnessFactor": 0.7}}},
          lights=[({"type": "point", "intensity": 25}, [1.5, 3.0, 2.0])],
          camera={"translation": [0.0, 0.8, 3.2], "yfov": 0.7},
          images=[png_bytes(srgb(base)), png_bytes((mr * 255).astype(np.uint8))],
          doc="A bottle-like metal body with a painted label, a smooth cap, on a rough ground")

    # A shader ball: white metal (roughness 0.3) on a dark plinth, a grey
    # floor and a warm back wall.
    write("shaderball", [("ball", sphere([0, 0.85, 0], 0.6, 96, 48)), ("plinth", box([-0.45, 0, -0.45], [0.45, 0.3, 0.45])),
                         ("floor", quad([-5, 0, 5], [10, 0, 0], [0, 0, -10])), ("wall", quad([-5, 0, -2], [10, 0, 0], [0, 5, 0]))],
          {"ball": {"pbrMetallicRoughness": {"baseColorFactor": [0.95, 0.95, 0.95, 1], "metallicFactor": 1,
                                             "roughnessFactor": 0.3}},
           "plinth": {"pbrMetallicRoughness": {"baseColorFactor": [0.1, 0.1, 0.12, 1], "metallicFactor": 0,
                                               "roughnessFactor": 0.5}},
           "floor": {"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1], "metallicFactor": 0,
                                              "roughnessFactor": 0.8}},
           "wall": {"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.5, 0.35, 1], "metallicFactor": 0,
                                             "roughnessFactor": 0.9}}},
          lights=[({"type": "point", "intensity": 20}, [1.5, 2.5, 1.5])],
          camera={"translation": [0.0, 0.9, 3.0], "yfov": 0.75},
          doc="A white metal shader ball on a plinth, a floor and a back wall")

    # A quad facing the camera whose normal map turns every normal 44
    # degrees towards image-up, under a light above it: lit where image-up
    # is up (the uvs upright), dark where the uvs mirror the image.
    up = np.array([0.0, 0.7, 0.714]) / np.linalg.norm([0.0, 0.7, 0.714])
    tilt = np.broadcast_to(((up * 0.5 + 0.5) * 255).astype(np.uint8), (8, 8, 3)).copy()
    for name, uv in (("tilt", [[0, 1], [1, 1], [1, 0], [0, 0]]), ("tilt-mirrored", [[0, 0], [1, 0], [1, 1], [0, 1]])):
        write(name, [("q", dict(quad([-1, -1, 0], [2, 0, 0], [0, 2, 0]), uv=uv))],
              {"q": {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0},
                     "normalTexture": tex(0)}},
              lights=[({"type": "point", "intensity": 5}, [0.0, 3.0, 0.3])],
              camera={"translation": [0.0, 0.0, 2.5], "yfov": 0.9}, images=[png_bytes(tilt)],
              doc="A normal map turned towards image-up under a light above it")

    # A garden: leaves cut out by an alpha mask (MASK, doubleSided), a ground
    # whose checker is turned, scaled and offset by KHR_texture_transform,
    # a copper ball, under a directional sun.
    holes = (((xx * 6) % 1 - 0.5) ** 2 + ((yy * 6) % 1 - 0.5) ** 2 > 0.09).astype(float)
    leaf = np.concatenate([srgb(np.stack([0.2 + 0.6 * xx, 0.6 + 0.3 * yy, 0.1 + 0 * xx], -1)),
                           (holes * 255).astype(np.uint8)[..., None]], -1)
    check = ((np.floor(xx * 8) + np.floor(yy * 8)) % 2) * 0.5 + 0.3
    leaves = []
    for x, z, a in [(-1.0, -0.5, 0.3), (0.6, -1.0, -0.5), (0.0, 0.5, 1.2)]:
        c, s = math.cos(a), math.sin(a)
        leaves.append(quad([x - c * 0.6, 0.2, z - s * 0.6], [c * 1.2, 0, s * 1.2], [0, 1.2, 0]))
    write("garden", [("ground", quad([-4, 0, 4], [8, 0, 0], [0, 0, -8])), ("leaf", merge(leaves)),
                     ("ball", sphere([1.5, 0.5, 0.5], 0.5, 48, 24))],
          {"ground": {"pbrMetallicRoughness": {
              "baseColorTexture": tex(1, {"rotation": 0.5, "scale": [3, 3], "offset": [0.2, 0.1]}),
              "metallicFactor": 0, "roughnessFactor": 0.8}},
           "leaf": {"pbrMetallicRoughness": {"baseColorTexture": tex(0), "metallicFactor": 0, "roughnessFactor": 0.6},
                    "alphaMode": "MASK", "alphaCutoff": 0.5, "doubleSided": True},
           "ball": {"pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.6, 0.5, 1], "metallicFactor": 1,
                                             "roughnessFactor": 0.4}}},
          lights=[({"type": "directional", "intensity": 3.0, "color": [1, 0.95, 0.85]}, [0, 0, 0],
                   [-0.3535534, 0.3535534, 0.1464466, 0.8535534])],
          camera={"translation": [0.0, 1.6, 4.5], "yfov": 0.8, "rotation": [-0.1305262, 0, 0, 0.9914449]},
          images=[png_bytes(leaf), png_bytes(srgb(np.stack([check, check * 0.9, check * 0.8], -1)))],
          doc="Alpha-masked leaves, a ground with a turned checker, a copper ball, under a directional sun")

    # A spot light (glTF's smooth falloff, 20-34 degree cone) pointing down
    # at a floor before a wall, a white-metal ball half in its cone.
    write("spot", [("floor", quad([-3, 0, 3], [6, 0, 0], [0, 0, -6])), ("wall", quad([-3, 0, -2], [6, 0, 0], [0, 3, 0])),
                   ("ball", sphere([0.5, 0.4, 0], 0.4, 48, 24))],
          {"floor": {"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1], "metallicFactor": 0,
                                              "roughnessFactor": 0.8}},
           "wall": {"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.4, 0.3, 1], "metallicFactor": 0}},
           "ball": {"pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.9, 0.9, 1], "metallicFactor": 1,
                                             "roughnessFactor": 0.3}}},
          lights=[({"type": "spot", "intensity": 15, "spot": {"innerConeAngle": 0.35, "outerConeAngle": 0.6}},
                   [0, 2.5, 0.3], [-0.7071068, 0, 0, 0.7071068])],
          camera={"translation": [0, 1.5, 4], "yfov": 0.8, "rotation": [-0.1305262, 0, 0, 0.9914449]},
          doc="A spot light pointing down at a floor before a wall, a metal ball half in its cone")

    # A closed 6 x 3 x 6 m studio seen from inside: a wood floor (2x tiled
    # base colour and metallic-roughness, a 6x tiled grooved normal map), a
    # red wall, a gold sphere, a plastic box, an emissive panel, a point light.
    big_y, big_x = np.mgrid[0:1024, 0:1024] / 1024
    wood = 0.55 + 0.25 * np.sin(2 * np.pi * (big_x * 12 + 0.3 * np.sin(2 * np.pi * big_y * 3)))
    sx, sy = grooves(big_x, big_y, 4, 4, 12 / 1024 * 4 / 4, 0.5)
    sx, sy = sx + rng.normal(0, 0.03, sx.shape), sy + rng.normal(0, 0.03, sy.shape)
    rough = 0.2 + 0.25 * (0.5 + 0.5 * np.sin(2 * np.pi * big_x * 2) * np.sin(2 * np.pi * big_y * 2))
    write("studio",
          [("floor", quad([-3, 0, 3], [6, 0, 0], [0, 0, -6])),
           ("wall", merge([quad([-3, 3, -3], [6, 0, 0], [0, 0, 6]), quad([-3, 0, -3], [6, 0, 0], [0, 3, 0]),
                           quad([3, 0, 3], [-6, 0, 0], [0, 3, 0]), quad([3, 0, -3], [0, 0, 6], [0, 3, 0])])),
           ("red", quad([-3, 0, 3], [0, 0, -6], [0, 3, 0])), ("panel", quad([-1.0, 1.2, -2.98], [2.0, 0, 0], [0, 0.5, 0])),
           ("gold", sphere([0.9, 0.6, -0.6], 0.6, 64, 32)), ("plastic", box([-1.8, 0, -1.6], [-0.8, 1.0, -0.6], 0.4))],
          {"floor": {"pbrMetallicRoughness": {"baseColorTexture": tex(0, {"scale": [2, 2]}),
                                              "metallicRoughnessTexture": tex(2, {"scale": [2, 2]}),
                                              "metallicFactor": 1, "roughnessFactor": 1},
                     "normalTexture": tex(1, {"scale": [6, 6]})},
           "wall": {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.78, 0.72, 1], "metallicFactor": 0,
                                             "roughnessFactor": 0.9}},
           "red": {"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.12, 0.08, 1], "metallicFactor": 0,
                                            "roughnessFactor": 0.8}},
           "gold": {"pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.78, 0.34, 1], "metallicFactor": 1,
                                             "roughnessFactor": 0.35}},
           "plastic": {"pbrMetallicRoughness": {"baseColorFactor": [0.1, 0.3, 0.6, 1], "metallicFactor": 0,
                                                "roughnessFactor": 0.4}},
           "panel": {"pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.9, 0.9, 1], "metallicFactor": 0},
                     "emissiveFactor": [1, 0.9, 0.8], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 6}}}},
          lights=[({"type": "point", "intensity": 12, "color": [1, 0.95, 0.9]}, [0.0, 2.7, 0.5])],
          camera={"translation": [0.3, 1.5, 2.7], "yfov": math.radians(55)},
          images=[png_bytes(srgb(np.stack([wood * 0.75, wood * 0.5, wood * 0.3], -1))),
                  normal_png(sx, sy), png_bytes((np.stack([0 * rough, rough, 0 * rough], -1) * 255).astype(np.uint8))],
          doc="A closed studio: textured, normal-mapped wood floor, gold sphere, plastic box, emissive panel, point light")
    sys.exit(0)

# The glTF default material is white (baseColorFactor 1); only emission is set.
cornell_with("fixture-thin-box", box([-0.25, 1.97, -0.25], [0.25, 1.99, 0.25]),
             {"emissiveFactor": [1, 1, 1], "doubleSided": True},
             "Cornell box lit by a thin closed emissive box (albedo 1, doubleSided) 1 cm under the ceiling")
cornell_with("fixture-quad-gap", quad([-0.25, 1.99, -0.25], [0.5, 0, 0], [0, 0, 0.5]),
             {"emissiveFactor": [1, 1, 1], "doubleSided": True,
              "pbrMetallicRoughness": {"baseColorFactor": [0.78, 0.78, 0.78, 1], "metallicFactor": 0}},
             "Cornell box lit by a doubleSided emissive quad 1 cm under the ceiling")
cornell_with("fixture-quad-flush", quad([-0.25, 1.999, -0.25], [0.5, 0, 0], [0, 0, 0.5]),
             {"emissiveFactor": [1, 0.85, 0.6], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}},
              "pbrMetallicRoughness": {"baseColorFactor": [0.78, 0.78, 0.78, 1], "metallicFactor": 0}},
             "Cornell box lit by a one-sided emissive quad 1 mm under the ceiling, facing down")



# Issue 34's two held-out boxes, rebuilt from their description, and
# variants of proportion (tests/third_party_scenes.rs renders every one).
slab_scene("slabs-open-box", "open-box", 0.006, 0.0, 0.13, False, True, fixture8=True,
           doc="Open-front box of five closed 13 cm slabs (doubleSided), a monkey head, no camera; "
               "lit only by a closed 1 m x 6 mm x 1 m emissive box (12 triangles) touching the ceiling")
slab_scene("slabs-open-box-large", "open-box", 0.006, 0.0, 0.13, False, True, size=3.0,
           doc="slabs-open-box three times as large (6 m), the fixture still 6 mm thick")
slab_scene("slabs-room", "room", 0.05, 0.0, 0.10, False, True,
           doc="Closed room of six 10 cm slabs (doubleSided, touching), two spheres, camera inside; "
               "lit only by a closed 5 cm emissive slab against the ceiling")
slab_scene("slabs-open-box-1mm-gap1cm", "open-box", 0.001, 0.01, 0.13, True, False,
           doc="slabs-open-box with a 1 mm fixture 1 cm under the ceiling, one-sided walls overlapping at the corners")
slab_scene("slabs-open-box-10cm", "open-box", 0.10, 0.0, 0.13, True, True,
           doc="slabs-open-box with a 10 cm fixture touching the ceiling, walls overlapping at the corners")
slab_scene("slabs-room-1mm", "room", 0.001, 0.0, 0.10, True, False,
           doc="slabs-room with a 1 mm fixture touching the ceiling, one-sided walls overlapping at the corners")
slab_scene("slabs-room-1mm-huge", "room", 0.001, 0.0, 0.10, False, True, size=10.0,
           doc="slabs-room ten times as large (40 m), the fixture 1 mm thick touching the ceiling 26 m up")
slab_scene("slabs-room-6mm-gap1cm", "room", 0.006, 0.01, 0.10, False, True, fixture8=True,
           doc="slabs-room with a 6 mm fixture (12 triangles) 1 cm under the ceiling")

write("closed-room",
      [("walls", box([-2, 0, -1.5], [2, 2.6, 1.5], inward=True)),
       ("blue", merge([sphere([-0.9, 0.45, -0.4], 0.45), sphere([0.6, 0.3, 0.5], 0.3)])),
       ("orange", merge([box([0.4, 0, -1.0], [1.2, 0.9, -0.2], 0.4), box([-1.6, 0, 0.4], [-1.0, 1.4, 1.0], -0.2)]))],
      {"walls": {"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1], "metallicFactor": 0}},
       "blue": {"pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.3, 0.7, 1], "metallicFactor": 0}},
       "orange": {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.45, 0.15, 1], "metallicFactor": 0}}},
      lights=[({"type": "point", "color": [1, 1, 1], "intensity": 8.0}, [0.3, 2.2, 0.2])],
      camera={"translation": [0.0, 1.4, 1.45], "yfov": math.radians(60)},
      doc="A closed room (4 x 2.6 x 3 m) with two spheres and two boxes, lit by an 8 W/sr point light; camera inside")

label = png(64, 64, lambda x, y: (255, 200, 80) if 24 <= y < 32 else (0, 0, 0))
write("glowing-label", [("bottle", cylinder([0, 0, 0], 0.04, 0.25))],
      {"bottle": {"pbrMetallicRoughness": {"baseColorFactor": [0.3, 0.6, 0.35, 1], "metallicFactor": 0},
                  "emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 0}}},
      images=[label], doc="A bottle whose only emission is an emissive texture, black but for a label band; no lights, no camera")

write("emissive-floor", [("floor", quad([-20, 0, 20], [40, 0, 0], [0, 0, -40]))],
      {"floor": {"emissiveFactor": [0.5, 0.5, 0.5],
                 "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0}}},
      doc="A 40 m emissive floor plane; no lights, no camera")

thin_box("thin-box-13cm-outside", 0.13, True, "outside",
         doc="Open-front box of 13 cm doubleSided slabs (albedo 1 white, saturated red, green), seen from outside")
thin_box("thin-box-1mm-outside", 0.001, False, "outside",
         doc="Open-front box of 1 mm one-sided slabs, seen from outside")
thin_box("thin-box-20cm-outside", 0.20, False, "outside",
         doc="Open-front box of 20 cm one-sided slabs, seen from outside")
thin_box("thin-box-1mm-inside", 0.001, True, "inside",
         doc="Open-front box of 1 mm doubleSided slabs, seen from inside")
two_rooms("thin-two-rooms-1mm", 0.001, True,
          doc="Two open-top rooms sharing a 1 mm doubleSided wall, a point light in the left one, seen from above")
two_rooms("thin-two-rooms-20cm", 0.20, False,
          doc="Two open-top rooms sharing a 20 cm one-sided wall, a point light in the left one, seen from above")
two_rooms("thin-two-rooms-1mm-two-lights", 0.001, True, right_light=0.2,
          doc="Two open-top rooms sharing a 1 mm doubleSided wall, a 2 W/sr point light in the left one and a 0.2 W/sr one in the right, seen from above")
