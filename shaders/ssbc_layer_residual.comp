#version 460
// SSBC with a second layer, before a further step: the residual S_k at the
// pixels of layer 1 (full or half resolution), each evaluated alone over both
// layers' pyramids: what layer 1's surfaces send in the next step (made
// view-independent, as every source: brdf_source_color).
#include "ssbc_types.glsl"

layout(push_constant) uniform IntegralPush {
    SsbcFrame frame;
    ResidualParams residual;
} pc;

#include "ssbc_pyramid.glsl"
#include "ssbc_pyramid_read.glsl"
#include "ssbc_residual.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 3, rgba32f) uniform readonly image2D g_position;  // layer 1
layout(set = 0, binding = 4, rg32ui) uniform readonly uimage2D g_normal;
layout(set = 0, binding = 5, rg32ui) uniform readonly uimage2D g_albedo;
layout(set = 0, binding = 6, rgba32f) uniform writeonly image2D residual;   // layer 1's S_k

void main() {
    ivec2 q = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(q), layer_image_size(1u)))) return;
    vec4 position = imageLoad(g_position, q);
    vec3 s = vec3(0.0);
    if (position.w != 0.0) {
        vec3 nx = unpack_gbuffer_normal(imageLoad(g_normal, q)).xyz;
        uint count = 0u;
        float variation;
        // Its centre in image pixels (pixel centres at integers).
        vec2 centre = (vec2(q) + 0.5) * float(1u << layer_shift(1u)) - 0.5;
        Residual r = residual_integral(position.xyz, nx, centre, count, variation);
        // What it sends, view-independent (brdf_source_color).
        Brdf b = receiver_brdf(unpack_gbuffer_albedo(imageLoad(g_albedo, q)), unpack_gbuffer_normal(imageLoad(g_normal, q)));
        s = brdf_source_color(b) / PI * residual_at(r, nx);
    }
    imageStore(residual, q, vec4(s, 1.0));
}
