// The pyramids as the builds bind them: storage texel buffers, read and
// written (the levels below the one being built are read). Bindings 0..2 of
// the geometry and radiance pyramid kernels.

#ifndef SSBC_PYRAMID_WRITE_GLSL
#define SSBC_PYRAMID_WRITE_GLSL

#include "ssbc_types.glsl"

layout(set = 0, binding = 0, rgba32ui) uniform uimageBuffer geo_words;    // three per GeoTexel (level 0: two)
layout(set = 0, binding = 1, rgba32ui) uniform uimageBuffer aux_words;    // one per GeoAux (none at level 0)
layout(set = 0, binding = 2, rgba32ui) uniform uimageBuffer radiance_sums; // one per texel: front, back packed (level 0: half, the front's)

GeoCluster geo_cluster(uint i, uint c) {
    int at = geo_word(i);
    if (is_level0(i)) {
        uvec4 a = imageLoad(geo_words, at);
        uvec4 b = imageLoad(geo_words, at + 1);
        if (c == 0u) return level0_front(a, b);
        uint code = level0_back_code(b);
        if (code == 0u) return empty_cluster();
        int q = geo_word(level0_neighbour(i, code - 1u));
        return level0_back(a, b, imageLoad(geo_words, q), imageLoad(geo_words, q + 1));
    }
    return unpack_cluster(imageLoad(geo_words, at + int(c)), imageLoad(geo_words, at + 2), c);
}

// Levels 1 and up.
void store_geo(uint i, GeoTexel t) {
    int at = geo_word(i);
    imageStore(geo_words, at, floatBitsToUint(t.front.position_extent));
    imageStore(geo_words, at + 1, floatBitsToUint(t.back.position_extent));
    imageStore(geo_words, at + 2, pack_normals(t));
}

// Level 0: a pixel's words (ssbc_types.glsl, "Level 0").
void store_level0(uint i, uvec4 a, uvec4 b) {
    int at = geo_word(i);
    imageStore(geo_words, at, a);
    imageStore(geo_words, at + 1, b);
}

GeoAux geo_aux(uint i) {
    if (is_level0(i)) {
        int at = geo_word(i);
        return level0_aux(imageLoad(geo_words, at), imageLoad(geo_words, at + 1));
    }
    uvec4 a = imageLoad(aux_words, aux_texel(i));
    return GeoAux(uintBitsToFloat(a.x), uintBitsToFloat(a.y), a.z, a.w);
}

// Levels 1 and up.
void store_aux(uint i, GeoAux a) {
    imageStore(aux_words, aux_texel(i), uvec4(floatBitsToUint(a.front_area), floatBitsToUint(a.back_area), a.pixels, a.flags));
}

// Both sums of texel i: at level 0 its front's, and its back cluster's
// from its neighbour's front, scaled by their areas.
void texel_sums(uint i, out vec3 front, out vec3 back) {
    uint half_;
    uvec4 t = imageLoad(radiance_sums, radiance_texel(i, half_));
    if (!is_level0(i)) {
        front = unpack_radiance(t.xy);
        back = unpack_radiance(t.zw);
        return;
    }
    front = unpack_radiance(half_ == 0u ? t.xy : t.zw);
    back = vec3(0.0);
    uvec4 b = imageLoad(geo_words, geo_word(i) + 1);
    uint code = level0_back_code(b);
    if (code != 0u) {
        uint q = level0_neighbour(i, code - 1u);
        float area_q = uintBitsToFloat(imageLoad(geo_words, geo_word(q)).w);
        uvec4 tq = imageLoad(radiance_sums, radiance_texel(q, half_));
        back = unpack_radiance(half_ == 0u ? tq.xy : tq.zw) * (uintBitsToFloat(b.w) / area_q);
    }
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
