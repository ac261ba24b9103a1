#version 460
// Bounded VPL lighting T_b L^: sum over VPLs of f_r(x) min(G, b) V_ISM f_r(z) Phi.
// Also writes S0 = direct + bounded indirect, the term SSBC compensates.
#include "common.glsl"
#include "ism.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D g_normal;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D g_albedo;
layout(set = 0, binding = 3, rgba32f) uniform readonly image2D direct;
layout(set = 0, binding = 4, rgba32f) uniform writeonly image2D indirect_bounded;
layout(set = 0, binding = 5, rgba32f) uniform writeonly image2D s0;
layout(set = 0, binding = 6) readonly buffer Vpls { GpuVpl vpls[]; };
layout(set = 0, binding = 7, r32f) uniform readonly image2D ism;

layout(push_constant) uniform Push {
    uvec2 size;
    uint vpl_count;
    uint tile;
    uint tiles_per_row;
    float far;            // ISM distances are stored divided by this
    float bound;          // b [1/m^2]; +inf disables clamping
    float ism_bias;       // relative depth tolerance of the ISM test
    float point_radius;   // world radius of one splatted point
} pc;

// ISM test for receiver at distance `dist` along unit `w` from the VPL (normal
// n), whose surface makes cos_x with -w. The tolerance grows with the
// receiver's slope across a splat (its own surface's points land in its texel).
float ism_visible(uint v, vec3 w, vec3 n, float dist, float cos_x) {
    vec2 uv = ism_paraboloid(w, n);
    float stored = imageLoad(ism, ism_texel(v, uv, pc.tile, pc.tiles_per_row)).r;
    if (stored < 0.0) return 1.0;
    return dist <= stored * pc.far + ism_tolerance(dist, cos_x, pc.tile, pc.point_radius, pc.ism_bias) ? 1.0 : 0.0;
}

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(pixel), pc.size))) return;
    vec4 position = imageLoad(g_position, pixel);
    vec4 direct_radiance = imageLoad(direct, pixel);
    vec3 radiance = vec3(0.0);
    if (position.w != 0.0) {
        vec3 x = position.xyz;
        vec3 n = imageLoad(g_normal, pixel).xyz;
        vec3 albedo = imageLoad(g_albedo, pixel).rgb;
        for (uint i = 0u; i < pc.vpl_count; i++) {
            GpuVpl vpl = vpls[i];
            vec3 d = x - vpl.position.xyz;
            float d2 = dot(d, d);
            if (d2 < 1e-10) continue;
            float dist = sqrt(d2);
            vec3 w = d / dist;
            float cos_z = dot(vpl.normal.xyz, w);
            float cos_x = -dot(n, w);
            if (cos_z <= 0.0 || cos_x <= 0.0) continue;
            float g = min(cos_x * cos_z / d2, pc.bound);
            float v = ism_visible(i, w, vpl.normal.xyz, dist, cos_x);
            radiance += vpl.albedo.rgb * vpl.flux.rgb * (g * v);
        }
        radiance *= albedo / (PI * PI);
    }
    imageStore(indirect_bounded, pixel, vec4(radiance, position.w));
    imageStore(s0, pixel, vec4(direct_radiance.rgb + radiance, position.w));
}
