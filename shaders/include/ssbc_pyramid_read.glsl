// The pyramids as the kernels that read them bind them: texel buffers (a
// texel fetch reads 16 bytes in one gather where a storage-buffer load costs
// lavapipe a per-lane loop for every 4 bytes; src/vk/buffer_view.rs).
// Bindings 0..2 of every such kernel, and 20 and 21: the G-buffer
// positions of both layers, which level 0's texels take theirs from.

#ifndef SSBC_PYRAMID_READ_GLSL
#define SSBC_PYRAMID_READ_GLSL

#include "ssbc_types.glsl"

layout(set = 0, binding = 0) uniform utextureBuffer geo_texels;       // three per GeoTexel (level 0: one)
layout(set = 0, binding = 1) uniform utextureBuffer aux_texels;       // one per GeoAux (none at level 0)
layout(set = 0, binding = 2) uniform utextureBuffer radiance_texels;  // one per texel: front, back packed (level 0: half, the front's)

layout(set = 0, binding = 20, rgba32f) uniform readonly image2D level0_position0;  // layer 0's G-buffer position
layout(set = 0, binding = 21, rgba32f) uniform readonly image2D level0_position1;  // layer 1's (layer 0's without one)

uvec4 geo_load(int at) { return texelFetch(geo_texels, at); }
uvec4 aux_load(int at) { return texelFetch(aux_texels, at); }
uvec4 radiance_load(int at) { return texelFetch(radiance_texels, at); }

#include "ssbc_pyramid_access.glsl"

// Both clusters of texel i (three fetches; at level 0 one and the
// position, a crease pixel's back cluster one and a position more).
GeoTexel geo_texel(uint i) {
    int at = geo_word(i);
    uvec4 a = geo_load(at);
    if (is_level0(i)) {
        vec3 x = level0_position(i);
        return GeoTexel(level0_front(x, a), level0_back_of(i, x, a));
    }
    uvec4 b = geo_load(at + 1);
    uvec4 normals = geo_load(at + 2);
    return GeoTexel(unpack_cluster(a, normals, 0u), unpack_cluster(b, normals, 1u));
}

// Both clusters' sums of texel i.
void texel_radiance(uint i, out vec3 front, out vec3 back) {
    uint half_;
    uvec4 t = radiance_load(radiance_texel(i, half_));
    bool level0 = is_level0(i);
    front = unpack_radiance(level0 && half_ == 1u ? t.zw : t.xy);
    back = level0 ? level0_back_radiance(i, geo_load(geo_word(i))) : unpack_radiance(t.zw);
}

#endif
