#version 460
// Indirect light alone: an image less the direct light. S0 less it is the
// bounded VPL light T_b L^; the final image less it T_b L^ + S_1 + ... + S_K
// (history-averaged where the final image is), for hosts that light directly
// themselves. Alpha is the image's (1 on geometry).

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D image;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D direct;
layout(set = 0, binding = 2, rgba32f) uniform writeonly image2D indirect;

layout(push_constant) uniform Push {
    uvec2 size;
} pc;

void main() {
    ivec2 q = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(q), pc.size))) return;
    vec4 f = imageLoad(image, q);
    imageStore(indirect, q, vec4(f.rgb - imageLoad(direct, q).rgb, f.a));
}
