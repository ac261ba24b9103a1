#version 460
// The interleaved gather's exception: pixels beside a crease or contact
// (indirect_filter.comp lists them) evaluate every VPL themselves. There
// the bounded lighting changes within a pixel (the geometry term of VPLs
// on the adjoining surface drops to zero at the crease line), so sums
// borrowed from neighbours, however close, would be wrong. Overwrites
// indirect_bounded and S0 at those pixels.
#include "common.glsl"
#include "ism.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D g_normal;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D g_albedo;
layout(set = 0, binding = 3, rgba32f) uniform readonly image2D direct;
layout(set = 0, binding = 4, rgba32f) uniform writeonly image2D indirect_bounded;
layout(set = 0, binding = 5, rgba32f) uniform writeonly image2D s0;
layout(set = 0, binding = 6) uniform samplerBuffer vpl_texels;
layout(set = 0, binding = 7, r32ui) uniform readonly uimage2D ism; // distance bits / far
// (dispatch x, y, z, count), then x | y << 16 per pixel.
layout(set = 0, binding = 8) readonly buffer Creases { uvec4 header; uint pixels[]; } creases;
layout(set = 0, binding = 9, rgba32f) uniform readonly image2D direct_diffuse;
layout(set = 0, binding = 10, rgba32f) uniform writeonly image2D s0_diffuse;

layout(push_constant) uniform Push {
    uvec2 size;
    uint vpl_count;
    uint tile;
    uint tiles_per_row;
    float far;
    float bound;
    float ism_bias;
    float point_radius;
    vec4 camera_position; // xyz: the eye
} pc;

#include "vpl_gather.glsl"

void main() {
    uint item = gl_GlobalInvocationID.x;
    if (item >= creases.header.w) return;
    uint packed = creases.pixels[item];
    ivec2 pixel = ivec2(packed & 0xFFFFu, packed >> 16);
    vec3 x = imageLoad(g_position, pixel).xyz;
    vec4 n = imageLoad(g_normal, pixel);
    Brdf b = brdf_from_gbuffer(imageLoad(g_albedo, pixel), n);
    vec3 wo = normalize(pc.camera_position.xyz - x);
    VplLight light = vpl_sum(x, n.xyz, b, wo, 0u, pc.vpl_count);
    vec3 diffuse = brdf_diffuse_color(b) / PI * light.irradiance;
    vec3 radiance = diffuse + light.glossy;
    imageStore(indirect_bounded, pixel, vec4(radiance, 1.0));
    imageStore(s0, pixel, vec4(imageLoad(direct, pixel).rgb + radiance, 1.0));
    imageStore(s0_diffuse, pixel, vec4(imageLoad(direct_diffuse, pixel).rgb + diffuse, 1.0));
}
