#version 460
// ISM texels traced (`Visibility::Traced`, devices with ray queries): each
// texel of a VPL's tile holds where its own centre ray first meets the
// scene and the normal of the triangle it meets there, instead of the
// nearest splatted point. No holes, no discs past a surface's edge: what
// is left of the ISM's error is the texel's size (an occluder's edge
// within a texel) and the test's tolerances (docs/accuracy.md). Its tiles
// map the hemisphere as splatted ones do (ism_map, ism_projected_local in ism.glsl).
#extension GL_EXT_ray_query : require
#include "common.glsl"
#include "ism.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 0, r32ui) uniform writeonly uimage2D ism_depth;
layout(set = 0, binding = 1) readonly buffer Vpls { GpuVpl vpls[]; };
layout(set = 0, binding = 2) uniform accelerationStructureEXT scene_tlas;
layout(set = 0, binding = 3) readonly buffer Objects { GpuObject objects[]; };
layout(set = 0, binding = 4) readonly buffer Vertices { float vertex_words[]; };  // scene::Vertex
layout(set = 0, binding = 5) readonly buffer Indices { uint indices[]; };
// Per mesh, its first index and first vertex (GpuScene::mesh_ranges).
layout(set = 0, binding = 6) readonly buffer MeshRanges { uvec2 mesh_ranges[]; };

layout(push_constant) uniform Push {
    uint vpl_count;
    uint tile;
    uint vertex_words;  // 32-bit words per scene::Vertex (its position first)
    float depth_scale;  // 1 / far
} pc;

// Corner k of triangle `primitive` of the mesh at `range`, in its object's space.
vec3 corner(uvec2 range, uint primitive, uint k) {
    uint v = (indices[range.x + 3u * primitive + k] + range.y) * pc.vertex_words;
    return vec3(vertex_words[v], vertex_words[v + 1u], vertex_words[v + 2u]);
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint v = gl_GlobalInvocationID.y;
    if (i >= pc.tile * pc.tile || v >= pc.vpl_count) return;
    ivec2 local = ivec2(i % pc.tile, i / pc.tile);
    GpuVpl vpl = vpls[v];
    uint cell = floatBitsToUint(vpl.normal.w);
    ivec2 texel = ivec2(cell & 0xFFFFu, cell >> 16) * int(pc.tile) + local;
    vec3 n = vpl.normal.xyz;
    vec3 t, b;
    orthonormal_basis(n, t, b);
    // Projected tiles (ism.glsl): beyond the horizon, in the tile's corners
    // (a fifth of the texels), no receiver's direction lands: nothing is
    // traced there.
    vec3 l = ism_projected_local(local, pc.tile);
    if (l.z <= 0.0) {
        imageStore(ism_depth, texel, uvec4(ISM_EMPTY));
        return;
    }
    vec3 ray = normalize(t * l.x + b * l.y + n * l.z);
    // Off the VPL's surface as the exact gathers leave one (exact_lift in
    // exact_visibility.glsl; the scene's diagonal is `far`).
    vec3 p = vpl.position.xyz;
    float floor_length = min(1.0, 1.0 / pc.depth_scale);
    vec3 from = p + n * (1e-4 * (floor_length + max(max(abs(p.x), abs(p.y)), abs(p.z))));
    float range = ISM_DEPTH_RANGE / pc.depth_scale;
    rayQueryEXT query;
    rayQueryInitializeEXT(query, scene_tlas, gl_RayFlagsOpaqueEXT, 0xFFu, from, 0.0, ray, range);
    while (rayQueryProceedEXT(query)) {
    }
    float dist = range;
    uint code = 0u;
    if (rayQueryGetIntersectionTypeEXT(query, true) != gl_RayQueryCommittedIntersectionNoneEXT) {
        dist = rayQueryGetIntersectionTEXT(query, true);
        // The triangle's own plane (not its interpolated normal): the plane
        // the test follows to a receiver's ray is the surface itself.
        uint object = rayQueryGetIntersectionInstanceCustomIndexEXT(query, true);
        uvec2 mesh = mesh_ranges[objects[object].params.w];
        uint primitive = rayQueryGetIntersectionPrimitiveIndexEXT(query, true);
        vec3 p0 = corner(mesh, primitive, 0u);
        vec3 m = mat3(objects[object].normal_matrix)
            * cross(corner(mesh, primitive, 1u) - p0, corner(mesh, primitive, 2u) - p0);
        if (dot(m, m) > 0.0) code = ism_normal_code(normalize(m));
    }
    imageStore(ism_depth, texel, uvec4(ism_pack(dist * pc.depth_scale, code)));
}
