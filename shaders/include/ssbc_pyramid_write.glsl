// The pyramids as the builds bind them: storage texel buffers, read and
// written (the levels below the one being built are read). Bindings 0..2 of
// the geometry and radiance pyramid kernels, and 20 and 21: the G-buffer
// positions of both layers, which level 0's texels take theirs from.

#ifndef SSBC_PYRAMID_WRITE_GLSL
#define SSBC_PYRAMID_WRITE_GLSL

#include "ssbc_types.glsl"

layout(set = 0, binding = 0, rgba32ui) uniform uimageBuffer geo_words;    // three per GeoTexel (level 0: one)
layout(set = 0, binding = 1, rgba32ui) uniform uimageBuffer aux_words;    // one per GeoAux (none at level 0)
layout(set = 0, binding = 2, rgba32ui) uniform uimageBuffer radiance_sums; // one per texel: front, back packed (level 0: half, the front's)

layout(set = 0, binding = 20, rgba32f) uniform readonly image2D level0_position0;  // layer 0's G-buffer position
layout(set = 0, binding = 21, rgba32f) uniform readonly image2D level0_position1;  // layer 1's (layer 0's without one)

uvec4 geo_load(int at) { return imageLoad(geo_words, at); }
uvec4 aux_load(int at) { return imageLoad(aux_words, at); }
uvec4 radiance_load(int at) { return imageLoad(radiance_sums, at); }

#include "ssbc_pyramid_access.glsl"

// Levels 1 and up.
void store_geo(uint i, GeoTexel t) {
    int at = geo_word(i);
    imageStore(geo_words, at, floatBitsToUint(t.front.position_extent));
    imageStore(geo_words, at + 1, floatBitsToUint(t.back.position_extent));
    imageStore(geo_words, at + 2, pack_normals(t));
}

// Level 0: a pixel's word (ssbc_types.glsl, "Level 0").
void store_level0(uint i, uvec4 w) {
    imageStore(geo_words, geo_word(i), w);
}

// Levels 1 and up.
void store_aux(uint i, GeoAux a) {
    imageStore(aux_words, aux_texel(i), uvec4(floatBitsToUint(a.front_area), floatBitsToUint(a.back_area), a.pixels, a.flags));
}

// Both sums of texel i (the level-1 build reads each child's once).
void texel_sums(uint i, out vec3 front, out vec3 back) {
    if (is_level0(i)) {
        front = level0_front_radiance(i);
        back = level0_back_radiance(i, imageLoad(geo_words, geo_word(i)));
        return;
    }
    uint half_;
    uvec4 t = imageLoad(radiance_sums, radiance_texel(i, half_));
    front = unpack_radiance(t.xy);
    back = unpack_radiance(t.zw);
}

// Levels 1 and up.
void store_radiance(uint i, vec3 front, vec3 back) {
    uint half_;
    imageStore(radiance_sums, radiance_texel(i, half_), uvec4(pack_radiance(front), pack_radiance(back)));
}

// Level 0: the front sums of texels i (even) and i + 1.
void store_level0_radiance(uint i, vec3 front, vec3 next_front) {
    uint half_;
    imageStore(radiance_sums, radiance_texel(i, half_), uvec4(pack_radiance(front), pack_radiance(next_front)));
}

#endif
