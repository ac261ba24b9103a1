// The interleaved gather's guide for its reconstruction filter: a pixel's
// position and normal in one rgba32ui texel (one load per filter tap).
#ifndef SSBC_GUIDE_GLSL
#define SSBC_GUIDE_GLSL

// w of a pixel without geometry (snorm16 never packs -32768).
const uint NO_GEOMETRY = 0x80008000u;

#include "octahedral.glsl"

uvec4 pack_guide(vec3 position, vec3 normal) {
    return uvec4(floatBitsToUint(position), packSnorm2x16(octahedral(normal)));
}

vec3 guide_position(uvec4 g) { return uintBitsToFloat(g.xyz); }
vec3 guide_normal(uvec4 g) { return from_octahedral(unpackSnorm2x16(g.w)); }

#endif
