// The pyramids' reads that the kernels reading them (ssbc_pyramid_read.glsl,
// texel buffers) and the builds (ssbc_pyramid_write.glsl, storage texel
// buffers) share: included by both after they define geo_load, aux_load
// and radiance_load (one RGBA32UI word of each buffer) and bind both
// layers' G-buffer positions (level0_position0, level0_position1: layer
// 0's again without a second layer).

#ifndef SSBC_PYRAMID_ACCESS_GLSL
#define SSBC_PYRAMID_ACCESS_GLSL

// The world position of level-0 texel i (its pixel's, in its layer's
// G-buffer).
vec3 level0_position(uint i) {
    uint layer;
    ivec2 p = level0_pixel(i, layer);
    return (layer == 0u ? imageLoad(level0_position0, p) : imageLoad(level0_position1, p)).xyz;
}

// A pixel's back cluster from its level-0 position x and word w.
GeoCluster level0_back_of(uint i, vec3 x, uvec4 w) {
    uint code = level0_back_code(w);
    if (code == 0u) return empty_cluster();
    uint q = level0_neighbour(i, code - 1u);
    return level0_back(x, w, level0_position(q), geo_load(geo_word(q)));
}

// Cluster c (0 front, 1 back) of texel i.
GeoCluster geo_cluster(uint i, uint c) {
    int at = geo_word(i);
    if (is_level0(i)) {
        uvec4 w = geo_load(at);
        vec3 x = level0_position(i);
        return c == 0u ? level0_front(x, w) : level0_back_of(i, x, w);
    }
    return unpack_cluster(geo_load(at + int(c)), geo_load(at + 2), c);
}

// The areas, pixels and flags of texel i.
GeoAux geo_aux(uint i) {
    if (is_level0(i)) return level0_aux(geo_load(geo_word(i)));
    uvec4 a = aux_load(aux_texel(i));
    return GeoAux(uintBitsToFloat(a.x), uintBitsToFloat(a.y), a.z, a.w);
}

// Sum of A_y S(y) over a level-0 texel's front cluster.
vec3 level0_front_radiance(uint i) {
    uint half_;
    uvec4 t = radiance_load(radiance_texel(i, half_));
    return unpack_radiance(half_ == 0u ? t.xy : t.zw);
}

// Sum of A_y S(y) over a level-0 texel's back cluster (word w): its area
// times its neighbour's S.
vec3 level0_back_radiance(uint i, uvec4 w) {
    uint code = level0_back_code(w);
    if (code == 0u) return vec3(0.0);
    uint q = level0_neighbour(i, code - 1u);
    float area_q = level0_area(geo_load(geo_word(q)));
    return level0_front_radiance(q) * (level0_back_area(w) / area_q);
}

// Sum of A_y S(y) over cluster c of texel i.
vec3 cluster_radiance(uint i, uint c) {
    if (is_level0(i)) {
        if (c == 0u) return level0_front_radiance(i);
        return level0_back_radiance(i, geo_load(geo_word(i)));
    }
    uint half_;
    uvec4 t = radiance_load(radiance_texel(i, half_));
    return unpack_radiance(c == 0u ? t.xy : t.zw);
}

#endif
