#version 460
// SSBC radiance pyramid of the term being compensated, S_{k-1}, one level
// per dispatch (pc.level): level 0 holds A_y S_{k-1}(y) per pixel (its one
// cluster; the part beyond a crease carries the neighbour's), level l sums its children's clusters into the cluster each was
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

// S at pixel p (linear index j) of layer pc.layer's level 0 times its area.
vec3 pixel_sum(ivec2 p, uint j, uint base) {
    vec3 s = all(lessThan(uvec2(p), layer_image_size(pc.layer))) ? imageLoad(term, p).rgb : vec3(0.0);
    return level0_area(imageLoad(geo_words, geo_word(base + j))) * s;  // its area
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    int level = int(pc.level);
    if (level == 0) {
        // Two pixels a texel (ssbc_pyramid.glsl, radiance_texel), by linear
        // index: this invocation's are 2m and 2m + 1, m counted over a grid
        // of ceil(width / 2) x height invocations. A pixel's back cluster
        // keeps no sum of its own (it carries its neighbour's S).
        ivec2 size = level_size(pc.layer, 0);
        uint m = uint(p.y) * uint((size.x + 1) / 2) + uint(p.x);
        uint texels = uint(size.x * size.y);
        if (p.x >= (size.x + 1) / 2 || 2u * m >= texels) return;
        uint base = texel_index(pc.layer, ivec2(0), 0);
        uint j = 2u * m;
        ivec2 first = ivec2(j % uint(size.x), j / uint(size.x));
        ivec2 second = first.x + 1 < size.x ? first + ivec2(1, 0) : ivec2(0, first.y + 1);
        vec3 next = j + 1u < texels ? pixel_sum(second, j + 1u, base) : vec3(0.0);
        store_level0_radiance(base + j, pixel_sum(first, j, base), next);
        return;
    }
    if (any(greaterThanEqual(p, level_size(pc.layer, level)))) return;
    uint dst = texel_index(pc.layer, p, level);
    uint back_mask = geo_aux(dst).flags >> 8;
    vec3 front = vec3(0.0);
    vec3 back = vec3(0.0);
    ivec2 below = level_size(pc.layer, level - 1);
    [[unroll]] for (int k = 0; k < 4; k++) {
        ivec2 child = p * 2 + ivec2(k & 1, k >> 1);
        bool exists = all(lessThan(child, below));  // else empty
        uint c = texel_index(pc.layer, child, level - 1);
        vec3 sums[2] = vec3[2](vec3(0.0), vec3(0.0));
        if (exists) texel_sums(c, sums[0], sums[1]);
        [[unroll]] for (int j = 0; j < 2; j++) {
            vec3 s = sums[j];
            if ((back_mask & (1u << (2 * k + j))) != 0u) {
                back += s;
            } else {
                front += s;
            }
        }
    }
    store_radiance(dst, front, back);
}
