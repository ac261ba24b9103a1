#version 460
// SSBC evaluation points of level pc.level: the residual integral I(x) (see
// ssbc.glsl) at the evaluation pixel of each texel, for every texel of the
// level (pc.from_list = 0: the coarsest level) or for the texels the resolve
// kernel asked for (pc.from_list = 1: finer levels, near what made
// interpolation fail). A texel that is not one smooth surface (above level
// 1), or where the bounding radius spans fewer than pc.texels_per_radius of
// its texels on screen, is unusable.
#define SSBC_READ_PYRAMIDS
#include "ssbc.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 3) buffer EvalPoints { EvalPoint points[]; };
layout(set = 0, binding = 4) readonly buffer Requests { ListHeader header; uint items[]; } requests;

void main() {
    int l = int(pc.level);
    uint i = gl_GlobalInvocationID.x;
    ivec2 size_l = level_size(l);
    ivec2 t;
    if (pc.from_list == 1u) {
        if (i >= requests.header.count) return;
        t = unpack_item(requests.items[i]);
    } else {
        // One row of work groups per row of the level (no integer division).
        t = ivec2(gl_GlobalInvocationID.xy);
        if (t.x >= size_l.x) return;
    }
    uint index = texel_index(t, l);
    ivec2 q = eval_pixel(t, l);
    GeoCluster g = geo_cluster(texel_index(q, 0), 0u);
    vec3 x = g.position_extent.xyz;
    float r_world = inversesqrt(pc.bound);
    // A point stands for its block only on one smooth surface, except at
    // level 1: there a pixel is at most a pixel from the points it
    // interpolates, and the resolve's own tests (normal, tangent plane) keep
    // it on the point's surface, so a block across a silhouette or crease
    // still serves the pixels on its point's side (tori 1024x768: 4.1 ->
    // 3.7% of pixels alone, traversal -12%). Coarser, that let pixels
    // interpolate across edges (cornell 640x480: 1.2 -> 4.2% RMSE). Either
    // way the point's own pixel must be geometry.
    bool usable = cluster_extent(g).y >= 0.0 && (l == 1 || (aux[index].flags & 1u) == 1u)
        && (l == 0 || screen_radius(x, r_world) >= pc.texels_per_radius * float(1 << l));
    if (!usable) {
        points[index] = EvalPoint(Residual(vec4(0.0), vec4(0.0), vec4(0.0)), -1.0, 0.0, pc.generation, 0u);
        return;
    }
    uint count = 0u;
    float variation;
    Residual residual = residual_integral(x, g.normal_cone.xyz, vec2(q), count, variation);
    points[index] = EvalPoint(residual, float(count), variation, pc.generation, 0u);
}
