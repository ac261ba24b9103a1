// The pyramids as the kernels that read them bind them: texel buffers (a
// texel fetch reads 16 bytes in one gather where a storage-buffer load costs
// lavapipe a per-lane loop for every 4 bytes; src/vk/buffer_view.rs).
// Bindings 0..2 of every such kernel.

#ifndef SSBC_PYRAMID_READ_GLSL
#define SSBC_PYRAMID_READ_GLSL

#include "ssbc_types.glsl"

layout(set = 0, binding = 0) uniform utextureBuffer geo_texels;       // three per GeoTexel
layout(set = 0, binding = 1) uniform utextureBuffer aux_texels;       // one per GeoAux
layout(set = 0, binding = 2) uniform utextureBuffer radiance_texels;  // one per texel: front, back packed

// Cluster c (0 front, 1 back) of texel i.
GeoCluster geo_cluster(uint i, uint c) {
    int at = int(3u * i);
    return unpack_cluster(texelFetch(geo_texels, at + int(c)), texelFetch(geo_texels, at + 2), c);
}

// Both clusters of texel i (three fetches).
GeoTexel geo_texel(uint i) {
    int at = int(3u * i);
    uvec4 normals = texelFetch(geo_texels, at + 2);
    return GeoTexel(unpack_cluster(texelFetch(geo_texels, at), normals, 0u),
                    unpack_cluster(texelFetch(geo_texels, at + 1), normals, 1u));
}

// The areas, pixels and flags of texel i.
GeoAux geo_aux(uint i) {
    uvec4 a = texelFetch(aux_texels, int(i));
    return GeoAux(uintBitsToFloat(a.x), uintBitsToFloat(a.y), a.z, a.w);
}

// Sum of A_y S(y) over cluster c of texel i.
vec3 cluster_radiance(uint i, uint c) {
    uvec4 t = texelFetch(radiance_texels, int(i));
    return unpack_radiance(c == 0u ? t.xy : t.zw);
}

#endif
