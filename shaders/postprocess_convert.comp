#version 460
// SSBC as a post-process: the host's G-buffer in its own formats into the
// RGBA32F inputs SSBC's kernels read. Everything is read through sampling,
// so sRGB, UNORM/SNORM and packed formats arrive decoded by the sampler;
// here depth becomes a world position and packed normals unit vectors.
// (src/postprocess/convert.rs; the accepted formats: docs/embedding.md.)
#include "common.glsl"
#include "octahedral.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

// Hardware depth (r) or world position (xyz, w = 0 off geometry).
layout(set = 0, binding = 0) uniform sampler2D host_geometry;
layout(set = 0, binding = 1) uniform sampler2D host_normal;
layout(set = 0, binding = 2) uniform sampler2D host_albedo;
layout(set = 0, binding = 3) uniform sampler2D host_s0;
// The host's sources if pc.sources, else host_s0 again (not read).
layout(set = 0, binding = 4) uniform sampler2D host_sources;
layout(set = 0, binding = 5, rgba32f) uniform writeonly image2D g_position;
layout(set = 0, binding = 6, rg32ui) uniform writeonly uimage2D g_normal;
layout(set = 0, binding = 7, rg32ui) uniform writeonly uimage2D g_albedo;
layout(set = 0, binding = 8, rgba32f) uniform writeonly image2D s0;
// Written if pc.sources (else s0 again).
layout(set = 0, binding = 9, rgba32f) uniform writeonly image2D sources;

const uint GEOMETRY_POSITION = 0u;
const uint GEOMETRY_DEPTH = 1u;

const uint NORMAL_SIGNED = 0u;              // xyz as stored
const uint NORMAL_UNSIGNED = 1u;            // xyz * 2 - 1
const uint NORMAL_OCTAHEDRAL = 2u;          // xy, octahedral in [-1, 1]
const uint NORMAL_OCTAHEDRAL_UNSIGNED = 3u; // xy * 2 - 1, octahedral

layout(push_constant) uniform ConvertPush {
    mat4 inverse_view_projection;   // clip to world (GEOMETRY_DEPTH)
    uvec2 size;
    uint geometry;                  // GEOMETRY_*
    uint normals;                   // NORMAL_*
    float background_depth;         // depth where there is no geometry
    uint sources;                   // 1: host_sources -> sources
} pc;

vec4 position_at(ivec2 p) {
    vec4 g = texelFetch(host_geometry, p, 0);
    if (pc.geometry == GEOMETRY_POSITION) return g;
    if (g.r == pc.background_depth) return vec4(0.0);
    // Vulkan's clip space: the pixel centre's x, y in [-1, 1], y down.
    vec2 ndc = (vec2(p) + 0.5) / vec2(pc.size) * 2.0 - 1.0;
    vec4 h = pc.inverse_view_projection * vec4(ndc, g.r, 1.0);
    vec3 x = h.xyz / h.w;
    bool finite = !any(isinf(x)) && !any(isnan(x)) && h.w != 0.0;
    return finite ? vec4(x, 1.0) : vec4(0.0);
}

vec4 normal_at(ivec2 p) {
    vec4 t = texelFetch(host_normal, p, 0);
    vec3 n;
    switch (pc.normals) {
    case NORMAL_UNSIGNED: n = t.xyz * 2.0 - 1.0; break;
    case NORMAL_OCTAHEDRAL: return vec4(from_octahedral(t.xy), 0.0);
    case NORMAL_OCTAHEDRAL_UNSIGNED: return vec4(from_octahedral(t.xy * 2.0 - 1.0), 0.0);
    default: n = t.xyz; break;
    }
    // Quantised normals are a little off unit length; w carries on (the
    // roughness of glossy receivers).
    float l = length(n);
    return vec4(l > 0.0 ? n / l : n, t.w);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(p), pc.size))) return;
    imageStore(g_position, p, position_at(p));
    imageStore(g_normal, p, uvec4(pack_gbuffer_normal(normal_at(p)), 0u, 0u));
    imageStore(g_albedo, p, uvec4(pack_gbuffer_albedo(texelFetch(host_albedo, p, 0)), 0u, 0u));
    imageStore(s0, p, vec4(texelFetch(host_s0, p, 0).rgb, 1.0));
    if (pc.sources != 0u) imageStore(sources, p, vec4(texelFetch(host_sources, p, 0).rgb, 1.0));
}
