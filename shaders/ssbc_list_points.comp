#version 460
// SSBC: the evaluation points of the coarsest level, pc.level, as a
// two-ended list (ssbc_types.glsl) for ssbc_eval.glsl in frames with glossy
// receivers: points at glossy receivers at the back. Once per frame; every
// step evaluates the same texels.
#include "ssbc_types.glsl"

layout(push_constant) uniform ListPointsPush {
    SsbcFrame frame;
    uint level;               // the coarsest level of evaluation points
} pc;

#include "ssbc_pyramid.glsl"
#include "ssbc_pyramid_read.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 3) buffer Points { ListHeader header; uint items[]; } points;

void main() {
    // One row of work groups per row of the level (no integer division).
    ivec2 t = ivec2(gl_GlobalInvocationID.xy);
    int l = int(pc.level);
    if (t.x >= level_size(0u, l).x) return;
    bool glossy = eval_pixel_inside(t, l)
        && (geo_aux(texel_index(0u, eval_pixel(t, l), 0)).flags & GLOSSY_RECEIVER) != 0u;
    APPEND_ITEM_TO(points, pack_item(t), glossy);
}
