// The bounded VPL sum at one receiver, shared by the gathers: sum over VPLs
// [first, last) of albedo_i Phi_i min(G, b) V_ISM (times albedo(x) / pi^2 it
// is T_b L^). The including shader declares `vpls` (GpuVpl[]), `ism` (the
// atlas, r32f) and push constants `pc` with tile, tiles_per_row, far, bound,
// ism_bias and point_radius.
#ifndef SSBC_VPL_GATHER_GLSL
#define SSBC_VPL_GATHER_GLSL

// ISM test for receiver at distance `dist` along unit `w` from the VPL (normal
// n), whose surface makes cos_x with -w. The tolerance grows with the
// receiver's slope across a splat (its own surface's points land in its texel).
float ism_visible(uint v, vec3 w, vec3 n, float dist, float cos_x) {
    vec2 uv = ism_paraboloid(w, n);
    float stored = imageLoad(ism, ism_texel(v, uv, pc.tile, pc.tiles_per_row)).r;
    if (stored < 0.0) return 1.0;
    return dist <= stored * pc.far + ism_tolerance(dist, cos_x, pc.tile, pc.point_radius, pc.ism_bias) ? 1.0 : 0.0;
}

vec3 vpl_sum(vec3 x, vec3 n, uint first, uint last) {
    vec3 radiance = vec3(0.0);
    for (uint i = first; i < last; i++) {
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
    return radiance;
}

#endif
