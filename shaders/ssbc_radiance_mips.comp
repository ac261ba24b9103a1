#version 460
#extension GL_EXT_control_flow_attributes : require
// SSBC radiance pyramid of the term being compensated, S_{k-1}, one level
// per dispatch (pc.level): level 0 holds A_y S_{k-1}(y) per pixel (its one
// cluster), level l sums its children's clusters into the cluster each was
// grouped into (GeoAux.flags), so a cluster carries sum(A_y S(y)) over its
// pixels.
#include "ssbc.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 3, rgba32f) uniform readonly image2D term;  // S_{k-1} of layer pc.build_layer

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    int level = int(pc.level);
    if (any(greaterThanEqual(p, level_size(level)))) return;
    uint dst = texel_index(p, level);
    if (level == 0) {
        // The back cluster is a neighbour's surface beyond a crease and
        // carries that neighbour's term (ssbc_geometry_base.comp).
        GeoAux a = aux[dst];
        uint code = (a.flags >> 1) & 15u;
        vec3 s = all(lessThan(uvec2(p), layer_image_size(pc.build_layer))) ? imageLoad(term, p).rgb : vec3(0.0);
        vec3 s_back = code > 0u ? imageLoad(term, p + CREASE_NEIGHBOURS[code - 1u]).rgb : vec3(0.0);
        radiance[2u * dst] = vec4(a.front_area * s, 0.0);
        radiance[2u * dst + 1u] = vec4(a.back_area * s_back, 0.0);
        return;
    }
    uint back_mask = aux[dst].flags >> 8;
    vec3 front = vec3(0.0);
    vec3 back = vec3(0.0);
    [[unroll]] for (int k = 0; k < 4; k++) {
        uint c = texel_index(p * 2 + ivec2(k & 1, k >> 1), level - 1);
        [[unroll]] for (int j = 0; j < 2; j++) {
            vec3 s = radiance[2u * c + uint(j)].rgb;
            if ((back_mask & (1u << (2 * k + j))) != 0u) {
                back += s;
            } else {
                front += s;
            }
        }
    }
    radiance[2u * dst] = vec4(front, 0.0);
    radiance[2u * dst + 1u] = vec4(back, 0.0);
}
