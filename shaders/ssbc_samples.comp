#version 460
// SSBC texels read per pixel: to each pixel's own reads (fallback) add its
// share of every evaluation point of this step whose block it is in (the
// point's reads divided by the block's pixels with geometry), so that the
// image sums to every texel read in the step. At least CUT_SHORT: the
// residual there was cut short by the device's loop limit.
#define SSBC_READ_PYRAMIDS
#include "ssbc.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 3) uniform usamplerBuffer point_texels;  // points[] as texels
layout(set = 0, binding = 4, r32f) uniform image2D samples;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(p), pc.size))) return;
    if (aux[texel_index(p, 0)].pixels == 0u) return;
    float reads = imageLoad(samples, p).x;
    for (int l = 0; l <= int(pc.eval_level); l++) {
        uint index = texel_index(p >> l, l);
        EvalPoint point = load_point(point_texels, index);
        if (point.generation == pc.generation && point.reads > 0.0) {
            // A point whose loops were cut short marks every pixel of its block.
            bool cut_short = point.reads >= float(CUT_SHORT);
            reads += cut_short ? float(CUT_SHORT) : point.reads / float(aux[index].pixels);
        }
    }
    imageStore(samples, p, vec4(reads));
}
