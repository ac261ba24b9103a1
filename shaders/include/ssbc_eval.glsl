#ifndef SSBC_EVAL_GLSL
#define SSBC_EVAL_GLSL
// SSBC evaluation points of level pc.level: the residual integral I(x) (see
// ssbc_residual.glsl) at the evaluation pixel of each texel, for every texel of the
// level (pc.from_list = 0: the coarsest level) or for the texels the resolve
// kernel asked for (pc.from_list = 1: finer levels, near what made
// interpolation fail). A texel that is not one smooth surface (above level
// 1), or where the bounding radius spans fewer than pc.texels_per_radius of
// its texels on screen, is unusable.
//
// Included by ssbc_eval.comp (the points at receivers that are not glossy)
// and, with SSBC_GLOSSY_POINTS defined, ssbc_eval_glossy.comp (the points
// at glossy receivers, which also sum their glossy rest; with ONE_DISPATCH
// every point). In frames with glossy receivers the points come from a
// two-ended list (ssbc_types.glsl), glossy ones at the back, so a SIMD
// group runs one walk. On a CPU device (lavapipe) the two kernels run one
// after the other and a Lambertian point runs none of the glossy code:
// lavapipe runs both sides of a branch. On a GPU, where a level takes as
// long as its slowest walk whatever the number of points, one dispatch
// runs both (ONE_DISPATCH) (measured: docs/accuracy.md, "Tuned constants").
#include "ssbc_types.glsl"

layout(push_constant) uniform EvalPush {
    SsbcFrame frame;
    ResidualParams residual;
    uint level;               // the level whose points are evaluated
    uint from_list;           // 1: the texels of `requests`; 0: every texel of `level`
    uint generation;          // the step's stamp on its points
    float texels_per_radius;  // evaluation texels wanted across the bounding radius 1/sqrt(b)
} pc;

#include "ssbc_pyramid.glsl"
#include "ssbc_pyramid_read.glsl"
#include "ssbc_residual.glsl"

layout(local_size_x = 64) in;

#ifdef SSBC_GLOSSY_POINTS
const bool GLOSSY_KERNEL = true;
#else
const bool GLOSSY_KERNEL = false;
#endif

layout(set = 0, binding = 3, rgba32ui) uniform writeonly uimageBuffer eval_points;  // three per EvalPoint
layout(set = 0, binding = 9, rg32ui) uniform writeonly uimageBuffer point_tails;   // one per EvalPoint
layout(set = 0, binding = 4) readonly buffer Requests { ListHeader header; uint items[]; } requests;
// The shading normal: how the receiver reflects (the pyramid's clusters
// carry the surface's geometric normal, geometric_normal.glsl).
layout(set = 0, binding = 6, rg32ui) uniform readonly uimage2D g_normal;
#ifdef SSBC_GLOSSY_POINTS
layout(set = 0, binding = 7, rg32ui) uniform readonly uimage2D g_albedo;
layout(set = 0, binding = 8, rg32ui) uniform writeonly uimageBuffer point_glossy;  // one per point (pack_point_rest)
#endif

void store_point(uint index, EvalPoint p) {
    int at = int(3u * index);
    imageStore(eval_points, at, floatBitsToUint(p.residual.r));
    imageStore(eval_points, at + 1, floatBitsToUint(p.residual.g));
    imageStore(eval_points, at + 2, floatBitsToUint(p.residual.b));
    imageStore(point_tails, int(index), uvec4(pack_point_tail(p), 0u, 0u));
}

// The point of texel t of level pc.level; `glossy`: at a glossy receiver,
// whose glossy rest is summed too (the lobe refined more coarsely than a
// pixel's own walk, see ssbc_walk.glsl) and written to point_glossy (with
// the step's generation). Pixels of the same material whose lobe points nearly the
// same way interpolate it (ssbc_resolve.comp).
void evaluate(ivec2 t, bool glossy) {
    int l = int(pc.level);
    uint index = texel_index(0u, t, l);
    uint point_slot = point_index(t, l);
    ivec2 q = eval_pixel(t, l);
    uint q_index = texel_index(0u, q, 0);
    bool inside = eval_pixel_inside(t, l);
    GeoCluster g = inside ? geo_cluster(q_index, 0u) : empty_cluster();
    vec3 x = g.position_extent.xyz;
    vec3 nx = inside ? unpack_gbuffer_normal(imageLoad(g_normal, q)).xyz : vec3(0.0);
    float r_world = inversesqrt(pc.frame.bound);
    // A point stands for its block only on one smooth surface, except at
    // level 1: there a pixel is at most a pixel from the points it
    // interpolates, and the resolve's own tests (normal, tangent plane) keep
    // it on the point's surface, so a block across a silhouette or crease
    // still serves the pixels on its point's side; coarser, that let
    // pixels interpolate across edges (measured: docs/accuracy.md, "Tuned constants"). Either way the point's
    // own pixel must be geometry.
    bool usable = cluster_extent(g).y >= 0.0 && (l == 1 || (geo_aux(index).flags & 1u) == 1u)
        && screen_radius(x, r_world) >= pc.texels_per_radius * float(1 << l);
    if (!usable) {
        store_point(point_slot, EvalPoint(Residual(vec4(0.0), vec4(0.0), vec4(0.0)), -1.0, 0.0, pc.generation));
        return;
    }
#ifdef SSBC_GLOSSY_POINTS
    if (glossy) {
        begin_glossy(receiver_brdf(unpack_gbuffer_albedo(imageLoad(g_albedo, q)), unpack_gbuffer_normal(imageLoad(g_normal, q))), x, nx);
        // The lobe refined at half its scale within 3 alpha of its mirror
        // direction, at its whole scale beyond (as the fallback does)
        // (measured: docs/accuracy.md, "Tuned constants").
        glossy_refine = 1.0;
        glossy_refine_near = 0.5;
        glossy_near = 3.0 * glossy_alpha;
    }
#endif
    uint count = 0u;
    float variation;
    Residual residual = residual_integral(x, nx, vec2(q), count, variation);
    store_point(point_slot, EvalPoint(residual, float(count), variation, pc.generation));
#ifdef SSBC_GLOSSY_POINTS
    if (glossy) imageStore(point_glossy, int(point_slot), uvec4(pack_point_rest(glossy_rest, pc.generation), 0u, 0u));
#endif
}

void main() {
    ivec2 t;
    bool glossy = GLOSSY_KERNEL;
    bool both = takes_both_ends(GLOSSY_KERNEL, pc.frame.layers);
    if (pc.from_list == 1u) {
        uint slot;
        LIST_SLOT(requests, slot, glossy, both);
        if (slot == ~0u) return;
        t = unpack_item(requests.items[slot]);
    } else {
        // Every texel of a frame without glossy receivers; one row of work
        // groups per row of the level (no integer division).
        t = ivec2(gl_GlobalInvocationID.xy);
        if (t.x >= level_size(0u, int(pc.level)).x) return;
    }
    evaluate(t, glossy);
}

#endif
