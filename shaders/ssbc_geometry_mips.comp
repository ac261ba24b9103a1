#version 460
// SSBC geometry pyramid, one level per dispatch (pc.level).
// Level 0 from the G-buffer: the pixel's world position and unit normal, and
// the world-space area A_y seen through it. Level l from l-1: summed area,
// area-weighted mean position and mean of the unit normals (left unnormalised:
// its length says how much they spread, and cos(theta_y) against it is the
// area-weighted mean cosine), a bounding sphere around the mean and a slab
// along the mean normal that hold every pixel position below, and whether
// the texel is one smooth surface ("continuous": all its pixels are geometry,
// its normals agree and its slab is thin), which lets it stand for its pixels
// as an evaluation point.
#include "ssbc.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 3, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 4, rgba32f) uniform readonly image2D g_normal;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    int level = int(pc.level);
    if (any(greaterThanEqual(p, level_size(level)))) return;
    uint dst = texel_index(p, level);
    if (level == 0) {
        vec4 position = vec4(0.0);
        vec3 n = vec3(0.0);
        if (all(lessThan(uvec2(p), pc.size))) {
            position = imageLoad(g_position, p);
            n = imageLoad(g_normal, p).xyz;
        }
        bool geometry = position.w != 0.0;
        geo[dst] = make_texel(position.xyz, 0.0, geometry ? 0.0 : -1.0, n, 1.0);
        aux[dst] = GeoAux(geometry ? pixel_area(position.xyz, n) : 0.0, geometry ? 1u : 0u,
                          geometry ? 1u : 0u, 0u);
        return;
    }
    GeoTexel child[4];
    GeoAux child_aux[4];
    float area = 0.0;
    uint pixels = 0u;
    bool continuous = true;
    vec3 position = vec3(0.0);
    vec3 normal = vec3(0.0);
    for (int k = 0; k < 4; k++) {
        uint c = texel_index(p * 2 + ivec2(k & 1, k >> 1), level - 1);
        child[k] = geo[c];
        child_aux[k] = aux[c];
        area += child_aux[k].area;
        pixels += child_aux[k].pixels;
        continuous = continuous && child_aux[k].continuous == 1u;
        position += child_aux[k].area * child[k].position_extent.xyz;
        normal += child_aux[k].area * child[k].normal_cone.xyz;
    }
    if (!(area > 0.0)) {
        geo[dst] = make_texel(vec3(0.0), 0.0, -1.0, vec3(0.0), 1.0);
        aux[dst] = GeoAux(0.0, 0u, 0u, 0u);
        return;
    }
    position /= area;
    normal /= area;
    float normal_len = length(normal);
    vec3 axis = normal_len > 0.0 ? normal / normal_len : vec3(0.0, 0.0, 1.0);
    // A child's slab (along its own mean normal n_c) projected onto the axis
    // adds |a| thickness_c + sqrt(1 - a^2) radius_c, with a = axis . n_c; its
    // cone widens the texel's by the angle between the axes.
    float radius = 0.0;
    float thickness = 0.0;
    float cone = 0.0;
    for (int k = 0; k < 4; k++) {
        if (child_aux[k].area > 0.0) {
            vec3 offset = child[k].position_extent.xyz - position;
            vec3 nc = child[k].normal_cone.xyz;
            float nc_len = length(nc);
            float a = nc_len > 0.0 ? clamp(dot(axis, nc) / nc_len, -1.0, 1.0) : 0.0;
            vec2 extent = texel_extent(child[k]);
            radius = max(radius, length(offset) + extent.x);
            thickness = max(thickness, abs(dot(axis, offset)) + abs(a) * extent.y + sqrt(1.0 - a * a) * extent.x);
            cone = max(cone, acos(a) + acos(clamp(child[k].normal_cone.w, -1.0, 1.0)));
        }
    }
    continuous = continuous && normal_len >= pc.max_normal_spread && thickness <= pc.max_thickness * radius;
    // Rounding: widen the cone by 1e-3 rad.
    geo[dst] = make_texel(position, radius, thickness, normal, cos(min(cone + 1e-3, PI)));
    aux[dst] = GeoAux(area, pixels, continuous ? 1u : 0u, 0u);
}
