// The pyramids' reads that the kernels reading them (ssbc_pyramid_read.glsl,
// texel buffers) and the builds (ssbc_pyramid_write.glsl, storage texel
// buffers) share: included by both after they define geo_load, aux_load
// and radiance_load (one RGBA32UI word of each buffer).

#ifndef SSBC_PYRAMID_ACCESS_GLSL
#define SSBC_PYRAMID_ACCESS_GLSL

// A pixel's back cluster from its level-0 words a and b.
GeoCluster level0_back_of(uint i, uvec4 a, uvec4 b) {
    uint code = level0_back_code(b);
    if (code == 0u) return empty_cluster();
    int q = geo_word(level0_neighbour(i, code - 1u));
    return level0_back(a, b, geo_load(q), geo_load(q + 1));
}

// Cluster c (0 front, 1 back) of texel i.
GeoCluster geo_cluster(uint i, uint c) {
    int at = geo_word(i);
    if (is_level0(i)) {
        uvec4 a = geo_load(at);
        uvec4 b = geo_load(at + 1);
        return c == 0u ? level0_front(a, b) : level0_back_of(i, a, b);
    }
    return unpack_cluster(geo_load(at + int(c)), geo_load(at + 2), c);
}

// The areas, pixels and flags of texel i.
GeoAux geo_aux(uint i) {
    if (is_level0(i)) {
        int at = geo_word(i);
        return level0_aux(geo_load(at), geo_load(at + 1));
    }
    uvec4 a = aux_load(aux_texel(i));
    return GeoAux(uintBitsToFloat(a.x), uintBitsToFloat(a.y), a.z, a.w);
}

// Sum of A_y S(y) over a level-0 texel's front cluster.
vec3 level0_front_radiance(uint i) {
    uint half_;
    uvec4 t = radiance_load(radiance_texel(i, half_));
    return unpack_radiance(half_ == 0u ? t.xy : t.zw);
}

// Sum of A_y S(y) over a level-0 texel's back cluster (word b): its area
// times its neighbour's S.
vec3 level0_back_radiance(uint i, uvec4 b) {
    uint code = level0_back_code(b);
    if (code == 0u) return vec3(0.0);
    uint q = level0_neighbour(i, code - 1u);
    float area_q = uintBitsToFloat(geo_load(geo_word(q)).w);
    return level0_front_radiance(q) * (uintBitsToFloat(b.w) / area_q);
}

// Sum of A_y S(y) over cluster c of texel i.
vec3 cluster_radiance(uint i, uint c) {
    if (is_level0(i)) {
        if (c == 0u) return level0_front_radiance(i);
        return level0_back_radiance(i, geo_load(geo_word(i) + 1));
    }
    uint half_;
    uvec4 t = radiance_load(radiance_texel(i, half_));
    return unpack_radiance(c == 0u ? t.xy : t.zw);
}

#endif
