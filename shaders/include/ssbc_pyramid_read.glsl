// The pyramids as the kernels that read them bind them: texel buffers (a
// texel fetch reads 16 bytes in one gather where a storage-buffer load costs
// lavapipe a per-lane loop for every 4 bytes; src/vk/buffer_view.rs).
// Bindings 0..2 of every such kernel.

#ifndef SSBC_PYRAMID_READ_GLSL
#define SSBC_PYRAMID_READ_GLSL

#include "ssbc_types.glsl"

layout(set = 0, binding = 0) uniform utextureBuffer geo_texels;       // three per GeoTexel (level 0: two)
layout(set = 0, binding = 1) uniform utextureBuffer aux_texels;       // one per GeoAux (none at level 0)
layout(set = 0, binding = 2) uniform utextureBuffer radiance_texels;  // one per texel: front, back packed (level 0: half, the front's)

// A pixel's back cluster from its level-0 words a and b.
GeoCluster level0_back_of(uint i, uvec4 a, uvec4 b) {
    uint code = level0_back_code(b);
    if (code == 0u) return empty_cluster();
    int q = geo_word(level0_neighbour(i, code - 1u));
    return level0_back(a, b, texelFetch(geo_texels, q), texelFetch(geo_texels, q + 1));
}

// Cluster c (0 front, 1 back) of texel i.
GeoCluster geo_cluster(uint i, uint c) {
    int at = geo_word(i);
    if (is_level0(i)) {
        uvec4 a = texelFetch(geo_texels, at);
        uvec4 b = texelFetch(geo_texels, at + 1);
        return c == 0u ? level0_front(a, b) : level0_back_of(i, a, b);
    }
    return unpack_cluster(texelFetch(geo_texels, at + int(c)), texelFetch(geo_texels, at + 2), c);
}

// Both clusters of texel i (three fetches; a crease pixel's back cluster
// two more).
GeoTexel geo_texel(uint i) {
    int at = geo_word(i);
    uvec4 a = texelFetch(geo_texels, at);
    uvec4 b = texelFetch(geo_texels, at + 1);
    if (is_level0(i)) return GeoTexel(level0_front(a, b), level0_back_of(i, a, b));
    uvec4 normals = texelFetch(geo_texels, at + 2);
    return GeoTexel(unpack_cluster(a, normals, 0u), unpack_cluster(b, normals, 1u));
}

// The areas, pixels and flags of texel i.
GeoAux geo_aux(uint i) {
    if (is_level0(i)) {
        int at = geo_word(i);
        return level0_aux(texelFetch(geo_texels, at), texelFetch(geo_texels, at + 1));
    }
    uvec4 a = texelFetch(aux_texels, aux_texel(i));
    return GeoAux(uintBitsToFloat(a.x), uintBitsToFloat(a.y), a.z, a.w);
}

// Sum of A_y S(y) over a level-0 texel's front cluster.
vec3 level0_front_radiance(uint i) {
    uint half_;
    uvec4 t = texelFetch(radiance_texels, radiance_texel(i, half_));
    return unpack_radiance(half_ == 0u ? t.xy : t.zw);
}

// Sum of A_y S(y) over a level-0 texel's back cluster (word b): its area
// times its neighbour's S.
vec3 level0_back_radiance(uint i, uvec4 b) {
    uint code = level0_back_code(b);
    if (code == 0u) return vec3(0.0);
    uint q = level0_neighbour(i, code - 1u);
    float area_q = uintBitsToFloat(texelFetch(geo_texels, geo_word(q)).w);
    return level0_front_radiance(q) * (uintBitsToFloat(b.w) / area_q);
}

// Sum of A_y S(y) over cluster c of texel i.
vec3 cluster_radiance(uint i, uint c) {
    if (is_level0(i)) {
        if (c == 0u) return level0_front_radiance(i);
        return level0_back_radiance(i, texelFetch(geo_texels, geo_word(i) + 1));
    }
    uint half_;
    uvec4 t = texelFetch(radiance_texels, radiance_texel(i, half_));
    return unpack_radiance(c == 0u ? t.xy : t.zw);
}

// Both clusters' sums of texel i.
void texel_radiance(uint i, out vec3 front, out vec3 back) {
    uint half_;
    uvec4 t = texelFetch(radiance_texels, radiance_texel(i, half_));
    bool level0 = is_level0(i);
    front = unpack_radiance(level0 && half_ == 1u ? t.zw : t.xy);
    back = level0 ? level0_back_radiance(i, texelFetch(geo_texels, geo_word(i) + 1)) : unpack_radiance(t.zw);
}

#endif
