#version 460
// ISM point splatting: every VPL splats its own block of scene points (the
// one its identity picks, position.w) into its paraboloid tile with atomicMin
// on the packed distance and how squarely the point's surface faces the
// VPL (ism_pack). Points come placed in world space (ism_points.comp; w:
// their surface's packed normal, 0: a hidden object's).
#include "ism.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 0, r32ui) uniform uimage2D ism_depth;
layout(set = 0, binding = 1) readonly buffer Vpls { GpuVpl vpls[]; };
layout(set = 0, binding = 2) readonly buffer Points { vec4 points[]; }; // xyz world, w normal (0: hidden)

layout(push_constant) uniform Push {
    uint vpl_count;
    uint points_per_vpl;
    uint tile;
    uint tiles_per_row;
    float depth_scale;   // 1 / far: distances are stored as d * depth_scale
    float point_radius;  // world radius each point stands for
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint v = gl_GlobalInvocationID.y;
    if (i >= pc.points_per_vpl || v >= pc.vpl_count) return;
    GpuVpl vpl = vpls[v];
    uint block = floatBitsToUint(vpl.position.w);
    vec4 point = points[block * pc.points_per_vpl + i];
    uint normal_bits = floatBitsToUint(point.w);
    if (normal_bits == 0u) return; // a hidden object's
    vec3 p = point.xyz;
    vec3 d = p - vpl.position.xyz;
    float dist = length(d);
    if (dist < 1e-5) return;
    vec3 w = d / dist;
    if (dot(w, vpl.normal.xyz) <= 0.0) return;
    vec2 uv = ism_paraboloid(w, vpl.normal.xyz);
    // Footprint in texels: the paraboloid maps a small angle a near the pole
    // to a/4 of the tile; larger splats near the VPL close holes.
    float radius_texels = clamp(pc.point_radius / dist * float(pc.tile) * 0.25, 0.0, 3.0);
    int r = int(radius_texels);
    uint depth = ism_pack(dist * pc.depth_scale, abs(dot(w, ism_unpack_normal(normal_bits))));
    uint cell = floatBitsToUint(vpl.normal.w);
    ivec2 origin = ivec2(cell & 0xFFFFu, cell >> 16) * int(pc.tile);
    ivec2 center = ivec2(uv * float(pc.tile));
    for (int dy = -r; dy <= r; dy++) {
        for (int dx = -r; dx <= r; dx++) {
            if (dx * dx + dy * dy > r * r) continue;
            ivec2 local = center + ivec2(dx, dy);
            if (any(lessThan(local, ivec2(0))) || any(greaterThanEqual(local, ivec2(int(pc.tile))))) continue;
            imageAtomicMin(ism_depth, origin + local, depth);
        }
    }
}
