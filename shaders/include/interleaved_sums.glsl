// What the interleaved gather hands its reconstruction filter besides the
// G-buffer (which the filter's surface tests read): one rgba32ui texel a
// pixel, its subset's sums, the diffuse and the glossy part with the
// glossy lobe's widening.
#ifndef SSBC_INTERLEAVED_SUMS_GLSL
#define SSBC_INTERLEAVED_SUMS_GLSL

// A pixel's subset sums: the diffuse part (xy), the glossy rest (zw) and
// the widening of its lobe (a half, its bytes in the top bytes of y and w).
uvec4 pack_sums(vec3 diffuse, vec3 glossy, float widening) {
    uint h = packHalf2x16(vec2(clamp(widening, 0.0, 65504.0), 0.0));
    uvec2 d = pack_rgb56(diffuse);
    uvec2 g = pack_rgb56(glossy);
    return uvec4(d.x, d.y | (h << 24), g.x, g.y | ((h >> 8) << 24));
}

vec3 sums_diffuse(uvec4 s) { return unpack_rgb56(s.xy); }
vec3 sums_glossy(uvec4 s) { return unpack_rgb56(s.zw); }
float sums_widening(uvec4 s) { return unpackHalf2x16((s.y >> 24) | ((s.w >> 24) << 8)).x; }

#endif
