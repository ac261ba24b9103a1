#version 460
// SSBC as a post-process: a layer's RGBA32F normal and albedo, which SSBC
// otherwise reads in place (the first layer when nothing is converted, the
// second layer always), packed into the two-word images SSBC's kernels read
// (pack_gbuffer_normal / pack_gbuffer_albedo, common.glsl).
// (src/postprocess/convert.rs.)
#include "common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D host_normal;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D host_albedo;
layout(set = 0, binding = 2, rg32ui) uniform writeonly uimage2D g_normal;
layout(set = 0, binding = 3, rg32ui) uniform writeonly uimage2D g_albedo;

layout(push_constant) uniform PackPush {
    uvec2 size;
} pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(p), pc.size))) return;
    imageStore(g_normal, p, uvec4(pack_gbuffer_normal(imageLoad(host_normal, p)), 0u, 0u));
    imageStore(g_albedo, p, uvec4(pack_gbuffer_albedo(imageLoad(host_albedo, p)), 0u, 0u));
}
