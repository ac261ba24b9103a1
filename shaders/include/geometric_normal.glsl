// A pixel's geometric normal (the interpolated vertex normal, before the
// normal map), kept in the G-buffer's emission.w where a normal map turned
// the shading normal (else emission.w = 1 and the two are the same). SSBC
// takes senders' areas, cosines and creases from it: positions lie on that
// surface, so a normal map's grooves, whose shading normals face each
// other across a pixel, are not surfaces lighting each other at a
// distance of a pixel (docs/ssbc-implementation.md).

#ifndef SSBC_GEOMETRIC_NORMAL_GLSL
#define SSBC_GEOMETRIC_NORMAL_GLSL

// Octahedral map of a unit vector onto [-1, 1]^2.
vec2 octahedral(vec3 n) {
    n /= abs(n.x) + abs(n.y) + abs(n.z);
    vec2 p = n.xy;
    if (n.z < 0.0) p = (1.0 - abs(p.yx)) * vec2(p.x >= 0.0 ? 1.0 : -1.0, p.y >= 0.0 ? 1.0 : -1.0);
    return p;
}

vec3 from_octahedral(vec2 p) {
    vec3 n = vec3(p, 1.0 - abs(p.x) - abs(p.y));
    if (n.z < 0.0) n.xy = (1.0 - abs(n.yx)) * vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
    return normalize(n);
}

// 12 bits per octahedral coordinate (within 0.05 degrees) as a negative
// integer, exact in a float: -(code + 1), code < 2^24.
float encode_geometric_normal(vec3 n) {
    uvec2 q = uvec2(round(clamp(octahedral(n) * 0.5 + 0.5, 0.0, 1.0) * 4095.0));
    return -(float(q.x * 4096u + q.y) + 1.0);
}

// The geometric normal from emission.w `w` (non-negative: the shading
// normal `shading` is the geometric one).
vec3 geometric_normal(float w, vec3 shading) {
    if (!(w < 0.0)) return shading;
    uint code = uint(-w) - 1u;
    return from_octahedral(vec2(code >> 12, code & 4095u) / 4095.0 * 2.0 - 1.0);
}

#endif
