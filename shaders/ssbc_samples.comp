#version 460
// SSBC texels read per pixel: to each pixel's own reads (fallback) add its
// share of every evaluation point of this step whose block it is in (the
// point's reads divided by the block's pixels with geometry), so that the
// image sums to every texel read in the step. At least CUT_SHORT: the
// residual there was cut short by the device's loop limit.
#include "ssbc_types.glsl"

layout(push_constant) uniform SamplesPush {
    SsbcFrame frame;
    uint eval_level;          // coarsest level of evaluation points
    uint generation;          // the step's stamp on its points
} pc;

#include "ssbc_pyramid.glsl"
#include "ssbc_pyramid_read.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 3) uniform utextureBuffer point_tails;  // the points' tails (EvalPoint)
layout(set = 0, binding = 4, r32f) uniform image2D samples;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(p), pc.frame.size))) return;
    if (geo_aux(texel_index(0u, p, 0)).pixels == 0u) return;
    float reads = imageLoad(samples, p).x;
    for (int l = 1; l <= int(pc.eval_level); l++) {
        uint index = texel_index(0u, p >> l, l);
        EvalPoint point = load_point_tail(point_tails, point_index(p >> l, l));
        if (point.generation == pc.generation && point.reads > 0.0) {
            // A point whose loops were cut short marks every pixel of its block.
            bool cut_short = point.reads >= float(CUT_SHORT);
            reads += cut_short ? float(CUT_SHORT) : point.reads / float(geo_aux(index).pixels);
        }
    }
    imageStore(samples, p, vec4(reads));
}
