// Materials in the G-buffer and shadow-map shaders; the CPU twin is
// src/cpu/shading.rs. Textures live in two arrays of one size each (colour,
// sRGB; normal maps, linear) and are sampled by hand so that every glTF
// sampler's wrap modes and filter are honoured without one Vulkan sampler
// per combination; minified textures are averaged over the pixel's
// footprint from mipmaps (src/texture_mips.rs). Needs `color_textures`
// (and, for normal maps, `linear_textures`) declared before inclusion.

#ifndef SSBC_MATERIAL_GLSL
#define SSBC_MATERIAL_GLSL

#include "common.glsl"

const int WRAP_REPEAT = 0;
const int WRAP_CLAMP = 1;
const int WRAP_MIRROR = 2;

int wrap_texel(int i, int n, int mode) {
    if (mode == WRAP_CLAMP) return clamp(i, 0, n - 1);
    if (mode == WRAP_MIRROR) {
        int period = ((i % (2 * n)) + 2 * n) % (2 * n);
        return period < n ? period : 2 * n - 1 - period;
    }
    return ((i % n) + n) % n;
}

vec4 fetch_wrapped(sampler2DArray tex, int layer, int level, ivec2 size, ivec2 t, int bits) {
    ivec2 w = ivec2(wrap_texel(t.x, size.x, bits & 3), wrap_texel(t.y, size.y, (bits >> 2) & 3));
    // The sampler is nearest: this is texel w of `level`. (texelFetch with
    // a level that differs between lanes read zeros on llvmpipe.)
    return textureLod(tex, vec3((vec2(w) + 0.5) / vec2(size), float(layer)), float(level));
}

// Mip `level` of layer `layer` at `uv` (texel centres at (i + 0.5) / size),
// bilinear or nearest.
vec4 sample_level(sampler2DArray tex, int layer, int bits, vec2 uv, int level, bool nearest) {
    ivec2 size = textureSize(tex, level).xy;
    vec2 p = uv * vec2(size) - 0.5;
    if (any(isnan(p)) || any(isinf(p))) p = vec2(0.0);
    if (nearest) return fetch_wrapped(tex, layer, level, size, ivec2(floor(p + 0.5)), bits);
    ivec2 t0 = ivec2(floor(p));
    vec2 f = p - floor(p);
    vec4 top = mix(fetch_wrapped(tex, layer, level, size, t0, bits), fetch_wrapped(tex, layer, level, size, t0 + ivec2(1, 0), bits), f.x);
    vec4 bottom = mix(fetch_wrapped(tex, layer, level, size, t0 + ivec2(0, 1), bits), fetch_wrapped(tex, layer, level, size, t0 + ivec2(1, 1), bits), f.x);
    return mix(top, bottom, f.y);
}

// Most taps along a footprint's longer side (anisotropy beyond this is
// filtered by a coarser level, i.e. blurred along the shorter side too).
const float MAX_FOOTPRINT_TAPS = 4.0;

// The mean of layer `layer` of `tex` over a pixel's footprint around `uv`:
// the parallelogram spanned by `duv_dx` and `duv_dy` (uv's derivatives along
// the screen's axes; zero for a point sample, as the CPU twin takes).
// Minified: taps spaced evenly along the longer side, each trilinear from
// the level whose texels are as wide as the spacing or the shorter side.
// Magnified: one tap at full resolution, with the sampler's filter.
vec4 sample_texture(sampler2DArray tex, int layer, int bits, vec2 uv, vec2 duv_dx, vec2 duv_dy) {
    vec2 size = vec2(textureSize(tex, 0).xy);
    // Derivatives that are not finite (a degenerate uv mapping): a point.
    vec4 d = vec4(duv_dx, duv_dy);
    if (any(isnan(d)) || any(isinf(d))) return sample_level(tex, layer, bits, uv, 0, (bits & 16) != 0);
    vec2 ax = duv_dx * size;
    vec2 ay = duv_dy * size;
    float lx = length(ax), ly = length(ay);
    float longer = max(lx, ly), shorter = min(lx, ly);
    if (!(longer > 1.0)) {
        return sample_level(tex, layer, bits, uv, 0, (bits & 16) != 0);
    }
    vec2 along = lx >= ly ? duv_dx : duv_dy;
    float taps = min(ceil(longer / max(shorter, 1.0)), MAX_FOOTPRINT_TAPS);
    float lod = clamp(log2(max(longer / taps, shorter)), 0.0, float(textureQueryLevels(tex) - 1));
    int level = int(lod);
    float f = lod - float(level);
    vec4 sum = vec4(0.0);
    for (float i = 0.5; i < taps; i += 1.0) {
        vec2 at = uv + along * (i / taps - 0.5);
        vec4 c = sample_level(tex, layer, bits, at, level, false);
        if (f > 0.0) c = mix(c, sample_level(tex, layer, bits, at, level + 1, false), f);
        sum += c;
    }
    return sum / taps;
}

// Linear albedo and alpha, averaged over a footprint (see sample_texture),
// times the interpolated vertex colour (glTF's COLOR_0, white without).
vec4 material_base_color(GpuMaterial m, vec2 uv, vec2 duv_dx, vec2 duv_dy, vec4 vertex_color) {
    vec4 c = m.base_color * vertex_color;
    if (m.textures.x >= 0) c *= sample_texture(color_textures, m.textures.x, m.samplers.x, uv, duv_dx, duv_dy);
    return c;
}

// Whether the surface exists here (alpha mask), at the point `uv` as the
// CPU's visibility tests it: averaging alpha would thin cut-outs away.
bool material_opaque(GpuMaterial m, vec2 uv, vec4 vertex_color) {
    return m.emission_cutoff.w < 0.0
        || material_base_color(m, uv, vec2(0.0), vec2(0.0), vertex_color).a >= m.emission_cutoff.w;
}

// Which of a material's textures is read at its own map of the mesh's uv
// (TextureRef::uv; the base colour is read at the mesh's uv).
const int UV_EMISSIVE = 0;
const int UV_NORMAL = 1;
const int UV_REFLECTANCE = 2;

// Texture k's coordinates and footprint (uv and its derivatives, mapped
// in place).
void map_uv(GpuMaterial m, int k, inout vec2 uv, inout vec2 duv_dx, inout vec2 duv_dy) {
    mat2 linear = mat2(m.uv_linear[k].xy, m.uv_linear[k].zw);
    vec2 offset = k == UV_EMISSIVE ? m.uv_offsets[0].xy : (k == UV_NORMAL ? m.uv_offsets[0].zw : m.uv_offsets[1].xy);
    uv = linear * uv + offset;
    duv_dx = linear * duv_dx;
    duv_dy = linear * duv_dy;
}

vec3 material_emission(GpuMaterial m, vec2 uv, vec2 duv_dx, vec2 duv_dy) {
    vec3 e = m.emission_cutoff.rgb;
    if (m.textures.y >= 0 && any(greaterThan(e, vec3(0.0)))) {
        map_uv(m, UV_EMISSIVE, uv, duv_dx, duv_dy);
        e *= sample_texture(color_textures, m.textures.y, m.samplers.y, uv, duv_dx, duv_dy).rgb;
    }
    return e;
}

bool material_double_sided(GpuMaterial m) {
    return (m.textures.w & 1) != 0;
}

#endif
