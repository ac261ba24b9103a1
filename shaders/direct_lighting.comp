#version 460
// Deferred direct lighting T Le: every punctual light, shadowed by its
// shadow map; plus Le, the radiance emissive surfaces send to the camera.
// Also what the pixel sends as an SSBC source (`direct_sources`): Le plus
// its reflection made view-independent (brdf_source_color).
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
layout(set = 0, binding = 8, rgba32f) uniform writeonly image2D direct_sources;

layout(push_constant) uniform Push {
    uvec2 size;
    uint light_count;
    vec4 camera_position;   // xyz: the eye, which glossy surfaces reflect towards
} pc;

#include "shadow.glsl"
#include "geometric_normal.glsl"

// The change of the shading normal per pixel along axis `e`, towards the
// neighbour on the same smooth surface (the smaller change of the two
// sides; zero if neither is: a silhouette or the image's edge). On one
// smooth surface the chord between two points is square to the sum of
// their normals.
vec3 normal_step(ivec2 pixel, ivec2 e, vec3 p, vec3 n) {
    vec3 best = vec3(0.0);
    float best2 = 1e30;
    for (int side = -1; side <= 1; side += 2) {
        ivec2 q = pixel + side * e;
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(uvec2(q), pc.size))) continue;
        vec4 pq = imageLoad(g_position, q);
        vec3 nq = imageLoad(g_normal, q).xyz;
        vec3 chord = pq.xyz - p;
        vec3 sum = n + nq;
        bool smooth_surface = pq.w != 0.0 && abs(dot(sum, chord)) <= 0.1 * length(sum) * length(chord);
        vec3 step = float(side) * (nq - n);
        if (smooth_surface && dot(step, step) < best2) {
            best = step;
            best2 = dot(step, step);
        }
    }
    return best;
}

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(pixel), pc.size))) return;
    vec4 position = imageLoad(g_position, pixel);
    if (position.w == 0.0) {
        imageStore(direct, pixel, vec4(0.0));
        imageStore(direct_sources, pixel, vec4(0.0));
        return;
    }
    vec4 normal = imageLoad(g_normal, pixel);
    Brdf b = brdf_from_gbuffer(imageLoad(g_albedo, pixel), normal);
    // Geometric specular anti-aliasing for point-like lights: the pixel's
    // normals span n +- dn_x / 2 +- dn_y / 2; the highlight is their mean,
    // taken at the centres of the pixel's four quarters, each lobe widened
    // by its quarter's spread ((|dn_x|^2 + |dn_y|^2) / 48, a box), so that
    // a highlight smaller than the pixel gives it its mean over the pixel
    // instead of all or nothing.
    // Where the spread is under a tenth of the lobe's width (a hundredth in
    // variance) the BRDF is taken at n alone (rough lobes, flat surfaces).
    vec3 dn_x = vec3(0.0), dn_y = vec3(0.0);
    float quarter_alpha = brdf_alpha(b);
    bool spread = false;
    if (!brdf_is_lambertian(b) && pc.light_count > 0u) {
        dn_x = normal_step(pixel, ivec2(1, 0), position.xyz, normal.xyz);
        dn_y = normal_step(pixel, ivec2(0, 1), position.xyz, normal.xyz);
        float spread2 = (dot(dn_x, dn_x) + dot(dn_y, dn_y)) / 12.0;
        spread = spread2 > 0.01 * quarter_alpha * quarter_alpha;
        quarter_alpha = brdf_widened_alpha(b, spread2 / 4.0);
    }
    vec3 wo = normalize(pc.camera_position.xyz - position.xyz);
    vec4 emission = imageLoad(g_emission, pixel);
    vec3 surface = geometric_normal(emission.w, normal.xyz);
    vec3 radiance = emission.rgb;
    vec3 source = radiance;
    for (uint i = 0u; i < pc.light_count; i++) {
        vec3 wi;
        vec3 irradiance = light_irradiance(lights[i], position.xyz, normal.xyz, surface, wi);
        if (max(irradiance.r, max(irradiance.g, irradiance.b)) <= 0.0) continue;
        // One tap where the spread does not matter: a loop, not a branch,
        // so that a SIMD group runs as many taps as its widest lane needs
        // (lavapipe runs both sides of a branch).
        int taps = spread ? 4 : 1;
        float a = spread ? quarter_alpha : brdf_alpha(b);
        vec3 f = vec3(0.0);
        for (int k = 0; k < taps; k++) {
            vec2 at = spread ? vec2(k & 1, k >> 1) * 0.5 - 0.25 : vec2(0.0);
            vec3 nk = normalize(normal.xyz + at.x * dn_x + at.y * dn_y);
            f += brdf_eval_alpha(b, a, nk, wo, wi);
        }
        f /= float(taps);
        radiance += f * irradiance;
        source += brdf_source_color(b) / PI * irradiance;
    }
    imageStore(direct, pixel, vec4(radiance, 1.0));
    imageStore(direct_sources, pixel, vec4(source, 1.0));
}
