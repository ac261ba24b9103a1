#version 460
// ISM coarse layer: every texel of a VPL's tile starts from the ray-cast
// distance of its block (src/cpu/ism_rays.rs) instead of "no point", so that
// occluders near the VPL, which get few points, still shadow; the splat then
// adds the points' finer detail with atomicMin. A block carries how
// squarely its surface faces the VPL (ism_pack), or the plane all its
// corners met (ism_layer_texel). In tiles whose blocks
// span more texels (ism_rays::layer_slack), the tile starts empty and the
// fill combines the splat with the blocks (with_layer in ism_fill.glsl).
#include "ism.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 0, r32ui) uniform writeonly uimage2D ism_depth;
layout(set = 0, binding = 1) readonly buffer Vpls { GpuVpl vpls[]; };
layout(set = 0, binding = 2) readonly buffer Base { LayerBlock base[]; }; // grid^2 per VPL

layout(push_constant) uniform Push {
    uint vpl_count;
    uint tile;
    uint grid;          // blocks per tile side
    float depth_scale;  // 1 / far, as the splat stores distances
    uint back_faces;    // 1: the atlas holds back-face maps (ism_back_texel)
    uint deferred;      // 1: start empty, the fill combines the layer
} pc;

void main() {
    // One invocation writes a block's texels (`span` x `span` of them: the
    // block's side, or 1 in tiles finer than the grid), reading the block
    // and the VPL's tile and setting up the block's plane once for them
    // (cornell 320x240: 13.5 -> 6.0 ms with a row of a block against one a
    // texel; with the planes 15 ms a row, 9.7 ms a block;
    // docs/performance.md).
    uint span = max(pc.tile / pc.grid, 1u);
    uint side = pc.tile / span;
    uint i = gl_GlobalInvocationID.x;
    uint v = gl_GlobalInvocationID.y;
    if (i >= side * side || v >= pc.vpl_count) return;
    uvec2 first = uvec2(i % side, i / side) * span;
    uvec2 block = first * pc.grid / pc.tile;
    LayerBlock b = base[v * pc.grid * pc.grid + block.y * pc.grid + block.x];
    uint cell = floatBitsToUint(vpls[v].normal.w);
    ivec2 origin = ivec2(cell & 0xFFFFu, cell >> 16) * int(pc.tile) + ivec2(first);
    // The block's plane in the VPL's frame, once for the block.
    vec3 n = vpls[v].normal.xyz, t, bt;
    orthonormal_basis(n, t, bt);
    vec3 m = ism_layer_normal(b);
    vec3 m_local = vec3(dot(m, t), dot(m, bt), dot(m, n));
    uint code = ism_normal_code(m);
    float beyond = ism_layer_far(b);
    // A back-face map starts empty: the layer's rays stop at front faces.
    int height = imageSize(ism_depth).y;
    for (uint y = 0u; y < span; y++) {
        for (uint x = 0u; x < span; x++) {
            ivec2 at = ivec2(x, y);
            uint texel = pc.deferred != 0u
                ? ISM_EMPTY
                : ism_layer_texel(b, beyond, ivec2(first) + at, pc.tile, m_local, code, 1.0 / pc.depth_scale);
            imageStore(ism_depth, origin + at, uvec4(texel));
            if (pc.back_faces != 0u)
                imageStore(ism_depth, ism_back_texel(origin + at, height), uvec4(ISM_EMPTY));
        }
    }
}
