// The interleaved gather's guide for its reconstruction filter: a pixel's
// position and normal in one rgba32ui texel (one load per filter tap).
#ifndef SSBC_GUIDE_GLSL
#define SSBC_GUIDE_GLSL

// w of a pixel without geometry (snorm16 never packs -32768).
const uint NO_GEOMETRY = 0x80008000u;

vec2 octahedral(vec3 n) {
    n /= abs(n.x) + abs(n.y) + abs(n.z);
    vec2 e = n.xy;
    if (n.z < 0.0) e = (1.0 - abs(n.yx)) * vec2(e.x >= 0.0 ? 1.0 : -1.0, e.y >= 0.0 ? 1.0 : -1.0);
    return e;
}

vec3 from_octahedral(vec2 e) {
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    float t = max(-n.z, 0.0);
    n.xy += vec2(n.x >= 0.0 ? -t : t, n.y >= 0.0 ? -t : t);
    return normalize(n);
}

uvec4 pack_guide(vec3 position, vec3 normal) {
    return uvec4(floatBitsToUint(position), packSnorm2x16(octahedral(normal)));
}

vec3 guide_position(uvec4 g) { return uintBitsToFloat(g.xyz); }
vec3 guide_normal(uvec4 g) { return from_octahedral(unpackSnorm2x16(g.w)); }

#endif
