// Materials in the G-buffer and shadow-map shaders; the CPU twin is
// src/cpu/shading.rs. Textures live in two arrays of one size each (colour,
// sRGB; normal maps, linear) and are sampled by hand so that every glTF
// sampler's wrap modes and filter are honoured without one Vulkan sampler
// per combination. Needs `color_textures` (and, for normal maps,
// `linear_textures`) declared before inclusion.

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

vec4 fetch_wrapped(sampler2DArray tex, int layer, ivec2 size, ivec2 t, int bits) {
    ivec2 w = ivec2(wrap_texel(t.x, size.x, bits & 3), wrap_texel(t.y, size.y, (bits >> 2) & 3));
    return texelFetch(tex, ivec3(w, layer), 0);
}

// Layer `layer` of `tex` at `uv` (texel centres at (i + 0.5) / size).
vec4 sample_texture(sampler2DArray tex, int layer, int bits, vec2 uv) {
    ivec2 size = textureSize(tex, 0).xy;
    vec2 p = uv * vec2(size) - 0.5;
    if (any(isnan(p)) || any(isinf(p))) p = vec2(0.0);
    if ((bits & 16) != 0) {
        return fetch_wrapped(tex, layer, size, ivec2(floor(p + 0.5)), bits);
    }
    ivec2 t0 = ivec2(floor(p));
    vec2 f = p - floor(p);
    vec4 top = mix(fetch_wrapped(tex, layer, size, t0, bits), fetch_wrapped(tex, layer, size, t0 + ivec2(1, 0), bits), f.x);
    vec4 bottom = mix(fetch_wrapped(tex, layer, size, t0 + ivec2(0, 1), bits), fetch_wrapped(tex, layer, size, t0 + ivec2(1, 1), bits), f.x);
    return mix(top, bottom, f.y);
}

// Linear albedo and alpha.
vec4 material_base_color(GpuMaterial m, vec2 uv) {
    vec4 c = m.base_color;
    if (m.textures.x >= 0) c *= sample_texture(color_textures, m.textures.x, m.samplers.x, uv);
    return c;
}

// Whether the surface exists here (alpha mask).
bool material_opaque(GpuMaterial m, vec2 uv) {
    return m.emission_cutoff.w < 0.0 || material_base_color(m, uv).a >= m.emission_cutoff.w;
}

vec3 material_emission(GpuMaterial m, vec2 uv) {
    vec3 e = m.emission_cutoff.rgb;
    if (m.textures.y >= 0 && any(greaterThan(e, vec3(0.0)))) {
        e *= sample_texture(color_textures, m.textures.y, m.samplers.y, uv).rgb;
    }
    return e;
}

bool material_double_sided(GpuMaterial m) {
    return (m.textures.w & 1) != 0;
}

#endif
