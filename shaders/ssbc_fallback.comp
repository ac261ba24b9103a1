#version 460
// SSBC fallback: the residual integral at the pixels no evaluation point can
// stand for (at corners, contacts and silhouettes, and every glossy
// receiver), each from its own position, normal and BRDF. Dispatched
// indirectly over the fallback list (bound as pending_in).
#include "ssbc_types.glsl"

layout(push_constant) uniform FallbackPush {
    SsbcFrame frame;
    ResidualParams residual;
} pc;

#include "ssbc_pyramid.glsl"
#include "ssbc_pyramid_read.glsl"
#include "ssbc_residual.glsl"
#include "ssbc_output.glsl"

layout(local_size_x = 64) in;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pending_in.header.count) return;
    ivec2 p = unpack_item(pending_in.items[i]);
    vec3 x = imageLoad(g_position, p).xyz;
    vec3 nx = imageLoad(g_normal, p).xyz;
    Brdf b = pixel_brdf(p);
    glossy_active = !brdf_is_lambertian(b);
    glossy_brdf = b;
    glossy_wo = normalize(pc.frame.camera_position.xyz - x);
    glossy_mirror = reflect(-glossy_wo, nx);
    glossy_alpha = brdf_alpha(b);
    uint count = 0u;
    float variation;
    Residual residual = residual_integral(x, nx, vec2(p), count, variation);
    write_residual(p, b, residual_at(residual, nx), glossy_rest, float(count));
}
