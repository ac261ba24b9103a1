// A pixel's geometric normal (the interpolated vertex normal, before the
// normal map), kept in the G-buffer's emission.w where a normal map turned
// the shading normal (else emission.w = 1 and the two are the same). SSBC
// takes senders' areas, cosines and creases from it: positions lie on that
// surface, so a normal map's grooves, whose shading normals face each
// other across a pixel, are not surfaces lighting each other at a
// distance of a pixel (docs/ssbc-implementation.md).

#ifndef SSBC_GEOMETRIC_NORMAL_GLSL
#define SSBC_GEOMETRIC_NORMAL_GLSL

#include "octahedral.glsl"

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
