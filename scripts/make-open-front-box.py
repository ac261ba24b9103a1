#!/usr/bin/env python3
"""Writes assets/open-front-box.gltf: the built-in Cornell box's geometry,
materials and camera (src/scene/builtin.rs) without a front wall, lit by a
3 W/sr point light 10 cm under the ceiling (KHR_lights_punctual, read as
radiometric W/sr). The scene the interleaved-gather defaults were chosen on
(docs/performance.md). Run from the repository root; standard library only."""
import base64, json, math, struct

def quad(corner, u, v):
    n = cross(u, v); l = math.sqrt(dot(n, n)); n = [c / l for c in n]
    p = [corner, add(corner, u), add(add(corner, u), v), add(corner, v)]
    return p, [n] * 4, [0, 1, 2, 0, 2, 3]

def cross(a, b): return [a[1]*b[2]-a[2]*b[1], a[2]*b[0]-a[0]*b[2], a[0]*b[1]-a[1]*b[0]]
def dot(a, b): return sum(x * y for x, y in zip(a, b))
def add(a, b): return [x + y for x, y in zip(a, b)]
def scale(a, s): return [x * s for x in a]

def block(base, size, angle):
    """A closed box centred on the floor at `base`, turned by `angle` about Y."""
    h = scale(size, 0.5)
    c = lambda x, y, z: [x * h[0], y * size[1], z * h[2]]
    X, Y, Z = [size[0], 0, 0], [0, size[1], 0], [0, 0, size[2]]
    faces = [(c(-1, 0, 1), X, Y), (c(1, 0, -1), scale(X, -1), Y), (c(1, 0, 1), scale(Z, -1), Y),
             (c(-1, 0, -1), Z, Y), (c(-1, 1, 1), X, scale(Z, -1)), (c(-1, 0, -1), X, Z)]
    co, si = math.cos(angle), math.sin(angle)
    rot = lambda p: [co * p[0] + si * p[2], p[1], -si * p[0] + co * p[2]]
    out = []
    for corner, u, v in faces:
        p, n, i = quad(corner, u, v)
        out.append(([add(rot(q), base) for q in p], [rot(m) for m in n], i))
    return out

meshes = {  # material -> quads
    "white": [quad([-1, 0, 1], [2, 0, 0], [0, 0, -2]),    # floor
              quad([-1, 2, -1], [2, 0, 0], [0, 0, 2]),    # ceiling
              quad([-1, 0, -1], [2, 0, 0], [0, 2, 0])]    # back
             + block([0.33, 0, 0.37], [0.6, 0.6, 0.6], -0.29)
             + block([-0.35, 0, -0.3], [0.6, 1.2, 0.6], 0.29),
    "red": [quad([-1, 0, 1], [0, 0, -2], [0, 2, 0])],
    "green": [quad([1, 0, -1], [0, 0, 2], [0, 2, 0])],
}
colors = {"white": [0.73, 0.73, 0.73], "red": [0.63, 0.065, 0.05], "green": [0.14, 0.45, 0.091]}

blob, views, accessors, gltf_meshes, materials = b"", [], [], [], []
def view(data, target):
    global blob
    views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data), "target": target})
    blob += data + b"\0" * (-len(data) % 4)
    return len(views) - 1
for name, quads in meshes.items():
    pos = [p for q in quads for p in q[0]]
    nrm = [n for q in quads for n in q[1]]
    idx = [i + 4 * k for k, q in enumerate(quads) for i in q[2]]
    vp = view(b"".join(struct.pack("<3f", *p) for p in pos), 34962)
    vn = view(b"".join(struct.pack("<3f", *n) for n in nrm), 34962)
    vi = view(struct.pack(f"<{len(idx)}I", *idx), 34963)
    lo = [min(p[k] for p in pos) for k in range(3)]; hi = [max(p[k] for p in pos) for k in range(3)]
    accessors += [{"bufferView": vp, "componentType": 5126, "count": len(pos), "type": "VEC3", "min": lo, "max": hi},
                  {"bufferView": vn, "componentType": 5126, "count": len(nrm), "type": "VEC3"},
                  {"bufferView": vi, "componentType": 5125, "count": len(idx), "type": "SCALAR"}]
    a = len(accessors) - 3
    materials.append({"name": name, "pbrMetallicRoughness": {"baseColorFactor": colors[name] + [1.0],
                      "metallicFactor": 0.0, "roughnessFactor": 1.0}})
    gltf_meshes.append({"name": name, "primitives": [{"attributes": {"POSITION": a, "NORMAL": a + 1},
                        "indices": a + 2, "material": len(materials) - 1}]})

gltf = {
    "asset": {"version": "2.0", "generator": "scripts/make-open-front-box.py"},
    "extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1, 1, 1], "intensity": 3.0, "name": "ceiling light, 3 W/sr"}]}},
    "scene": 0,
    "scenes": [{"nodes": list(range(len(gltf_meshes) + 2))}],
    "nodes": [{"mesh": i, "name": m["name"]} for i, m in enumerate(gltf_meshes)]
             + [{"name": "light", "translation": [0, 1.9, 0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
                {"name": "camera", "translation": [0, 1, 3.9], "camera": 0}],
    "cameras": [{"type": "perspective", "perspective": {"yfov": math.radians(40), "znear": 0.01, "aspectRatio": 4 / 3}}],
    "meshes": gltf_meshes, "materials": materials, "accessors": accessors, "bufferViews": views,
    "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
}
with open("assets/open-front-box.gltf", "w") as f:
    json.dump(gltf, f, indent=1)
    f.write("\n")
print(f"wrote assets/open-front-box.gltf ({len(blob)} bytes of geometry)")
