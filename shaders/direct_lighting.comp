#version 460
// Deferred direct lighting T Le: every punctual light, shadowed by its
// shadow map; plus Le, the radiance emissive surfaces send to the camera.
// Also what the pixel sends as an SSBC source (`direct_sources`): Le plus
// its reflection made view-independent (brdf_source_color).
#include "common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 1, rg32ui) uniform readonly uimage2D g_normal;
layout(set = 0, binding = 2, rg32ui) uniform readonly uimage2D g_albedo;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D direct;
layout(set = 0, binding = 4) readonly buffer Lights { GpuLight lights[]; };
layout(set = 0, binding = 5) readonly buffer ShadowViews { ShadowView shadow_views[]; };
layout(set = 0, binding = 6) uniform sampler2DArray shadow_maps;
layout(set = 0, binding = 7, rgba32f) uniform readonly image2D g_emission;
layout(set = 0, binding = 8, rgba32f) uniform writeonly image2D direct_sources;
// Bit i mod 32: light i reaches the pixel (the interleaved filter's).
layout(set = 0, binding = 9, r32ui) uniform writeonly uimage2D direct_lights;

layout(push_constant) uniform Push {
    uvec2 size;
    uint light_count;
    vec4 camera_position;   // xyz: the eye, which glossy surfaces reflect towards
} pc;

#include "shadow.glsl"
#include "geometric_normal.glsl"
// A tap's lobe takes its quarter's widening fully within the widened
// lobe's alpha of the peak (in tan^2 of the angle from its half vector),
// fading to none at 3 alpha: in GGX's tail a widened lobe is brighter than
// the narrow one's mean over the quarter (alpha^2 / theta^4 grows with
// alpha^2). Measured: docs/accuracy.md, "Tuned constants".
const float WIDENED_TO = 9.0;

// The change of the shading normal per pixel along axis `e`, towards the
// neighbour on the same smooth surface (the smaller change of the two
// sides; zero if neither is: a silhouette or the image's edge), and the
// position's (dp). On one smooth surface the chord between two points is
// square to the sum of their normals.
vec3 normal_step(ivec2 pixel, ivec2 e, vec3 p, vec3 n, out vec3 dp) {
    vec3 best = vec3(0.0);
    float best2 = 1e30;
    dp = vec3(0.0);
    for (int side = -1; side <= 1; side += 2) {
        ivec2 q = pixel + side * e;
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(uvec2(q), pc.size))) continue;
        vec4 pq = imageLoad(g_position, q);
        vec3 nq = unpack_gbuffer_normal(imageLoad(g_normal, q)).xyz;
        vec3 chord = pq.xyz - p;
        vec3 sum = n + nq;
        bool smooth_surface = pq.w != 0.0 && abs(dot(sum, chord)) <= 0.1 * length(sum) * length(chord);
        vec3 step = float(side) * (nq - n);
        if (smooth_surface && dot(step, step) < best2) {
            best = step;
            best2 = dot(step, step);
            dp = float(side) * chord;
        }
    }
    return best;
}

// The half vector between the eye and the light (at its position, or in
// direction `wi` for a directional light) seen from p.
vec3 half_vector_at(vec3 p, GpuLight light, vec3 wi) {
    vec3 to_light = uint(light.position_kind.w) == LIGHT_DIRECTIONAL ? wi
        : normalize(light.position_kind.xyz - p);
    return normalize(normalize(pc.camera_position.xyz - p) + to_light);
}

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(pixel), pc.size))) return;
    vec4 position = imageLoad(g_position, pixel);
    if (position.w == 0.0) {
        imageStore(direct, pixel, vec4(0.0));
        imageStore(direct_sources, pixel, vec4(0.0));
        imageStore(direct_lights, pixel, uvec4(0u));
        return;
    }
    vec4 normal = unpack_gbuffer_normal(imageLoad(g_normal, pixel));
    Brdf b = brdf_from_gbuffer(unpack_gbuffer_albedo(imageLoad(g_albedo, pixel)), normal);
    // Geometric specular anti-aliasing for point-like lights: across the
    // pixel the normal relative to the half vector spans n +- d_x / 2 +-
    // d_y / 2 (d: the normal's step per pixel less the half vector's); the
    // highlight is the mean, taken at the centres of the pixel's four
    // quarters, each lobe widened by its quarter's spread ((|d_x|^2 +
    // |d_y|^2) / 48, a box), so that a highlight smaller than the pixel
    // gives it its mean over the pixel instead of all or nothing.
    // Where the spread is under a tenth of the lobe's width (a hundredth in
    // variance) the BRDF is taken at n alone (rough lobes, flat surfaces).
    vec3 dn_x = vec3(0.0), dn_y = vec3(0.0), dp_x = vec3(0.0), dp_y = vec3(0.0);
    bool glossy = !brdf_is_lambertian(b) && pc.light_count > 0u;
    if (glossy) {
        dn_x = normal_step(pixel, ivec2(1, 0), position.xyz, normal.xyz, dp_x);
        dn_y = normal_step(pixel, ivec2(0, 1), position.xyz, normal.xyz, dp_y);
    }
    vec3 wo = normalize(pc.camera_position.xyz - position.xyz);
    vec4 emission = imageLoad(g_emission, pixel);
    vec3 surface = geometric_normal(emission.w, normal.xyz);
    vec3 radiance = emission.rgb;
    vec3 source = radiance;
    uint reached = 0u;
    for (uint i = 0u; i < pc.light_count; i++) {
        vec3 wi;
        vec3 irradiance = light_irradiance(lights[i], position.xyz, normal.xyz, surface, wi);
        if (max(irradiance.r, max(irradiance.g, irradiance.b)) <= 0.0) continue;
        reached |= 1u << (i & 31u);
        // What the lobe sees change across the pixel is the normal relative
        // to the half vector: the half vector turns too, as the eye and the
        // light are seen from another point (on a convex mirror it adds to
        // the normal's turn (measured: docs/accuracy.md, "Tuned constants")).
        vec3 d_x = dn_x, d_y = dn_y;
        vec3 h = normalize(wo + wi);
        float alpha = brdf_alpha(b);
        float widened = alpha;
        bool spread = false;
        if (glossy && (dot(dp_x, dp_x) > 0.0 || dot(dp_y, dp_y) > 0.0)) {
            if (dot(dp_x, dp_x) > 0.0) d_x -= half_vector_at(position.xyz + dp_x, lights[i], wi) - h;
            if (dot(dp_y, dp_y) > 0.0) d_y -= half_vector_at(position.xyz + dp_y, lights[i], wi) - h;
            float spread2 = (dot(d_x, d_x) + dot(d_y, d_y)) / 12.0;
            spread = spread2 > 0.01 * alpha * alpha;
            widened = brdf_widened_alpha(b, spread2 / 4.0);
        }
        // One tap where the spread does not matter: a loop, not a branch,
        // so that a SIMD group runs as many taps as its widest lane needs
        // (lavapipe runs both sides of a branch).
        int taps = spread ? 4 : 1;
        vec3 f = vec3(0.0);
        for (int k = 0; k < taps; k++) {
            vec2 at = spread ? vec2(k & 1, k >> 1) * 0.5 - 0.25 : vec2(0.0);
            vec3 nk = normalize(normal.xyz + at.x * d_x + at.y * d_y);
            float a = alpha;
            if (spread) {
                // tan^2 of the tap's angle to the half vector.
                vec3 c = cross(nk, h);
                float t2 = dot(c, c) / max(dot(nk, h) * dot(nk, h), 1e-8);
                float w2 = widened * widened;
                float near = clamp((WIDENED_TO * w2 - t2) / ((WIDENED_TO - 1.0) * w2), 0.0, 1.0);
                a = sqrt(alpha * alpha + near * (w2 - alpha * alpha));
            }
            f += brdf_eval_alpha(b, a, nk, wo, wi);
        }
        f /= float(taps);
        radiance += f * irradiance;
        source += brdf_source_color(b) / PI * irradiance;
    }
    imageStore(direct, pixel, vec4(radiance, 1.0));
    // w: the geometric normal's code (geometric_normal.glsl), which SSBC
    // reads here after the G-buffer's emission image is gone.
    imageStore(direct_sources, pixel, vec4(source, emission.w));
    imageStore(direct_lights, pixel, uvec4(reached));
}
