#ifndef SSBC_FALLBACK_GLSL
#define SSBC_FALLBACK_GLSL
// SSBC fallback: the residual integral at the pixels no evaluation point can
// stand for (at corners, contacts and silhouettes, and glossy receivers
// whose lobe no point shares), each from its own position, normal and
// BRDF. Dispatched indirectly over the fallback list (bound as pending_in).
//
// Like the evaluation points (ssbc_eval.glsl), glossy receivers (marked by
// the geometry pass) are at the back of the fallback list, for
// ssbc_fallback_glossy.comp, which defines SSBC_GLOSSY_FALLBACK (and with
// ONE_DISPATCH takes the front too): on a CPU device a pixel here never
// runs the glossy walk, and a SIMD group never runs both: Lambertian
// frames gain the most (measured: docs/accuracy.md, "Tuned constants").
#include "ssbc_types.glsl"

layout(push_constant) uniform IntegralPush {
    SsbcFrame frame;
    ResidualParams residual;
} pc;

#include "ssbc_pyramid.glsl"
#include "ssbc_pyramid_read.glsl"
#include "ssbc_residual.glsl"
#include "ssbc_output.glsl"

layout(local_size_x = 64) in;

#ifdef SSBC_GLOSSY_FALLBACK
const bool GLOSSY_KERNEL = true;
#else
const bool GLOSSY_KERNEL = false;
#endif

// One pixel of the fallback list. A receiver that is not glossy takes
// its BRDF at the sources' mean direction if nearly Lambertian, as where
// it interpolates points (ssbc_resolve.comp).
// A glossy one (only in the glossy kernel) walks with its BRDF, refined by
// its lobe (ssbc_walk.glsl), finely only within 3 alpha of its mirror
// direction (at the whole angular scale beyond). `rest_only`: its
// evaluation points stood for its Lambertian part but not for its glossy
// rest, and the resolve kernel wrote what they give; the walk adds the
// glossy rest, at a quarter of the lobe's scale near the mirror and with
// the geometric refinement 5x coarser (REST_ONLY_COARSER). Other glossy
// pixels are alone for their geometry (silhouettes, contacts): their lobe
// at 0.75 of its scale near the mirror (measured: docs/accuracy.md, "Tuned
// constants").
// Both kinds share one call of residual_integral: it is most of the
// kernel, and LLVM's compile time grows faster than the code (Mesa 22.3,
// while the brute force was in every kernel: 619 s for the glossy kernel
// with two calls, 197 s with one; docs/development.md).
void fallback(ivec2 p, bool glossy, bool rest_only) {
    vec3 x = imageLoad(g_position, p).xyz;
    vec3 nx = unpack_gbuffer_normal(imageLoad(g_normal, p)).xyz;
    Brdf b = pixel_brdf(p);
    if (glossy) {
        begin_glossy(b, x, nx);
        glossy_refine = 1.0;
        glossy_refine_near = rest_only ? 0.25 : 0.75;
        glossy_near = 3.0 * glossy_alpha;
        glossy_rest_only = rest_only;
    }
    uint count = 0u;
    float variation;
    Residual residual = residual_integral(x, nx, vec2(p), count, variation);
    vec3 integral = residual_at(residual, nx);
    if (glossy && rest_only) {
        add_glossy_rest(p, glossy_rest, float(count));
    } else if (glossy) {
        write_residual(p, b, integral, glossy_rest, float(count));
    } else {
        vec3 wo = normalize(pc.frame.camera_position.xyz - x);
        vec3 rest = brdf_is_lambertian(b) ? vec3(0.0) : nearly_lambertian_rest(b, nx, wo, residual, integral);
        write_residual(p, b, integral, rest, float(count));
    }
}

void main() {
    uint slot;
    bool glossy = GLOSSY_KERNEL;
    bool both = takes_both_ends(GLOSSY_KERNEL, pc.frame.layers);
    LIST_SLOT(pending_in, slot, glossy, both);
    if (slot == ~0u) return;
    uint item = pending_in.items[slot];
    // (glossy stays false in the Lambertian kernel: its glossy code folds away.)
    fallback(unpack_item(item), GLOSSY_KERNEL && glossy, (item & REST_ONLY) != 0u);
}
#endif
