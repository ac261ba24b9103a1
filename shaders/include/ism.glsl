// Imperfect shadow maps (Ritschel et al. 2008): one paraboloid depth tile per
// VPL, oriented along the VPL normal, in one atlas.
#ifndef SSBC_ISM_GLSL
#define SSBC_ISM_GLSL

// A VPL (mirrors GpuVpl in src/gpu_types.rs). The gathers read it as five
// RGBA32F texels (vpl_gather.glsl), the splat as a struct.
struct GpuVpl {
    vec4 position;   // xyz position; w: bits of its ISM point block (uint)
    vec4 normal;     // xyz unit normal (hemisphere it emits into); w: bits of
                     // its atlas tile's column | row << 16 (uint)
    vec4 power;      // rgb: Lambertian: albedo x flux Phi [W] (f_r(z) Phi x pi); glossy:
                     // Phi. w: -1 Lambertian, -2 Lambertian with a shading
                     // normal (in incident.xyz), else metallic
    vec4 base;       // glossy: rgb base colour, w roughness
    vec4 incident;   // glossy: xyz direction the light arrived from (lobe
                     // turned to the shading normal's); Lambertian with -2:
                     // its shading normal; w: radius (m), which widens
                     // glossy lobes towards and from it
};

#include "octahedral.glsl"

// A unit normal in 32 bits (pack_normal in src/cpu/points.rs): its
// octahedral map, 15 bits a coordinate, the top bit set (0: no normal).
uint ism_pack_normal(vec3 n) {
    uvec2 q = uvec2(round(clamp(octahedral(n) * 0.5 + 0.5, 0.0, 1.0) * 32767.0));
    return 0x80000000u | (q.x << 15) | q.y;
}

vec3 ism_unpack_normal(uint bits) {
    vec2 e = vec2(uvec2((bits >> 15) & 32767u, bits & 32767u)) * (2.0 / 32767.0) - 1.0;
    return from_octahedral(e);
}

// Texels per GpuVpl in the gathers' texel view.
const uint VPL_TEXELS = 5u;

// Orthonormal basis around n (Duff et al. 2017); matches cpu::sampling::basis.
void ism_basis(vec3 n, out vec3 t, out vec3 b) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
    b = vec3(c, s + n.y * n.y * a, -n.y);
}

// Paraboloid coordinates in [0,1]^2 of unit direction w leaving a VPL with
// normal n; w must lie in the upper hemisphere.
vec2 ism_paraboloid(vec3 w, vec3 n) {
    vec3 t, b;
    ism_basis(n, t, b);
    vec3 l = vec3(dot(w, t), dot(w, b), dot(w, n));
    return l.xy / (1.0 + l.z) * 0.5 + 0.5;
}

// Texel of the atlas at paraboloid coordinate uv in the tile whose column
// and row are packed in `cell` (GpuVpl.normal.w).
ivec2 ism_texel(uint cell, vec2 uv, uint tile) {
    ivec2 origin = ivec2(cell & 0xFFFFu, cell >> 16) * int(tile);
    ivec2 local = clamp(ivec2(uv * float(tile)), ivec2(0), ivec2(int(tile) - 1));
    return origin + local;
}

// Unit direction leaving a VPL with normal n through paraboloid coordinate
// uv (the inverse of ism_paraboloid; paraboloid_direction in
// src/cpu/ism_rays.rs).
vec3 ism_direction(vec3 n, vec2 uv) {
    vec2 p = uv * 2.0 - 1.0;
    float r2 = min(dot(p, p), 0.998);
    p *= inversesqrt(max(dot(p, p), 1e-12)) * sqrt(r2);
    float z = (1.0 - r2) / (1.0 + r2);
    vec2 xy = p * (1.0 + z);
    vec3 t, b;
    ism_basis(n, t, b);
    return t * xy.x + b * xy.y + n * z;
}

// The direction through the centre of texel `local` of a tile.
vec3 ism_texel_direction(vec3 n, ivec2 local, uint tile) {
    return ism_direction(n, (vec2(local) + 0.5) / float(tile));
}

// An atlas texel: the surface nearest the VPL at the texel's centre, as a
// plane. High 16 bits: the distance at which the texel's centre ray meets
// the plane (/ far, below ISM_DEPTH_RANGE), so that atomicMin keeps the
// nearest; low 16: the plane's normal (octahedral, 8 bits a coordinate; 0:
// not known, the distance is then the surface's own). The test evaluates
// the plane along the receiver's own ray (ism_plane_depth): a surface is
// compared with itself exactly wherever it is flat, instead of with the
// nearest of it anywhere in the texel, which needed a tolerance of the
// texel's footprint times the surface's slope and let light through walls
// thinner than that (issue 61: 22-30% of the occluded light).
const float ISM_DEPTH_RANGE = 4.0;
const float ISM_DEPTH_STEPS = 65535.0;

uint ism_pack_plane_normal(vec3 n) {
    uvec2 q = uvec2(round(clamp(octahedral(n) * 0.5 + 0.5, 0.0, 1.0) * 255.0));
    return max((q.x << 8) | q.y, 1u);
}

uint ism_pack(float depth, uint normal_code) {
    float q = clamp(depth * (ISM_DEPTH_STEPS / ISM_DEPTH_RANGE), 0.0, ISM_DEPTH_STEPS);
    return (uint(q) << 16) | normal_code;
}

float ism_texel_depth(uint texel) {
    return float(texel >> 16) * (ISM_DEPTH_RANGE / ISM_DEPTH_STEPS);
}

bool ism_texel_has_plane(uint texel) {
    return (texel & 0xFFFFu) != 0u;
}

vec3 ism_texel_normal(uint texel) {
    vec2 e = vec2(uvec2((texel >> 8) & 255u, texel & 255u)) * (2.0 / 255.0) - 1.0;
    return from_octahedral(e);
}

// Where the ray along unit `w` meets the plane of normal `normal` that the
// ray along `wc` meets at `depth`; a plane the ray runs along (within a
// 50th of a radian) or away from does not stop it.
float ism_plane_depth(float depth, vec3 normal, vec3 wc, vec3 w) {
    float a = dot(normal, wc);
    float b = dot(normal, w);
    return a * b > 0.0 && abs(b) > 0.02 ? depth * a / b : 1e30;
}

// tan of the angle whose cosine is c, c clamped to [0.1, 1].
float ism_slope(float c) {
    c = clamp(c, 0.1, 1.0);
    return sqrt(1.0 - c * c) / c;
}

// Depth tolerance [m] of the test against a texel without a plane (the
// ray-cast layer where its rays met nothing): the depth change of the
// receiver's surface across a footprint at its slope, as before planes.
float ism_footprint_tolerance(float dist, float cos_x, uint tile, float point_radius, float relative_bias) {
    float footprint = max(dist * 4.0 / float(tile), point_radius);
    return relative_bias * dist + footprint * ism_slope(cos_x) + 1e-3;
}

// Depth tolerance [m] of the test against a texel's plane, for a receiver
// of normal `receiver` (unit): a relative bias, and what a curved surface
// departs from the plane of another of its points: over a lateral offset s
// its normal turns by an angle a = s / R and it falls s a / 2 behind the
// plane, s at most a texel's footprint and a point's radius (the splat).
// Up to 60 degrees of turn; beyond, the plane is another surface, and the
// receiver lies behind it or not.
float ism_plane_tolerance(float dist, vec3 receiver, vec3 stored, uint tile, float point_radius, float relative_bias) {
    float reach = dist * 4.0 / float(tile) + point_radius;
    float c = abs(dot(receiver, stored));
    // The chord of the turn (its angle to within 5% up to 60 degrees).
    float curve = c > 0.5 ? 0.5 * reach * sqrt(max(2.0 - 2.0 * c, 0.0)) : 0.0;
    return relative_bias * dist + curve + 1e-3;
}

#endif
