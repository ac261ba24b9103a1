// Shared GPU structs. Each has a #[repr(C)] twin in src/gpu_types.rs; the test
// `gpu_types_match_glsl` checks the sizes and field order stay in step.

#ifndef SSBC_COMMON_GLSL
#define SSBC_COMMON_GLSL

// Buffers read as texels are `textureBuffer`s fetched without a sampler: a
// `samplerBuffer` is an OpTypeSampledImage of Dim Buffer, which SPIR-V 1.6
// forbids (Vulkan 1.4 validation flags it).
#extension GL_EXT_samplerless_texture_functions : require

const float PI = 3.14159265358979;

// Three channels in 56 bits: signed 16-bit mantissas under the largest
// channel's exponent (within 2^-15 of it, with f32's range: the sums are in
// physical units, which overflow halves at bright emitters, and the glossy
// rest may be negative); x: r | g << 16, y: b | exponent << 16, y's top
// byte free. Non-finite sums are 0. Powers of two from exponent bits
// (ldexp and frexp cost lavapipe calls).
uvec2 pack_rgb56(vec3 v) {
    float largest = max(max(abs(v.r), abs(v.g)), abs(v.b));
    if (!(largest > 0.0) || isinf(largest)) return uvec2(0u);
    // largest = f 2^e with f in [0.5, 1).
    int e = clamp(int(floatBitsToUint(largest) >> 23) - 126, -110, 128);
    float to_mantissa = uintBitsToFloat(uint(142 - e) << 23);  // 2^(15 - e)
    uvec3 m = uvec3(ivec3(clamp(round(v * to_mantissa), vec3(-32767.0), vec3(32767.0)))) & 0xFFFFu;
    return uvec2(m.r | (m.g << 16), m.b | (uint(e + 110) << 16));
}

vec3 unpack_rgb56(uvec2 w) {
    ivec3 m = ivec3(bitfieldExtract(int(w.x), 0, 16), bitfieldExtract(int(w.x), 16, 16), bitfieldExtract(int(w.y), 0, 16));
    int e = int((w.y >> 16) & 255u) - 110;
    return vec3(m) * uintBitsToFloat(uint(e + 112) << 23);  // 2^(e - 15)
}

// The G-buffer's normal and albedo images are R32G32_UINT, two words a
// pixel (src/passes/gbuffer.rs): the normal's xyz and its w (the roughness,
// -1 for Lambertian) as four snorm16, the albedo's rgb and its w (the
// metallic) as four unorm16 (an albedo above 1 is clamped). 16 bytes a
// pixel less than RGBA32F for both; snorm16 puts a unit normal within
// 2^-15 per component, which unpack_gbuffer_normal renormalises.
uvec2 pack_gbuffer_normal(vec4 n) {
    return uvec2(packSnorm2x16(n.xy), packSnorm2x16(n.zw));
}

vec4 unpack_gbuffer_normal(uvec4 words) {
    vec4 n = vec4(unpackSnorm2x16(words.x), unpackSnorm2x16(words.y));
    float l2 = dot(n.xyz, n.xyz);
    return vec4(l2 > 0.0 ? n.xyz * inversesqrt(l2) : n.xyz, n.w);
}

uvec2 pack_gbuffer_albedo(vec4 a) {
    return uvec2(packUnorm2x16(a.xy), packUnorm2x16(a.zw));
}

vec4 unpack_gbuffer_albedo(uvec4 words) {
    return vec4(unpackUnorm2x16(words.x), unpackUnorm2x16(words.y));
}

const uint LIGHT_POINT = 0u;
const uint LIGHT_SPOT = 1u;
const uint LIGHT_DIRECTIONAL = 2u;

// A punctual light in radiometric units (W/sr, or W/m^2 for directional).
struct GpuLight {
    vec4 position_kind;       // xyz position, w kind (LIGHT_*)
    vec4 direction_cos_outer; // xyz unit direction light travels, w cos(outer cone)
    vec4 intensity_cos_inner; // rgb intensity, w cos(inner cone)
    ivec4 shadow;             // x first shadow-map layer, y layer count
};

// One shadow-map layer: its projection and how to linearise its depth.
struct ShadowView {
    mat4 view_proj;
    vec4 params;              // x near, y far, z 1 = orthographic, w texel size at unit distance (or absolute, ortho)
};

// Lambertian material, possibly emissive, alpha-masked, normal-mapped
// (material.glsl evaluates it).
// An object: how its mesh's vertices and ISM points reach world space.
struct GpuObject {
    mat4 model;               // object to world
    mat4 normal_matrix;       // inverse transpose of model's linear part (normals)
    uvec4 params;             // x material override (0xFFFFFFFF: the mesh's own), y visible,
                              // z handedness bits (-1.0 for a mirror, else 1.0), w its mesh
};

struct GpuMaterial {
    vec4 base_color;          // rgb linear albedo factor, a alpha factor
    vec4 emission_cutoff;     // rgb emitted radiance W/(m^2 sr), w alpha cutoff (< 0: opaque)
    ivec4 textures;           // layers: x base colour, y emissive (colour array), z normal map
                              // (linear array); -1: none; w bit 0: double-sided, bits 1..:
                              // metallic-roughness map's layer + 1 (linear array; 0: none)
    ivec4 samplers;           // x, y, z, w: sampler of each texture (bits 0-1 wrap s,
                              // 2-3 wrap t: 0 repeat, 1 clamp, 2 mirror; bit 4 nearest)
    vec4 normal;              // x normal-map scale, y metallic, z roughness, w specular
                              // layer (1: glTF metallic-roughness, 0: Lambertian)
    vec4 uv_linear[3];        // where the emissive, normal and metallic-roughness maps are
                              // read: linear part of each one's map of uv, columns xy, zw
    vec4 uv_offsets[2];       // their offsets: [0].xy emissive, [0].zw normal, [1].xy
                              // metallic-roughness
};

#endif
