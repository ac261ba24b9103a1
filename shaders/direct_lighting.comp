#version 460
// Deferred direct lighting T Le: every punctual light, shadowed by its
// shadow map; plus Le, the radiance emissive surfaces send to the camera.
// Also its diffuse, view-independent part (what SSBC's sources send).
#include "common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D g_normal;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D g_albedo;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D direct;
layout(set = 0, binding = 4) readonly buffer Lights { GpuLight lights[]; };
layout(set = 0, binding = 5) readonly buffer ShadowViews { ShadowView shadow_views[]; };
layout(set = 0, binding = 6) uniform sampler2DArray shadow_maps;
layout(set = 0, binding = 7, rgba32f) uniform readonly image2D g_emission;
layout(set = 0, binding = 8, rgba32f) uniform writeonly image2D direct_diffuse;

layout(push_constant) uniform Push {
    uvec2 size;
    uint light_count;
    vec4 camera_position;   // xyz: the eye, which glossy surfaces reflect towards
} pc;

#include "shadow.glsl"

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(pixel), pc.size))) return;
    vec4 position = imageLoad(g_position, pixel);
    if (position.w == 0.0) {
        imageStore(direct, pixel, vec4(0.0));
        imageStore(direct_diffuse, pixel, vec4(0.0));
        return;
    }
    vec4 normal = imageLoad(g_normal, pixel);
    Brdf b = brdf_from_gbuffer(imageLoad(g_albedo, pixel), normal);
    vec3 wo = normalize(pc.camera_position.xyz - position.xyz);
    vec3 radiance = imageLoad(g_emission, pixel).rgb;
    vec3 diffuse = radiance;
    for (uint i = 0u; i < pc.light_count; i++) {
        direct_radiance(lights[i], position.xyz, normal.xyz, b, wo, radiance, diffuse);
    }
    imageStore(direct, pixel, vec4(radiance, 1.0));
    imageStore(direct_diffuse, pixel, vec4(diffuse, 1.0));
}
