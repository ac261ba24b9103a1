#version 460
// SSBC geometry pyramid, level 0, from a G-buffer layer (pc.build_layer): each pixel's world
// position and unit normal as one cluster, and the world-space area A_y seen
// through it. Kept apart from the coarser levels (ssbc_geometry_mips.comp):
// inside their kernel lavapipe ran this level 3x slower (45 vs 14 ms at
// 1024x768), paying per invocation for code it does not run.
#include "ssbc.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 3, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 4, rgba32f) uniform readonly image2D g_normal;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, level_size(0)))) return;
    uint dst = texel_index(p, 0);
    vec4 position = vec4(0.0);
    vec3 n = vec3(0.0);
    if (all(lessThan(uvec2(p), layer_image_size(pc.build_layer)))) {
        position = imageLoad(g_position, p);
        n = imageLoad(g_normal, p).xyz;
    }
    bool geometry = position.w != 0.0;
    geo[dst] = GeoTexel(geometry ? make_cluster(position.xyz, 0.0, 0.0, n, 1.0) : empty_cluster(), empty_cluster());
    // A layer-1 pixel is 2 x 2 image pixels.
    float area = pixel_area(position.xyz, n) * float(1u << (2u * pc.build_layer));
    aux[dst] = GeoAux(geometry ? area : 0.0, 0.0, geometry ? 1u : 0u,
                      geometry ? 1u : 0u);
}
