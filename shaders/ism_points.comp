#version 460
// ISM points to world space, once per redraw: each point (stored in its
// object's space, w the object) placed by its object's transform, with its
// surface normal (w: ism_pack_normal); a hidden object's points get w = 0
// and are not splatted. Each point's disc (its radius, and where it ends
// at an edge of its surface: src/cpu/point_discs.rs) turns with it. (Placing them in the splat instead repeats the
// transform for every VPL sharing a block; placing runs only when the
// points or the objects changed (measured: docs/accuracy.md, "Tuned constants").)
#include "common.glsl"
#include "ism.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 0) readonly buffer Points { vec4 points[]; };
layout(set = 0, binding = 1) readonly buffer Objects { GpuObject objects[]; };
layout(set = 0, binding = 2) writeonly buffer WorldPoints { vec4 world_points[]; };
layout(set = 0, binding = 3) readonly buffer Normals { uint normals[]; };  // object space, packed
layout(set = 0, binding = 4) readonly buffer Discs { uint discs[]; };  // object space, ism_pack_disc
layout(set = 0, binding = 5) writeonly buffer WorldDiscs { uint world_discs[]; };

layout(push_constant) uniform Push {
    uint count;
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    vec4 point = points[i];
    uint o = floatBitsToUint(point.w);
    bool hidden = objects[o].params.y == 0u;
    world_points[i] = hidden
        ? vec4(0.0)
        : vec4((objects[o].model * vec4(point.xyz, 1.0)).xyz,
               uintBitsToFloat(ism_pack_normal(normalize(mat3(objects[o].normal_matrix) * ism_unpack_normal(normals[i])))));
    // A clip is the half-plane dot(u, dir) <= distance of the disc's plane;
    // under the object's linear map M it becomes dot(v, M^-T dir) <=
    // distance, so its direction turns with the normal matrix and its
    // distance divides by |M^-T dir|, times the object's mean scale, which
    // the distance (sampled in world units) already holds (exact for rigid
    // moves and uniform scales). The disc's radius stays a fraction of the
    // point radius.
    uint disc = discs[i];
    uint code = disc >> 24;
    if (hidden || code == 0u) {
        world_discs[i] = disc;
        return;
    }
    mat3 linear = mat3(objects[o].model);
    vec3 dir = mat3(objects[o].normal_matrix) * ism_unpack_clip_dir(disc);
    float stretch = length(dir) * pow(abs(determinant(linear)), 1.0 / 3.0);
    // (Rounded up, less a rounding error: an unscaled clip keeps its code.)
    uint scaled = uint(clamp(ceil(float(code) / max(stretch, 1e-6) - 1e-3), 1.0, 255.0));
    world_discs[i] = ism_pack_disc(normalize(dir), (scaled << 24) | (disc & 0x00F00000u));
}
