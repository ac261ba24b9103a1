#!/usr/bin/env python3
"""Writes tests/scenes/*.gltf: scenes modelled the way third-party files
model them, for the tests of emissive fixtures, the default light and the
default camera (tests/third_party_scenes.rs, docs/accuracy.md). Run from the
repository root; standard library only.

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
"""
import base64, json, math, struct, zlib

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
        gltf["extensions"] = {"KHR_lights_punctual": {"lights": [l for l, _ in lights]}}
        nodes += [{"name": "light", "translation": t, "extensions": {"KHR_lights_punctual": {"light": i}}}
                  for i, (_, t) in enumerate(lights)]
    if camera:
        gltf["cameras"] = [{"type": "perspective", "perspective": {"yfov": camera["yfov"], "znear": 0.01, "aspectRatio": 4 / 3}}]
        nodes.append({"name": "camera", "translation": camera["translation"], "camera": 0})
    if images:
        gltf["images"] = [{"uri": "data:image/png;base64," + base64.b64encode(i).decode()} for i in images]
        gltf["textures"] = [{"source": k} for k in range(len(images))]
    if used:
        gltf["extensionsUsed"] = sorted(used)
    gltf["nodes"] = nodes
    gltf["scenes"] = [{"nodes": list(range(len(nodes)))}]
    gltf["buffers"] = [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}]
    with open(f"tests/scenes/{name}.gltf", "w") as f:
        json.dump(gltf, f, indent=1)
        f.write("\n")
    print(f"wrote tests/scenes/{name}.gltf ({len(blob)} bytes of geometry)")

def cornell_with(name, fixture, fixture_material, doc):
    walls = cornell_walls()
    meshes = [(k, g) for k, g in walls.items()] + [("fixture", fixture)]
    write(name, meshes, dict(WALLS, fixture=fixture_material), camera=CORNELL_CAMERA, doc=doc)

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
