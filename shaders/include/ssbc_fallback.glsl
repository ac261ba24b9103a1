#ifndef SSBC_FALLBACK_GLSL
#define SSBC_FALLBACK_GLSL
// SSBC fallback: the residual integral at the pixels no evaluation point can
// stand for (at corners, contacts and silhouettes, and glossy receivers
// whose lobe no point shares), each from its own position, normal and
// BRDF. Dispatched indirectly over the fallback list (bound as pending_in).
//
// Like the evaluation points (ssbc_eval.glsl), glossy receivers (marked by
// the geometry pass) are listed (pending_out) for ssbc_fallback_glossy.comp,
// which defines SSBC_GLOSSY_FALLBACK: here a pixel never runs the glossy
// walk, and a SIMD group never runs both. Lambertian frames gain the most:
// the Lambertian twin of spheres at 1024x768 took 152 -> 97 ms here with
// the glossy code behind a per-pixel test removed.
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

#ifndef SSBC_GLOSSY_FALLBACK
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pending_in.header.count) return;
    ivec2 p = unpack_item(pending_in.items[i]);
    if ((geo_aux(texel_index(0u, p, 0)).flags & GLOSSY_RECEIVER) != 0u) {
        APPEND_ITEM(pending_out, pack_item(p));
        return;
    }
    vec3 x = imageLoad(g_position, p).xyz;
    vec3 nx = imageLoad(g_normal, p).xyz;
    uint count = 0u;
    float variation;
    Residual residual = residual_integral(x, nx, vec2(p), count, variation);
    vec3 integral = residual_at(residual, nx);
    // A nearly Lambertian receiver takes its BRDF at the sources' mean
    // direction, as where it interpolates points (ssbc_resolve.comp).
    Brdf b = pixel_brdf(p);
    vec3 wo = normalize(pc.frame.camera_position.xyz - x);
    vec3 rest = brdf_is_lambertian(b) ? vec3(0.0) : nearly_lambertian_rest(b, nx, wo, residual, integral);
    write_residual(p, b, integral, rest, float(count));
}
#else
// The listed glossy receivers: the walk with their BRDF, refined by their
// lobe (ssbc_walk.glsl).
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pending_in.header.count) return;
    ivec2 p = unpack_item(pending_in.items[i]);
    vec3 x = imageLoad(g_position, p).xyz;
    vec3 nx = imageLoad(g_normal, p).xyz;
    Brdf b = pixel_brdf(p);
    begin_glossy(b, x, nx);
    uint count = 0u;
    float variation;
    Residual residual = residual_integral(x, nx, vec2(p), count, variation);
    write_residual(p, b, residual_at(residual, nx), glossy_rest, float(count));
}
#endif
#endif
