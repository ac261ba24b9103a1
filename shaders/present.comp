#version 460
// Viewer output: linear radiance -> exposure -> clamp -> sRGB 8-bit, in the
// swapchain's channel order (the result is copied into the swapchain image).

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D radiance;
layout(set = 0, binding = 1, rgba8) uniform writeonly image2D display;

layout(push_constant) uniform Push {
    uvec2 size;
    float exposure;
    uint swap_red_blue;   // 1 for a BGRA swapchain
} pc;

vec3 srgb_encode(vec3 x) {
    return mix(12.92 * x, 1.055 * pow(x, vec3(1.0 / 2.4)) - 0.055, greaterThan(x, vec3(0.0031308)));
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(p), pc.size))) return;
    vec3 c = srgb_encode(clamp(imageLoad(radiance, p).rgb * pc.exposure, 0.0, 1.0));
    imageStore(display, p, vec4(pc.swap_red_blue == 1u ? c.bgr : c, 1.0));
}
