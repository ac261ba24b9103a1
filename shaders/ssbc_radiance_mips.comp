#version 460
// SSBC radiance pyramid of the term being compensated, S_{k-1}, one level
// per dispatch (pc.level): level 0 holds A_y S_{k-1}(y) per pixel, level l
// the sum of its four children, so a texel carries sum(A_y S(y)) under it.
#include "ssbc.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 3, rgba32f) uniform readonly image2D term;  // S_{k-1}, full resolution

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    int level = int(pc.level);
    if (any(greaterThanEqual(p, level_size(level)))) return;
    uint dst = texel_index(p, level);
    if (level == 0) {
        vec3 s = all(lessThan(uvec2(p), pc.size)) ? imageLoad(term, p).rgb : vec3(0.0);
        radiance[dst] = vec4(aux[dst].area * s, 0.0);
        return;
    }
    vec3 sum = vec3(0.0);
    for (int k = 0; k < 4; k++) {
        sum += radiance[texel_index(p * 2 + ivec2(k & 1, k >> 1), level - 1)].rgb;
    }
    radiance[dst] = vec4(sum, 0.0);
}
