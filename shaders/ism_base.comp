#version 460
// ISM coarse layer: every texel of a VPL's tile starts from the ray-cast
// surface of its block (src/cpu/ism_rays.rs) instead of "no point", so that
// occluders near the VPL, which get few points, still shadow; the splat then
// adds the points' finer detail with atomicMin. Each texel takes the plane
// of the surface its nearest corner ray met (exact where that surface is
// flat), evaluated at the texel's centre ray; a corner whose ray met
// nothing gives its distance, without a plane.
#include "ism.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 0, r32ui) uniform writeonly uimage2D ism_depth;
layout(set = 0, binding = 1) readonly buffer Vpls { GpuVpl vpls[]; };
// Per corner ray, (grid + 1)^2 per VPL: x the plane's offset from the VPL
// along its normal (without a plane: the distance), y the normal's bits
// (ism_pack_normal; 0: none).
layout(set = 0, binding = 2) readonly buffer Base { vec2 base[]; };

layout(push_constant) uniform Push {
    uint vpl_count;
    uint tile;
    uint grid;          // blocks per tile side (corner rays: grid + 1 a side)
    float depth_scale;  // 1 / far, as the splat stores distances
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint v = gl_GlobalInvocationID.y;
    if (i >= pc.tile * pc.tile || v >= pc.vpl_count) return;
    uvec2 local = uvec2(i % pc.tile, i / pc.tile);
    uvec2 corner = uvec2(round((vec2(local) + 0.5) * float(pc.grid) / float(pc.tile)));
    uint side = pc.grid + 1u;
    vec2 plane = base[v * side * side + corner.y * side + corner.x];
    GpuVpl vpl = vpls[v];
    uint normal_bits = floatBitsToUint(plane.y);
    uint packed = ism_pack(plane.x * pc.depth_scale, 0u);
    if (normal_bits != 0u) {
        vec3 normal = ism_unpack_normal(normal_bits);
        float along = dot(normal, ism_texel_direction(vpl.normal.xyz, ivec2(local), pc.tile));
        // A texel whose centre ray runs along the plane or away from it
        // lies past the surface's edge: nothing of it there.
        packed = plane.x * along > 0.0 && abs(along) > 0.02
            ? ism_pack(plane.x / along * pc.depth_scale, ism_pack_plane_normal(normal))
            : ism_pack(ISM_DEPTH_RANGE, 0u);
    }
    uint cell = floatBitsToUint(vpl.normal.w);
    ivec2 origin = ivec2(cell & 0xFFFFu, cell >> 16) * int(pc.tile);
    imageStore(ism_depth, origin + ivec2(local), uvec4(packed));
}
