#version 460
// dst = a + b (rgb), alpha from a: composes the final image from its terms.

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D a;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D b;
layout(set = 0, binding = 2, rgba32f) uniform writeonly image2D dst;

layout(push_constant) uniform Push {
    uvec2 size;
} pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(p), pc.size))) return;
    vec4 va = imageLoad(a, p);
    imageStore(dst, p, vec4(va.rgb + imageLoad(b, p).rgb, va.w));
}
