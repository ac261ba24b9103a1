#!/usr/bin/env python3
"""Renders a glTF scene with Mitsuba 3, an independent path tracer, for
checking ssbc (and its own CPU path tracer, `ssbc reference`) against a
renderer that shares no code with it (docs/accuracy.md, "An independent
renderer").

  pip install mitsuba numpy pillow        # once; not needed by ssbc itself
  python3 scripts/mitsuba-reference.py scene.gltf -o truth.exr \
      --size 160x120 --spp 1024
  ssbc compare image.exr truth.exr --blocks 4

What it reads (the subset of glTF ssbc's conventions cover that third-party
test scenes use; anything else is named on stderr and rendered without):
triangle meshes of the default scene's node tree (positions, normals,
TEXCOORD_0), metallic-roughness materials with their textures (base
colour and emission sRGB, metallic-roughness linear B/G, normal maps with
their scale, KHR_texture_transform, sampler wrap and filter), alpha MASK /
BLEND (as a mask at 0.5), KHR_materials_emissive_strength,
KHR_lights_punctual (radiometric, as docs/conventions.md: W/sr, W/m^2;
spot lights with glTF's falloff under the gltf BRDF, Mitsuba's own else) and
the first camera in node order (required: ssbc's default camera is not
reproduced).

Materials become Mitsuba's `principled` BSDF (Disney-style: its diffuse is
not Lambert, its dielectric Fresnel is exact for eta 1.5 rather than
Schlick, its masking is separable Smith), two-sided, as ssbc treats every
surface as a two-sided reflector: close to glTF's appendix B, not equal
to it. `--lambertian` makes every material a Lambertian `diffuse` of its
base colour (for scenes whose materials are all metallic 0, roughness 1,
or to separate the geometry, lights and camera from the BRDF).

Not reproduced (ssbc follows glTF, Mitsuba cannot here): a one-sided
(`doubleSided: false`) surface seen from behind is culled for the camera,
and a double-sided emitter emits from both sides; Mitsuba shows the first
and emits from the front only (a warning names such emitters; a reversed
null-BSDF copy a hair behind the surface emitted the back's light right in
open space but 2.4x too much beside a ceiling 1 cm away).

Pixels are area-sampled with a box filter (`ssbc reference --antialias`
does the same; `ssbc render` samples pixel centres).
"""
import argparse
import base64
import io
import json
import math
import os
import struct
import sys

import numpy as np
from PIL import Image

COMPONENT = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}
NORMALIZED_SCALE = {np.int8: 127.0, np.uint8: 255.0, np.int16: 32767.0, np.uint16: 65535.0}
# Sampler wrap modes (glTF) -> Mitsuba's bitmap wrap_mode (one for both axes).
WRAP = {33071: "clamp", 33648: "mirror", 10497: "repeat"}
READ_EXTENSIONS = {"KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_texture_transform"}


def warn(msg):
    print(f"mitsuba-reference: warning: {msg}", file=sys.stderr)


class Gltf:
    def __init__(self, path):
        self.folder = os.path.dirname(os.path.abspath(path))
        data = open(path, "rb").read()
        self.glb_bin = None
        if data[:4] == b"glTF":
            length = struct.unpack_from("<I", data, 8)[0]
            offset = 12
            while offset < length:
                chunk_len, chunk_type = struct.unpack_from("<II", data, offset)
                chunk = data[offset + 8 : offset + 8 + chunk_len]
                if chunk_type == 0x4E4F534A:
                    self.doc = json.loads(chunk)
                elif chunk_type == 0x004E4942:
                    self.glb_bin = chunk
                offset += 8 + chunk_len
        else:
            self.doc = json.loads(data)
        self.buffers = [self._buffer(b) for b in self.doc.get("buffers", [])]
        for ext in self.doc.get("extensionsUsed", []):
            if ext not in READ_EXTENSIONS:
                warn(f"extension {ext} is not read")

    def _uri(self, uri):
        if uri.startswith("data:"):
            return base64.b64decode(uri.split(",", 1)[1])
        path = os.path.normpath(os.path.join(self.folder, uri.replace("%20", " ")))
        return open(path, "rb").read()

    def _buffer(self, b):
        if "uri" not in b:
            return self.glb_bin
        return self._uri(b["uri"])

    def view_bytes(self, index):
        view = self.doc["bufferViews"][index]
        start = view.get("byteOffset", 0)
        return self.buffers[view["buffer"]][start : start + view["byteLength"]], view.get("byteStride")

    def accessor(self, index):
        acc = self.doc["accessors"][index]
        dtype = np.dtype(COMPONENT[acc["componentType"]]).newbyteorder("<")
        width = WIDTH[acc["type"]]
        count = acc["count"]
        if "bufferView" in acc:
            data, stride = self.view_bytes(acc["bufferView"])
            offset = acc.get("byteOffset", 0)
            item = dtype.itemsize * width
            stride = stride or item
            raw = np.frombuffer(data, dtype=np.uint8, count=stride * (count - 1) + item, offset=offset)
            rows = np.lib.stride_tricks.as_strided(raw, shape=(count, item), strides=(stride, 1))
            out = np.ascontiguousarray(rows).view(dtype).reshape(count, width)
        else:
            out = np.zeros((count, width), dtype)
        if "sparse" in acc:
            sp = acc["sparse"]
            idx_data, _ = self.view_bytes(sp["indices"]["bufferView"])
            idx = np.frombuffer(idx_data, dtype=np.dtype(COMPONENT[sp["indices"]["componentType"]]).newbyteorder("<"),
                                count=sp["count"], offset=sp["indices"].get("byteOffset", 0))
            val_data, _ = self.view_bytes(sp["values"]["bufferView"])
            vals = np.frombuffer(val_data, dtype=dtype, count=sp["count"] * width,
                                 offset=sp["values"].get("byteOffset", 0)).reshape(-1, width)
            out = out.copy()
            out[idx] = vals
        if acc.get("normalized") and dtype.type in NORMALIZED_SCALE:
            return np.maximum(out.astype(np.float64) / NORMALIZED_SCALE[dtype.type], -1.0)
        return out.astype(np.float64)

    def image(self, index):
        img = self.doc["images"][index]
        if "uri" in img:
            data = self._uri(img["uri"])
        else:
            data, _ = self.view_bytes(img["bufferView"])
        return np.asarray(Image.open(io.BytesIO(data)).convert("RGBA"), dtype=np.float64) / 255.0


def node_matrix(node):
    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T
    t = np.eye(4)
    t[:3, 3] = node.get("translation", [0, 0, 0])
    x, y, z, w = node.get("rotation", [0, 0, 0, 1])
    r = np.eye(4)
    r[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    s = np.diag(list(node.get("scale", [1, 1, 1])) + [1])
    return t @ r @ s


def walk(gltf):
    """(node index, world matrix) of the default scene's nodes, depth first."""
    doc = gltf.doc
    scene = doc.get("scenes", [{}])[doc.get("scene", 0)] if doc.get("scenes") else {"nodes": list(range(len(doc.get("nodes", []))))}
    stack = [(n, np.eye(4)) for n in reversed(scene.get("nodes", []))]
    while stack:
        n, parent = stack.pop()
        node = doc["nodes"][n]
        world = parent @ node_matrix(node)
        yield n, world
        stack.extend((c, world) for c in reversed(node.get("children", [])))


def srgb_to_linear(c):
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def texture_transform(info):
    ext = info.get("extensions", {}).get("KHR_texture_transform")
    if ext is None:
        return None
    if "texCoord" in ext and ext["texCoord"] != 0 or info.get("texCoord", 0) != 0:
        warn("a texture on a TEXCOORD set other than 0 is read from set 0")
    ox, oy = ext.get("offset", [0, 0])
    sx, sy = ext.get("scale", [1, 1])
    r = ext.get("rotation", 0.0)
    c, s = math.cos(r), math.sin(r)
    translation = np.array([[1, 0, ox], [0, 1, oy], [0, 0, 1]], dtype=np.float64)
    rotation = np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]], dtype=np.float64)
    scale = np.array([[sx, 0, 0], [0, sy, 0], [0, 0, 1]], dtype=np.float64)
    return translation @ rotation @ scale


class Converter:
    def __init__(self, mi, gltf, brdf):
        self.mi = mi
        self.gltf = gltf
        self.brdf = brdf
        self.images = {}
        self.masked = False

    def bitmap(self, info, pixels, raw=True):
        """A Mitsuba bitmap texture of `pixels` (H x W x C, linear) read with
        glTF texture `info`'s sampler and transform."""
        mi = self.mi
        doc = self.gltf.doc
        tex = doc["textures"][info["index"]]
        sampler = doc.get("samplers", [{}] * (tex.get("sampler", 0) + 1))[tex["sampler"]] if "sampler" in tex else {}
        wrap_s, wrap_t = sampler.get("wrapS", 10497), sampler.get("wrapT", 10497)
        if wrap_s != wrap_t:
            warn("a sampler wraps s and t differently; Mitsuba takes s's for both")
        d = {
            "type": "bitmap",
            "bitmap": mi.Bitmap(np.ascontiguousarray(pixels, dtype=np.float32)),
            "raw": raw,
            "wrap_mode": WRAP.get(wrap_s, "repeat"),
            "filter_type": "nearest" if sampler.get("magFilter") == 9728 else "bilinear",
        }
        m = texture_transform(info)
        if m is not None:
            d["to_uv"] = mi.ScalarTransform3f(m.tolist())
        return d

    def texture_pixels(self, info):
        index = self.gltf.doc["textures"][info["index"]]["source"]
        if index not in self.images:
            self.images[index] = self.gltf.image(index)
        return self.images[index]

    def material(self, index):
        """(BSDF dict, emitted radiance (rgb or texture dict) or None, alpha info)."""
        doc = self.gltf.doc
        m = doc["materials"][index] if index is not None else {}
        for ext in m.get("extensions", {}):
            if ext not in READ_EXTENSIONS:
                warn(f"material {index}: extension {ext} is not read")
        pbr = m.get("pbrMetallicRoughness", {})
        factor = np.array(pbr.get("baseColorFactor", [1, 1, 1, 1]), dtype=np.float64)
        base_tex = None
        alpha = None
        if "baseColorTexture" in pbr:
            px = self.texture_pixels(pbr["baseColorTexture"])
            rgb = srgb_to_linear(px[..., :3]) * factor[:3]
            base_tex = self.bitmap(pbr["baseColorTexture"], rgb)
            alpha_px = px[..., 3] * factor[3]
        else:
            alpha_px = None
        mode = m.get("alphaMode", "OPAQUE")
        if mode != "OPAQUE":
            cutoff = m.get("alphaCutoff", 0.5) if mode == "MASK" else 0.5
            if alpha_px is not None:
                alpha = self.bitmap(pbr["baseColorTexture"], (alpha_px >= cutoff).astype(np.float64)[..., None])
                alpha["filter_type"] = "nearest"
            elif factor[3] < cutoff:
                alpha = 0.0
        if self.brdf == "lambertian":
            bsdf = {"type": "diffuse", "reflectance": base_tex or {"type": "rgb", "value": factor[:3].tolist()}}
        else:
            bsdf = {"type": self.brdf,
                    "base_color": base_tex or {"type": "rgb", "value": factor[:3].tolist()}}
            metallic = float(pbr.get("metallicFactor", 1.0))
            roughness = float(pbr.get("roughnessFactor", 1.0))
            if "metallicRoughnessTexture" in pbr:
                px = self.texture_pixels(pbr["metallicRoughnessTexture"])
                bsdf["roughness"] = self.bitmap(pbr["metallicRoughnessTexture"], (px[..., 1] * roughness)[..., None])
                bsdf["metallic"] = self.bitmap(pbr["metallicRoughnessTexture"], (px[..., 2] * metallic)[..., None])
            else:
                bsdf["roughness"] = roughness
                bsdf["metallic"] = metallic
            if "normalTexture" in m:
                info = m["normalTexture"]
                px = self.texture_pixels(info)[..., :3].copy()
                n = px * 2.0 - 1.0
                n[..., :2] *= info.get("scale", 1.0)
                n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-9)
                if self.brdf == "gltf":
                    bsdf["normalmap"] = self.bitmap(info, n * 0.5 + 0.5)
                else:
                    # Mitsuba's own: its bitangent is n x dp/du whatever the uv mapping's handedness.
                    bsdf = {"type": "normalmap", "normalmap": self.bitmap(info, n * 0.5 + 0.5), "bsdf": bsdf}
        if self.brdf != "gltf":
            bsdf = {"type": "twosided", "bsdf": bsdf}
        if alpha is not None:
            self.masked = True
            bsdf = {"type": "mask", "opacity": alpha if isinstance(alpha, dict) else {"type": "rgb", "value": [alpha] * 3},
                    "bsdf": bsdf}
        emissive = np.array(m.get("emissiveFactor", [0, 0, 0]), dtype=np.float64)
        strength = m.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
        emission = None
        if np.any(emissive * strength > 0):
            if "emissiveTexture" in m:
                px = self.texture_pixels(m["emissiveTexture"])
                emission = self.bitmap(m["emissiveTexture"], srgb_to_linear(px[..., :3]) * emissive * strength)
            else:
                emission = {"type": "rgb", "value": (emissive * strength).tolist()}
            if m.get("doubleSided"):
                warn(f"material {index}: a double-sided emitter emits from its front only here")
        return bsdf, emission

    def mesh(self, name, prim, world):
        mi = self.mi
        attrs = prim["attributes"]
        if prim.get("mode", 4) != 4:
            warn(f"{name}: primitive mode {prim.get('mode')} is not triangles; skipped")
            return None
        if "targets" in prim:
            warn(f"{name}: morph targets are not applied")
        pos = self.gltf.accessor(attrs["POSITION"])[:, :3]
        idx = self.gltf.accessor(prim["indices"])[:, 0].astype(np.uint32) if "indices" in prim else np.arange(len(pos), dtype=np.uint32)
        idx = idx[: len(idx) // 3 * 3]
        p = (world[:3, :3] @ pos.T).T + world[:3, 3]
        if np.linalg.det(world[:3, :3]) < 0:
            idx = idx.reshape(-1, 3)[:, ::-1].ravel()
        normals = None
        if "NORMAL" in attrs:
            nm = np.linalg.inv(world[:3, :3]).T
            normals = (nm @ self.gltf.accessor(attrs["NORMAL"])[:, :3].T).T
            normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
        uv = self.gltf.accessor(attrs["TEXCOORD_0"])[:, :2] if "TEXCOORD_0" in attrs else None
        if "COLOR_0" in attrs:
            warn(f"{name}: COLOR_0 is not read")
        bsdf, emission = self.material(prim.get("material"))
        props = mi.Properties()
        props["bsdf"] = mi.load_dict(bsdf)
        if emission is not None:
            props["emitter"] = mi.load_dict({"type": "area", "radiance": emission})
        mesh = mi.Mesh(name, len(p), len(idx) // 3, props=props,
                       has_vertex_normals=normals is not None, has_vertex_texcoords=uv is not None)
        params = mi.traverse(mesh)
        floats = type(params["vertex_positions"])  # the variant's dynamic float array
        params["vertex_positions"] = floats(p.astype(np.float32).ravel())
        params["faces"] = type(params["faces"])(idx.astype(np.uint32).ravel())
        if normals is not None:
            params["vertex_normals"] = floats(normals.astype(np.float32).ravel())
        if uv is not None:
            params["vertex_texcoords"] = floats(uv.astype(np.float32).ravel())
        params.update()
        return mesh

    def light(self, light, world):
        color = np.array(light.get("color", [1, 1, 1]), dtype=np.float64) * light.get("intensity", 1.0)
        value = {"type": "rgb", "value": color.tolist()}
        position = world[:3, 3]
        direction = world[:3, :3] @ np.array([0.0, 0.0, -1.0])
        kind = light.get("type")
        if kind == "point":
            return {"type": "point", "position": position.tolist(), "intensity": value}
        if kind == "directional":
            return {"type": "directional", "direction": direction.tolist(), "irradiance": value}
        if kind == "spot":
            spot = light.get("spot", {})
            cos_inner = math.cos(spot.get("innerConeAngle", 0.0))
            cos_outer = math.cos(spot.get("outerConeAngle", math.pi / 4))
            if self.brdf == "gltf":
                return {"type": "gltf_spot", "position": position.tolist(), "direction": direction.tolist(),
                        "intensity": color.tolist(), "cos_inner": cos_inner, "cos_outer": cos_outer}
            warn("a spot light's falloff is Mitsuba's (linear in angle), not glTF's (smooth in cosine)")
            up = np.array([0.0, 1.0, 0.0]) if abs(direction[1]) < 0.99 else np.array([1.0, 0.0, 0.0])
            return {"type": "spot", "intensity": value, "cutoff_angle": math.degrees(math.acos(cos_outer)),
                    "beam_width": math.degrees(math.acos(cos_inner)),
                    "to_world": self.mi.ScalarTransform4f().look_at(origin=position.tolist(),
                                                                    target=(position + direction).tolist(),
                                                                    up=up.tolist())}
        warn(f"light type {kind} is not read")
        return None


def register_gltf_bsdf(mi, min_roughness):
    """Registers `gltf`: glTF 2.0's metallic-roughness BRDF exactly as its
    specification's appendix B states it (Lambert diffuse weighted by
    1 - F, GGX with height-correlated Smith visibility, Schlick Fresnel at
    the half vector, F0 = 0.04 for the dielectric, the base colour for the
    metal, mixed by metallic), two-sided. Sampled as a mixture of the
    cosine-weighted hemisphere and GGX's distribution of normals; written
    from the specification, sharing nothing with ssbc's code."""
    import drjit as dr

    def parts(self, si, active):
        base = self.base.eval(si, active)
        metallic = dr.clip(self.metallic.eval_1(si, active), 0.0, 1.0)
        rough = dr.clip(self.roughness.eval_1(si, active), min_roughness, 1.0)
        return base, metallic, rough * rough

    def spec_probability(metallic):
        return 0.5 + 0.5 * metallic

    def ggx_d(alpha, cos_h):
        a2 = alpha * alpha
        t = cos_h * cos_h * (a2 - 1.0) + 1.0
        return a2 / (dr.pi * t * t)

    class GltfBsdf(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.base = props.get_texture("base_color")
            self.metallic = props.get_texture("metallic")
            self.roughness = props.get_texture("roughness")
            self.normals = props.get_texture("normalmap") if "normalmap" in props else None
            sides = mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide
            self.m_components = [mi.BSDFFlags.DiffuseReflection | sides, mi.BSDFFlags.GlossyReflection | sides]
            self.m_flags = self.m_components[0] | self.m_components[1]

        def _frame(self, si, active):
            """The shading frame: the interpolated normal, or the normal map's
            normal in glTF's tangent frame (tangent along +u, bitangent towards
            image-up, -v: MikkTSpace's on glTF's v-down uvs, so a mirrored uv
            mapping mirrors it), turned to the side wi is on (two-sided)."""
            n = si.sh_frame.n
            if self.normals is not None:
                m = self.normals.eval(si, active) * 2.0 - 1.0
                t = dr.normalize(si.dp_du - n * dr.dot(n, si.dp_du))
                mirrored = dr.dot(dr.cross(si.dp_du, si.dp_dv), n) > 0.0
                b = dr.cross(n, t) * dr.select(mirrored, -1.0, 1.0)
                mapped = dr.normalize(t * m.x + b * m.y + n * m.z)
                n = dr.select(dr.all(dr.isfinite(mapped)), mapped, n)
            n = dr.select(mi.Frame3f.cos_theta(si.wi) < 0.0, -n, n)
            return mi.Frame3f(n)

        def _eval_pdf(self, si, wo, active):
            base, metallic, alpha = parts(self, si, active)
            frame = self._frame(si, active)
            wi = frame.to_local(si.sh_frame.to_world(si.wi))
            wo = frame.to_local(si.sh_frame.to_world(wo))
            nv, nl = wi.z, wo.z
            ok = active & (nv > 0.0) & (nl > 0.0)
            h = dr.normalize(wi + wo)
            vh = dr.abs(dr.dot(wi, h))
            a2 = alpha * alpha
            d = ggx_d(alpha, h.z)
            vis = 0.5 / (nl * dr.sqrt(nv * nv * (1.0 - a2) + a2) + nv * dr.sqrt(nl * nl * (1.0 - a2) + a2))
            schlick = dr.power(1.0 - vh, 5.0)
            f_dielectric = 0.04 + 0.96 * schlick
            f_metal = base + (1.0 - base) * schlick
            diffuse = (1.0 - f_dielectric) * base * dr.inv_pi
            dielectric = diffuse + f_dielectric * vis * d
            metal = f_metal * vis * d
            value = ((1.0 - metallic) * dielectric + metallic * metal) * nl
            p = spec_probability(metallic)
            pdf = p * d * h.z / (4.0 * vh) + (1.0 - p) * nl * dr.inv_pi
            return dr.select(ok, value, 0.0), dr.select(ok, pdf, 0.0)

        def eval(self, ctx, si, wo, active=True):
            return self._eval_pdf(si, wo, active)[0]

        def pdf(self, ctx, si, wo, active=True):
            return self._eval_pdf(si, wo, active)[1]

        def eval_pdf(self, ctx, si, wo, active=True):
            return self._eval_pdf(si, wo, active)

        def sample(self, ctx, si, sample1, sample2, active=True):
            _, metallic, alpha = parts(self, si, active)
            frame = self._frame(si, active)
            wi = frame.to_local(si.sh_frame.to_world(si.wi))
            specular = sample1 < spec_probability(metallic)
            # GGX normals: tan^2(theta) = alpha^2 u / (1 - u).
            u = dr.minimum(sample2.x, 1.0 - 1e-7)
            cos2 = (1.0 - u) / (1.0 + (alpha * alpha - 1.0) * u)
            cos_h = dr.sqrt(cos2)
            sin_h = dr.sqrt(dr.maximum(1.0 - cos2, 0.0))
            phi = 2.0 * dr.pi * sample2.y
            h = mi.Vector3f(sin_h * dr.cos(phi), sin_h * dr.sin(phi), cos_h)
            reflected = 2.0 * dr.dot(wi, h) * h - wi
            wo = dr.select(specular, reflected, mi.warp.square_to_cosine_hemisphere(sample2))
            wo = si.sh_frame.to_local(frame.to_world(wo))
            value, pdf = self._eval_pdf(si, wo, active)
            bs = mi.BSDFSample3f()
            bs.wo = wo
            bs.pdf = pdf
            bs.eta = 1.0
            bs.sampled_type = dr.select(specular, mi.UInt32(+mi.BSDFFlags.GlossyReflection),
                                        mi.UInt32(+mi.BSDFFlags.DiffuseReflection))
            bs.sampled_component = dr.select(specular, mi.UInt32(1), mi.UInt32(0))
            weight = dr.select(pdf > 0.0, value / pdf, 0.0)
            return bs, weight

        def traverse(self, callback):
            pass

        def to_string(self):
            return "GltfBsdf[]"

    mi.register_bsdf("gltf", lambda props: GltfBsdf(props))

    class GltfSpot(mi.Emitter):
        """KHR_lights_punctual's spot: intensity (W/sr) x t^2,
        t = clamp((cos - cos_outer) / (cos_inner - cos_outer), 0, 1)."""

        def __init__(self, props):
            mi.Emitter.__init__(self, props)
            self.position = mi.Point3f(props["position"])
            self.direction = dr.normalize(mi.Vector3f(props["direction"]))
            self.intensity = mi.Color3f(props["intensity"])
            self.cos_inner = props["cos_inner"]
            self.cos_outer = props["cos_outer"]
            self.m_flags = mi.EmitterFlags.DeltaPosition

        def sample_direction(self, it, sample, active=True):
            d = self.position - it.p
            dist2 = dr.squared_norm(d)
            dist = dr.sqrt(dist2)
            ds = dr.zeros(mi.DirectionSample3f)
            ds.p = self.position
            ds.d = d / dist
            ds.dist = dist
            ds.pdf = 1.0
            ds.delta = True
            ds.emitter = mi.EmitterPtr(self)
            t = dr.clip((dr.dot(-ds.d, self.direction) - self.cos_outer)
                        / dr.maximum(self.cos_inner - self.cos_outer, 1e-4), 0.0, 1.0)
            return ds, self.intensity * (t * t / dist2)

        def pdf_direction(self, it, ds, active=True):
            return 0.0

        def eval_direction(self, it, ds, active=True):
            return 0.0

        def eval(self, si, active=True):
            return 0.0  # a point: no ray hits it

        def traverse(self, callback):
            pass

        def to_string(self):
            return "GltfSpot[]"

    mi.register_emitter("gltf_spot", lambda props: GltfSpot(props))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("-o", "--output", default="mitsuba.exr")
    ap.add_argument("--size", default="160x120")
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--max-depth", type=int, default=65, help="Mitsuba's max_depth (65 = 64 bounces)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--brdf", choices=["gltf", "principled", "lambertian"], default="gltf",
                    help="gltf: appendix B exactly (a Python plugin; needs an LLVM variant); principled: Mitsuba's "
                         "Disney-style BSDF (close to glTF's, not equal); lambertian: every material diffuse")
    ap.add_argument("--min-roughness", type=float, default=0.05,
                    help="perceptual roughness floor of the gltf BRDF (ssbc's, docs/conventions.md)")
    ap.add_argument("--variant", default=None,
                    help="Mitsuba variant (default llvm_ad_rgb for gltf, else scalar_rgb); llvm variants need "
                         "libLLVM >= 16 (DRJIT_LIBLLVM_PATH)")
    args = ap.parse_args()
    if "DRJIT_LIBLLVM_PATH" not in os.environ:
        # Dr.Jit's LLVM backend needs libLLVM >= 16 (Debian 12: apt install libllvm19).
        import glob, re
        found = sorted(glob.glob("/usr/lib/*/libLLVM*.so*") + glob.glob("/usr/lib/llvm-*/lib/libLLVM*.so*"),
                       key=lambda p: [int(x) for x in re.findall(r"\d+", os.path.basename(p))[:1] or [0]])
        if found:
            os.environ["DRJIT_LIBLLVM_PATH"] = found[-1]
    try:
        import mitsuba as mi
    except ImportError:
        sys.exit("mitsuba-reference: Mitsuba 3 is not installed (pip install mitsuba)")
    variant = args.variant or ("llvm_ad_rgb" if args.brdf == "gltf" else "scalar_rgb")
    try:
        mi.set_variant(variant)
    except Exception as e:  # noqa: BLE001 (Dr.Jit reports a missing LLVM in several ways)
        sys.exit(f"mitsuba-reference: Mitsuba's {variant} variant is unavailable ({e}); the gltf BRDF needs "
                 "libLLVM >= 16 (Debian 12: apt install libllvm19, or set DRJIT_LIBLLVM_PATH)")
    if args.brdf == "gltf":
        register_gltf_bsdf(mi, args.min_roughness)
    width, height = (int(v) for v in args.size.lower().split("x"))

    gltf = Gltf(args.scene)
    conv = Converter(mi, gltf, args.brdf)
    doc = gltf.doc
    lights = doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    scene = {"type": "scene"}
    camera = None
    for n, world in walk(gltf):
        node = doc["nodes"][n]
        if "mesh" in node:
            if "skin" in node:
                warn(f"node {n}: skins are not applied")
            for k, prim in enumerate(doc["meshes"][node["mesh"]]["primitives"]):
                mesh = conv.mesh(f"node{n}_prim{k}", prim, world)
                if mesh is not None:
                    scene[f"node{n}_prim{k}"] = mesh
        if "camera" in node and camera is None:
            camera = (doc["cameras"][node["camera"]], world)
        ext = node.get("extensions", {}).get("KHR_lights_punctual")
        if ext is not None:
            light = conv.light(lights[ext["light"]], world)
            if light is not None:
                scene[f"light{n}"] = light
    # `path` tests shadow rays against the geometry only; `volpath` lets
    # them through the cut-out parts of alpha masks (null interactions).
    integrator = "volpath" if conv.masked else "path"
    scene["integrator"] = {"type": integrator, "max_depth": args.max_depth, "hide_emitters": False}
    if camera is None:
        sys.exit("mitsuba-reference: the scene has no camera (ssbc's default camera is not reproduced)")
    cam, world = camera
    if cam.get("type") != "perspective":
        sys.exit("mitsuba-reference: only perspective cameras are read")
    to_world = world @ np.diag([-1.0, 1.0, -1.0, 1.0])
    # Mitsuba's camera looks down +z with +x to the left; glTF's down -z, +x right.
    scene["sensor"] = {
        "type": "perspective",
        "fov_axis": "y",
        "fov": math.degrees(cam["perspective"]["yfov"]),
        "near_clip": cam["perspective"].get("znear", 0.01),
        "to_world": mi.ScalarTransform4f(to_world.tolist()),
        "sampler": {"type": "independent", "sample_count": args.spp, "seed": args.seed},
        "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"},
                 "pixel_format": "rgb"},
    }
    image = mi.render(mi.load_dict(scene), spp=args.spp, seed=args.seed)
    mi.Bitmap(image).write(args.output)


if __name__ == "__main__":
    main()
