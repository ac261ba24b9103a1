// Exact visibility with ray queries against the scene's top-level
// acceleration structure (src/ray_scene.rs), for the kernels' _exact twins
// (which enable GL_EXT_ray_query and define EXACT_VISIBILITY).
#ifndef SSBC_EXACT_VISIBILITY_GLSL
#define SSBC_EXACT_VISIBILITY_GLSL

layout(set = 0, binding = 15) uniform accelerationStructureEXT scene_tlas;

// How far a point leaves its surface before a ray from or to it: 1e-4 of
// its coordinates' size plus of `floor`, the scene's diagonal up to a
// metre (SceneBvh::surface_offset, the CPU's twin: src/cpu/bvh.rs).
float exact_lift(vec3 p, float floor) {
    return 1e-4 * (floor + max(max(abs(p.x), abs(p.y)), abs(p.z)));
}

// Whether the segment from a (lifted along its normal na, turned towards
// b) to b (lifted along nb, turned towards a) meets no surface; `floor`:
// see exact_lift.
bool segment_free(vec3 a, vec3 na, vec3 b, vec3 nb, float floor) {
    vec3 from = a + (dot(na, b - a) >= 0.0 ? na : -na) * exact_lift(a, floor);
    vec3 to = b + (dot(nb, from - b) >= 0.0 ? nb : -nb) * exact_lift(b, floor);
    vec3 d = to - from;
    float len = length(d);
    if (!(len > 1e-7)) return true;
    rayQueryEXT query;
    rayQueryInitializeEXT(query, scene_tlas, gl_RayFlagsTerminateOnFirstHitEXT | gl_RayFlagsOpaqueEXT,
                          0xFFu, from, 0.0, d / len, len);
    while (rayQueryProceedEXT(query)) {
    }
    return rayQueryGetIntersectionTypeEXT(query, true) == gl_RayQueryCommittedIntersectionNoneEXT;
}

#endif
