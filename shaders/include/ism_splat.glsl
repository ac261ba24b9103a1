// ISM point splatting (ism_splat.comp; with ISM_BACK_FACES defined,
// ism_splat_back.comp): every VPL splats its own block of scene points (the
// one its identity picks, position.w) into its tile (ism_map) with atomicMin
// on the packed distance and the point's surface normal (ism_pack). Points
// come placed in world space (ism_points.comp; w: their surface's packed
// normal, 0: a hidden object's).
#include "ism.glsl"

layout(local_size_x = 64) in;

// How far past its surface's edge a disc still reaches, in point radii:
// a texel whose centre ray passes just beyond an occluder's edge then
// still holds it, which costs a little false shadow there and saves a
// leak (a mirror-like floor before a plinth reflected the VPLs behind it
// over its top edge: 1.59x the exact VPL light over the metre at no
// margin, 1.39x at half a radius; measured: docs/accuracy.md, "ISM discs
// as wide as their surface allows").
const float ISM_EDGE_MARGIN = 0.25;

layout(set = 0, binding = 0, r32ui) uniform uimage2D ism_depth;
layout(set = 0, binding = 1) readonly buffer Vpls { GpuVpl vpls[]; };
layout(set = 0, binding = 2) readonly buffer Points { vec4 points[]; }; // xyz world, w normal (0: hidden)
layout(set = 0, binding = 3) readonly buffer Discs { uint discs[]; };  // world, ism_pack_disc

layout(push_constant) uniform Push {
    uint vpl_count;
    uint points_per_vpl;
    uint tile;
    uint tiles_per_row;
    float depth_scale;   // 1 / far: distances are stored as d * depth_scale
    float point_radius;  // world radius each point stands for
    float disc_reach;    // the widest disc's radius (m): ism_pack_disc's unit
} pc;

// A point's disc in the VPL's frame (see main): its plane's normal, its
// in-plane axes and its edge's direction as columns; d (VPL to point)
// along the last three; dot(d, normal); how far along the edge's
// direction it reaches.
struct Disc {
    mat4x3 frame;
    vec3 offsets;
    float plane;
    float clip_distance;
};

// Whether the disc, out to radius sqrt(reach2), covers texel `local` of
// the tile, and the distance `hit` along that texel's centre ray where it
// meets the disc's plane.
bool disc_covers(Disc disc, ivec2 local, float reach2, out float hit) {
    vec3 r = ism_projected_local(local, pc.tile);
    vec4 f = r * disc.frame;  // dot(r, .) for each column
    hit = disc.plane / f.x;
    vec3 miss = hit * f.yzw - disc.offsets;  // along u, u2 and the edge's direction
    return r.z > 0.0 && abs(f.x) >= 1e-3 && hit > 0.0 && dot(miss.xy, miss.xy) <= reach2
        && miss.z <= disc.clip_distance;
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint v = gl_GlobalInvocationID.y;
    if (i >= pc.points_per_vpl || v >= pc.vpl_count) return;
    GpuVpl vpl = vpls[v];
    uint block = floatBitsToUint(vpl.position.w);
    uint index = block * pc.points_per_vpl + i;
    vec4 point = points[index];
    uint normal_bits = floatBitsToUint(point.w);
    if (normal_bits == 0u) return; // a hidden object's
    // The point's disc: as wide as its surface allows, and the half-plane
    // of it that stays on its surface, dot(miss, clip_dir) <= clip_distance
    // for a point `miss` of its plane relative to it (src/cpu/point_discs.rs).
    uint disc = discs[index];
    float radius = ism_disc_radius(disc, pc.disc_reach);
    vec3 clip_dir = ism_unpack_clip_dir(disc);
    float clip_distance = ism_clip_distance(disc, pc.disc_reach) + ISM_EDGE_MARGIN * pc.point_radius;
    vec3 p = point.xyz;
    vec3 d = p - vpl.position.xyz;
    float dist = length(d);
    if (dist < 1e-5) return;
    vec3 w = d / dist;
    vec3 n = vpl.normal.xyz;
    float cos_theta = dot(w, n);
    if (cos_theta <= 0.0) return;
    vec2 uv = ism_map(w, n);
    // Footprint in texels: an angle a spans a tile / 2 texels across the
    // map's rings and a cos(theta) tile / 2 along them, about 0.354 a tile
    // in the mean; larger splats near the VPL close holes, up to 2 texels
    // (3 before the ISM test followed the stored plane, whose cost this
    // pays: docs/performance.md).
    float radius_texels = clamp(radius / dist * float(pc.tile) * 0.354, 0.0, 2.0);
    int r = int(ceil(radius_texels));
    vec3 normal = ism_unpack_normal(normal_bits);
    uint cell = floatBitsToUint(vpl.normal.w);
    ivec2 origin = ivec2(cell & 0xFFFFu, cell >> 16) * int(pc.tile);
    ivec2 center = ivec2(uv * float(pc.tile));
    // Where the point lies in its texel, in texels from the centre.
    vec2 within = uv * float(pc.tile) - vec2(center) - 0.5;
    // Every texel takes the distance where its centre ray meets the point's
    // tangent plane, so that a texel holds its surface along one ray, the
    // one the test's tolerance assumes. The texels the point's disc (its
    // tangent plane within its radius) covers: a surface seen at a slant
    // covers the texels it does, at the distances it has there, not a round
    // splat at the point's distance, which shadowed what lay just behind a
    // slanted surface's edge (measured: docs/accuracy.md, "ISM points as
    // discs"). The point's own texel also where its plane meets the centre
    // ray within a texel's footprint of the point, so that far points still
    // fill their texels; but not at the point's own distance, which a
    // point beside an occluder's silhouette put on the ray past it (false
    // shadows), nor where a plane seen at a slant meets that ray far from
    // the point (measured: docs/accuracy.md, "ISM texels along their
    // centre ray").
    vec3 t, b;
    orthonormal_basis(n, t, b);
    uint code = ism_normal_code(normal);
    // The other texels the disc may cover: within r of the point's texel
    // and within its reach, inside the tile, visited as one box in one flat
    // loop (a SIMD group runs as many iterations as its largest box, not
    // its largest row times its largest column). Seen from the VPL the
    // disc lies within an angle alpha of w, tan(alpha) >= sin(alpha) =
    // radius / (dist - radius). The map (ism_map) takes it to an ellipse
    // of tan(alpha) tile / 2 texels across its rings and at most
    // cos(theta - alpha) times that along them (the radial direction in the
    // tile): the box is that ellipse's (cornell 320x240: 98 -> 94 ms against
    // the circle's).
    float sin_alpha = min(radius / max(dist - radius, 1e-6), 1.0);
    float cos_alpha = sqrt(1.0 - sin_alpha * sin_alpha);
    float tan_alpha = sin_alpha / max(cos_alpha, 1e-6);
    float reach = tan_alpha * float(pc.tile) * 0.5;
    float sin_theta = sqrt(max(1.0 - cos_theta * cos_theta, 0.0));
    float cos_near = sin_alpha < sin_theta ? cos_theta * cos_alpha + sin_theta * sin_alpha : 1.0;
    vec2 radial = sin_theta > 1e-6 ? (uv * 2.0 - 1.0) / sin_theta : vec2(1.0, 0.0);
    vec2 ext = reach * sqrt(cos_near * cos_near * radial * radial + radial.yx * radial.yx);
    ivec2 lo = max(max(ivec2(ceil(within - ext)), ivec2(-r)), -center);
    ivec2 hi = min(min(ivec2(floor(within + ext)), ivec2(r)), ivec2(int(pc.tile) - 1) - center);
    ivec2 box = max(hi - lo + 1, ivec2(0));
    float reach2 = reach * reach;
    float radius2 = radius * radius;
    float texel_footprint = dist * 4.0 / float(pc.tile);  // ism_footprint's texel
    float own2 = max(radius2, texel_footprint * texel_footprint);
    // A texel's centre ray r meets the point's plane at hit = dot(d,
    // normal) / dot(r, normal), and there `miss` = r hit - d lies in the
    // plane: so the tests need only the plane's normal, its in-plane axes
    // u, u2 and the edge's direction in the VPL's frame (`frame`, one column
    // each), against r in that frame (ism_projected_local), and a texel
    // costs one division (cornell 320x240: the points 67 -> 61 ms;
    // docs/performance.md).
    vec3 u, u2;
    orthonormal_basis(normal, u, u2);
    mat3 vpl_frame = transpose(mat3(t, b, n));
    Disc disc_in_frame = Disc(
        mat4x3(vpl_frame * normal, vpl_frame * u, vpl_frame * u2, vpl_frame * clip_dir),
        vec3(dot(d, u), dot(d, u2), dot(d, clip_dir)),
        dot(d, normal),
        clip_distance);
#ifdef ISM_BACK_FACES
    // A point seen from behind also goes to the back-face map (ism.glsl):
    // in the front map too, its disc fills holes in its solid's front
    // (open box, replayed: leaks 0.047 with it there, 0.054 without).
    bool back = dot(normal, d) > 0.0;
    ivec2 back_offset = ism_back_texel(ivec2(0), imageSize(ism_depth).y);
#endif
    float hit;
    if (disc_covers(disc_in_frame, center, own2, hit)) {
        uint packed = ism_pack(hit * pc.depth_scale, code);
        imageAtomicMin(ism_depth, origin + center, packed);
#ifdef ISM_BACK_FACES
        if (back) imageAtomicMin(ism_depth, origin + center + back_offset, packed);
#endif
    }
    ivec2 o = lo;
    for (int k = 0; k < box.x * box.y; k++) {
        vec2 off = vec2(o) - within;
        bool covers = disc_covers(disc_in_frame, center + o, radius2, hit);
        if (covers && (o.x != 0 || o.y != 0) && dot(off, off) <= reach2) {
            uint packed = ism_pack(hit * pc.depth_scale, code);
            imageAtomicMin(ism_depth, origin + center + o, packed);
#ifdef ISM_BACK_FACES
            if (back) imageAtomicMin(ism_depth, origin + center + o + back_offset, packed);
#endif
        }
        o = o.x < hi.x ? ivec2(o.x + 1, o.y) : ivec2(lo.x, o.y + 1);
    }
}
