// The bounded VPL sum at one receiver, shared by the gathers: sum over VPLs
// [first, last) of albedo_i Phi_i min(G, b) V_ISM (times albedo(x) / pi^2 it
// is T_b L^). The including shader declares `vpl_texels` (the GpuVpls as
// RGBA32F texels: lavapipe fetches a texel in one vector gather, a struct
// from a storage buffer a component and a lane at a time), `ism` (the atlas,
// r32f) and push constants `pc` with tile, far, bound,
// ism_bias and point_radius.
#ifndef SSBC_VPL_GATHER_GLSL
#define SSBC_VPL_GATHER_GLSL

// ISM test for receiver at distance `dist` along unit `w` from the VPL (normal
// n), whose surface makes cos_x with -w. The tolerance grows with the
// receiver's slope across a splat (its own surface's points land in its texel).
float ism_visible(uint cell, vec3 w, vec3 n, float dist, float cos_x) {
    vec2 uv = ism_paraboloid(w, n);
    float stored = uintBitsToFloat(imageLoad(ism, ism_texel(cell, uv, pc.tile)).r);
    if (stored < 0.0) return 1.0;
    return dist <= stored * pc.far + ism_tolerance(dist, cos_x, pc.tile, pc.point_radius, pc.ism_bias) ? 1.0 : 0.0;
}

vec3 vpl_sum(vec3 x, vec3 n, uint first, uint last) {
    vec3 radiance = vec3(0.0);
    for (uint i = first; i < last; i++) {
        vec3 z = texelFetch(vpl_texels, int(3u * i)).xyz;
        vec3 d = x - z;
        float d2 = dot(d, d);
        if (d2 < 1e-10) continue;
        float dist = sqrt(d2);
        vec3 w = d / dist;
        vec4 n_z = texelFetch(vpl_texels, int(3u * i + 1u));
        float cos_z = dot(n_z.xyz, w);
        float cos_x = -dot(n, w);
        if (cos_z <= 0.0 || cos_x <= 0.0) continue;
        float g = min(cos_x * cos_z / d2, pc.bound);
        float v = ism_visible(floatBitsToUint(n_z.w), w, n_z.xyz, dist, cos_x);
        radiance += texelFetch(vpl_texels, int(3u * i + 2u)).rgb * (g * v);
    }
    return radiance;
}

#endif
