#version 460
// SSBC geometry pyramid, one level >= 1 per dispatch (pc.level; level 0 is
// ssbc_geometry_base.comp). Level l from l-1:
// the children's clusters (up to eight) sorted by depth and split at the
// largest gap into a front and a back cluster; each gets the area-weighted
// mean position and mean of the unit normals (left unnormalised: its length
// says how much they spread, and cos(theta_y) against it is the
// area-weighted mean cosine), a bounding sphere around the mean, a slab
// along the mean normal and a cone around it that hold every pixel position
// and normal of the cluster. The texel is "continuous" (one smooth surface
// that may stand for its pixels as an evaluation point) if all its pixels
// are geometry, all its children are continuous, and all its pixels taken
// together have normals that agree and a thin slab.
#include "ssbc_types.glsl"

layout(push_constant) uniform GeometryMipsPush {
    SsbcFrame frame;
    uint layer;               // the pyramid built
    uint level;               // the level written (>= 1)
    float max_normal_spread;  // continuous: |mean of unit normals| at least this
    float max_thickness;      // continuous: slab half-thickness at most this x the radius
} pc;

#include "ssbc_pyramid.glsl"
#include "ssbc_pyramid_write.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

// The clusters of the four children: 2k + c is cluster c of child k.
GeoCluster members[8];
float member_area[8];

struct Merged {
    GeoCluster cluster;
    float area;
    float normal_len;
    float radius;
    float thickness;
};

// Merges the member clusters whose bit is set in `mask`.
Merged merge(uint mask) {
    float area = 0.0;
    vec3 position = vec3(0.0);
    vec3 normal = vec3(0.0);
    [[unroll]] for (int j = 0; j < 8; j++) {
        if ((mask & (1u << j)) != 0u && member_area[j] > 0.0) {
            area += member_area[j];
            position += member_area[j] * members[j].position_extent.xyz;
            normal += member_area[j] * members[j].normal_cone.xyz;
        }
    }
    if (!(area > 0.0)) return Merged(empty_cluster(), 0.0, 0.0, 0.0, -1.0);
    position /= area;
    normal /= area;
    float normal_len = length(normal);
    vec3 axis = normal_len > 0.0 ? normal / normal_len : vec3(0.0, 0.0, 1.0);
    // A member's slab (along its own mean normal n_c) projected onto the
    // axis adds |a| thickness_c + sqrt(1 - a^2) radius_c, with a = axis . n_c;
    // its cone widens the merged one by the angle between the axes.
    float radius = 0.0;
    float thickness = 0.0;
    float cone = 0.0;
    [[unroll]] for (int j = 0; j < 8; j++) {
        if ((mask & (1u << j)) != 0u && member_area[j] > 0.0) {
            vec3 offset = members[j].position_extent.xyz - position;
            vec3 nc = members[j].normal_cone.xyz;
            float nc_len = length(nc);
            float a = nc_len > 0.0 ? clamp(dot(axis, nc) / nc_len, -1.0, 1.0) : 0.0;
            vec2 extent = cluster_extent_m(members[j], pc.frame.camera_position.xyz, pc.frame.camera_forward.xyz);
            radius = max(radius, length(offset) + extent.x);
            thickness = max(thickness, abs(dot(axis, offset)) + abs(a) * extent.y + sqrt(1.0 - a * a) * extent.x);
            cone = max(cone, acos(a) + acos(clamp(members[j].normal_cone.w, -1.0, 1.0)));
        }
    }
    // Rounding: widen the cone by 1e-3 rad.
    float unit = cluster_unit(position, pc.frame.camera_position.xyz, pc.frame.camera_forward.xyz);
    GeoCluster cluster = make_cluster(position, radius, thickness, normal, cos(min(cone + 1e-3, PI)), unit);
    return Merged(cluster, area, normal_len, radius, thickness);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    int level = int(pc.level);
    if (any(greaterThanEqual(p, level_size(pc.layer, level)))) return;
    uint dst = texel_index(pc.layer, p, level);
    uint pixels = 0u;
    bool continuous = true;
    float depth[8];
    ivec2 below = level_size(pc.layer, level - 1);
    [[unroll]] for (int k = 0; k < 4; k++) {
        ivec2 child = p * 2 + ivec2(k & 1, k >> 1);
        // A child beyond the last row or column is empty (as a pixel
        // outside the image is at level 0).
        bool exists = all(lessThan(child, below));
        uint c = texel_index(pc.layer, child, level - 1);
        GeoAux child_aux = exists ? geo_aux(c) : GeoAux(0.0, 0.0, 0u, 0u);
        members[2 * k] = exists ? geo_cluster(c, 0u) : empty_cluster();
        members[2 * k + 1] = exists ? geo_cluster(c, 1u) : empty_cluster();
        member_area[2 * k] = child_aux.front_area;
        member_area[2 * k + 1] = child_aux.back_area;
        pixels += child_aux.pixels;
        continuous = continuous && (child_aux.flags & 1u) == 1u;
    }
    // Split at the largest gap in depth between consecutive members.
    uint present = 0u;
    [[unroll]] for (int j = 0; j < 8; j++) {
        depth[j] = dot(members[j].position_extent.xyz - pc.frame.camera_position.xyz, pc.frame.camera_forward.xyz);
        if (member_area[j] > 0.0) present |= 1u << j;
    }
    uint back_mask = 0u;
    float largest_gap = 0.0;
    [[unroll]] for (int j = 0; j < 8; j++) {
        // Gap from member j to the nearest member behind it.
        float next = 3.4e38;
        [[unroll]] for (int i = 0; i < 8; i++) {
            if ((present & (1u << i)) != 0u && depth[i] > depth[j]) next = min(next, depth[i]);
        }
        if ((present & (1u << j)) != 0u && next < 3.4e38 && next - depth[j] > largest_gap) {
            largest_gap = next - depth[j];
            back_mask = 0u;
            [[unroll]] for (int i = 0; i < 8; i++) {
                if ((present & (1u << i)) != 0u && depth[i] > depth[j]) back_mask |= 1u << i;
            }
        }
    }
    Merged front = merge(present & ~back_mask);
    Merged back = merge(back_mask);
    float area = front.area + back.area;
    if (!(area > 0.0)) {
        store_geo(dst, GeoTexel(empty_cluster(), empty_cluster()));
        store_aux(dst, GeoAux(0.0, 0.0, 0u, 0u));
        return;
    }
    // The texel taken whole, for continuity: its mean normal and a slab
    // around its mean holding both clusters' slabs.
    vec3 normal = (front.area * front.cluster.normal_cone.xyz + back.area * back.cluster.normal_cone.xyz) / area;
    vec3 position = (front.area * front.cluster.position_extent.xyz + back.area * back.cluster.position_extent.xyz) / area;
    float normal_len = length(normal);
    vec3 axis = normal_len > 0.0 ? normal / normal_len : vec3(0.0, 0.0, 1.0);
    float radius = 0.0;
    float thickness = 0.0;
    for (int c = 0; c < 2; c++) {
        Merged part = c == 0 ? front : back;
        if (part.area > 0.0) {
            vec3 offset = part.cluster.position_extent.xyz - position;
            float a = part.normal_len > 0.0 ? clamp(dot(axis, part.cluster.normal_cone.xyz) / part.normal_len, -1.0, 1.0) : 0.0;
            radius = max(radius, length(offset) + part.radius);
            thickness = max(thickness, abs(dot(axis, offset)) + abs(a) * part.thickness + sqrt(1.0 - a * a) * part.radius);
        }
    }
    continuous = continuous && normal_len >= pc.max_normal_spread && thickness <= pc.max_thickness * radius;
    // Which children hold members of each cluster, for the traversal (see
    // children_bits in ssbc_types.glsl).
    uint front_children = 0u;
    uint back_children = 0u;
    [[unroll]] for (int k = 0; k < 4; k++) {
        uint of_child = (present >> (2 * k)) & 3u;
        if ((of_child & ~(back_mask >> (2 * k))) != 0u) front_children |= 1u << k;
        if ((of_child & (back_mask >> (2 * k))) != 0u) back_children |= 1u << k;
    }
    store_geo(dst, GeoTexel(with_children_bits(front.cluster, front_children | (back_children << 4)), back.cluster));
    store_aux(dst, GeoAux(front.area, back.area, pixels, (continuous ? 1u : 0u) | (back_mask << 8)));
}
