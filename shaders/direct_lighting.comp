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

// The squared change of the shading normal to the neighbour across axis
// `e` on the same smooth surface (the smaller of the two sides; 0 if
// neither is: a silhouette or the image's edge). On one smooth surface the
// chord between two points is square to the sum of their normals.
float normal_change2(ivec2 pixel, ivec2 e, vec3 p, vec3 n) {
    float best = 1e30;
    for (int side = -1; side <= 1; side += 2) {
        ivec2 q = pixel + side * e;
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(uvec2(q), pc.size))) continue;
        vec4 pq = imageLoad(g_position, q);
        vec3 nq = imageLoad(g_normal, q).xyz;
        vec3 chord = pq.xyz - p;
        vec3 sum = n + nq;
        bool smooth_surface = pq.w != 0.0 && abs(dot(sum, chord)) <= 0.1 * length(sum) * length(chord);
        if (smooth_surface) best = min(best, dot(nq - n, nq - n));
    }
    return best < 1e30 ? best : 0.0;
}

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
    // Geometric specular anti-aliasing for point-like lights: the normals
    // within the pixel spread by (|dn/dx|^2 + |dn/dy|^2) / 12 (a box pixel),
    // which widens the GGX lobe, so that a highlight smaller than the pixel
    // gives it its mean over the pixel instead of all or nothing.
    if (!brdf_is_lambertian(b) && pc.light_count > 0u) {
        float spread2 = (normal_change2(pixel, ivec2(1, 0), position.xyz, normal.xyz)
                         + normal_change2(pixel, ivec2(0, 1), position.xyz, normal.xyz)) / 12.0;
        b.roughness = sqrt(brdf_widened_alpha(b, spread2));
    }
    vec3 wo = normalize(pc.camera_position.xyz - position.xyz);
    vec3 radiance = imageLoad(g_emission, pixel).rgb;
    vec3 diffuse = radiance;
    for (uint i = 0u; i < pc.light_count; i++) {
        direct_radiance(lights[i], position.xyz, normal.xyz, b, wo, radiance, diffuse);
    }
    imageStore(direct, pixel, vec4(radiance, 1.0));
    imageStore(direct_diffuse, pixel, vec4(diffuse, 1.0));
}
