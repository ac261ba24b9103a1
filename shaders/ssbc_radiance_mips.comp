#version 460
// SSBC radiance pyramid of the term being compensated, S_{k-1}, one level
// per dispatch (pc.level): level 0 holds A_y S_{k-1}(y) per pixel (its one
// cluster), level l sums its children's clusters into the cluster each was
// grouped into (GeoAux.flags), so a cluster carries sum(A_y S(y)) over its
// pixels.
#include "ssbc_types.glsl"

layout(push_constant) uniform RadiancePush {
    SsbcFrame frame;
    uint layer;               // the pyramid built
    uint level;               // the level written
} pc;

#include "ssbc_pyramid.glsl"
#include "ssbc_pyramid_write.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 3, rgba32f) uniform readonly image2D term;  // S_{k-1} of layer pc.layer

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    int level = int(pc.level);
    if (any(greaterThanEqual(p, level_size(pc.layer, level)))) return;
    uint dst = texel_index(pc.layer, p, level);
    if (level == 0) {
        // The back cluster is a neighbour's surface beyond a crease and
        // carries that neighbour's term (ssbc_geometry_base.comp).
        GeoAux a = geo_aux(dst);
        uint code = (a.flags >> 1) & 15u;
        vec3 s = all(lessThan(uvec2(p), layer_image_size(pc.layer))) ? imageLoad(term, p).rgb : vec3(0.0);
        vec3 s_back = code > 0u ? imageLoad(term, p + CREASE_NEIGHBOURS[code - 1u]).rgb : vec3(0.0);
        store_radiance(dst, a.front_area * s, a.back_area * s_back);
        return;
    }
    uint back_mask = geo_aux(dst).flags >> 8;
    vec3 front = vec3(0.0);
    vec3 back = vec3(0.0);
    ivec2 below = level_size(pc.layer, level - 1);
    [[unroll]] for (int k = 0; k < 4; k++) {
        ivec2 child = p * 2 + ivec2(k & 1, k >> 1);
        bool exists = all(lessThan(child, below));  // else empty
        uint c = texel_index(pc.layer, child, level - 1);
        [[unroll]] for (int j = 0; j < 2; j++) {
            vec3 s = exists ? cluster_radiance(c, uint(j)) : vec3(0.0);
            if ((back_mask & (1u << (2 * k + j))) != 0u) {
                back += s;
            } else {
                front += s;
            }
        }
    }
    store_radiance(dst, front, back);
}
