// What the interleaved gather hands its reconstruction filter besides the
// G-buffer (which the filter's surface tests read): one rgba32ui texel a
// pixel, its subset's sums, the diffuse and the glossy part with the
// glossy lobe's widening.
#ifndef SSBC_INTERLEAVED_SUMS_GLSL
#define SSBC_INTERLEAVED_SUMS_GLSL

// Three channels in 56 bits: signed 16-bit mantissas under the largest
// channel's exponent (within 2^-15 of it, with f32's range: the sums are in
// physical units, which overflow halves at bright emitters, and the glossy
// rest may be negative); x: r | g << 16, y: b | exponent << 16, y's top
// byte free. Non-finite sums are 0. Powers of two from exponent bits
// (ldexp and frexp cost lavapipe calls).
uvec2 pack_rgb56(vec3 v) {
    float largest = max(max(abs(v.r), abs(v.g)), abs(v.b));
    if (!(largest > 0.0) || isinf(largest)) return uvec2(0u);
    // largest = f 2^e with f in [0.5, 1).
    int e = clamp(int(floatBitsToUint(largest) >> 23) - 126, -110, 128);
    float to_mantissa = uintBitsToFloat(uint(142 - e) << 23);  // 2^(15 - e)
    uvec3 m = uvec3(ivec3(clamp(round(v * to_mantissa), vec3(-32767.0), vec3(32767.0)))) & 0xFFFFu;
    return uvec2(m.r | (m.g << 16), m.b | (uint(e + 110) << 16));
}

vec3 unpack_rgb56(uvec2 w) {
    ivec3 m = ivec3(bitfieldExtract(int(w.x), 0, 16), bitfieldExtract(int(w.x), 16, 16), bitfieldExtract(int(w.y), 0, 16));
    int e = int((w.y >> 16) & 255u) - 110;
    return vec3(m) * uintBitsToFloat(uint(e + 112) << 23);  // 2^(e - 15)
}

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
