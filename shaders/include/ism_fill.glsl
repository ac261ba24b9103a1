// ISM hole filling, after the splat (ism_fill.comp; with ISM_BACK_FACES
// defined, ism_fill_back.comp, which also sets ISM_BACK_FLAG): a texel
// that no disc of the surface around it reached holds whatever lies behind (a hole in an occluder's
// splats, the commonest leak: docs/accuracy.md, "Holes filled between
// two texels of one plane"). Where the two texels either side of it (left
// and right, or above and below) lie nearer and hold one plane (normals
// within ISM_FILL_COS) that, followed to its centre ray, lies more than a
// footprint nearer than what it holds, both agreeing there within
// ISM_FILL_AGREE footprints, it takes that plane. One checkerboard parity
// per dispatch, in place: a texel reads only the other parity's, so the
// result does not depend on the order invocations run in (the second
// dispatch reads what the first filled). In tiles that start empty, it
// first combines every texel it reads with the ray-cast layer (with_layer).
#include "ism.glsl"

layout(local_size_x = 64) in;

const float ISM_FILL_COS = 0.99;
const float ISM_FILL_AGREE = 0.5;

layout(set = 0, binding = 0, r32ui) uniform uimage2D ism_depth;
layout(set = 0, binding = 1) readonly buffer Vpls { GpuVpl vpls[]; };
layout(set = 0, binding = 2) readonly buffer Layer { LayerBlock layer[]; }; // grid^2 per VPL

layout(push_constant) uniform Push {
    uint vpl_count;
    uint tile;
    uint parity;         // which texels this dispatch fills: (x + y) % 2
    uint run;            // texels of a row per invocation (tile or less)
    float far;           // distances are stored divided by this
    float point_radius;  // world radius each point stands for
    uint grid;           // ray-cast layer blocks per tile side
    float layer_slack;   // ism_rays::layer_slack; 0: the layer is in the atlas
} pc;

// Texel `stored` of VPL v's tile at `local` combined with its ray-cast
// block, in tiles that start empty (layer_slack > 0): what the splat
// stored, unless the block lies nearer by more than layer_slack x its
// distance (or the splat stored nothing): then the block's texel
// (ism_layer_texel; t, bt, n the VPL's basis). Such a block stopped at an
// occluder near the VPL whose few points missed this texel, which is what
// the layer is for. A splat less far behind is the block's own surface,
// beyond all four of its corners: a concave crease or a curve within the
// block, where the farthest corner, which atomicMin would keep, lies in
// front of it and shadows it (docs/accuracy.md, "The ray-cast layer in
// finer tiles"). Idempotent: a combined texel combines to itself.
uint with_layer(uint stored, uint v, ivec2 local, vec3 t, vec3 bt, vec3 n) {
    if (pc.layer_slack <= 0.0) return stored;
    uvec2 block = uvec2(local) * pc.grid / pc.tile;
    LayerBlock b = layer[(v * pc.grid + block.y) * pc.grid + block.x];
    float splat = ism_texel_depth(stored) * pc.far;
    float beyond = ism_layer_far(b);
    if ((stored & 4095u) != 0u && splat <= beyond * (1.0 + pc.layer_slack)) return stored;
    vec3 m = ism_layer_normal(b);
    vec3 m_local = vec3(dot(m, t), dot(m, bt), dot(m, n));
    uint layer = ism_layer_texel(b, beyond, local, pc.tile, m_local, ism_normal_code(m), pc.far);
    return layer | (stored & ISM_BACK_FLAG);
}

// The distance along centre ray c0 to the plane of normal m that texel
// `stored` holds along its own centre ray c (0 where that is ill-posed).
float plane_along(uint stored, vec3 m, vec3 c, vec3 c0) {
    float cm = dot(c, m);
    float wm = dot(c0, m);
    return abs(wm) > 0.05 && cm * wm > 0.0 ? ism_texel_depth(stored) * pc.far * cm / wm : 0.0;
}

// Whether the two texels either side of one that holds `held` (m) may
// fill it: both hold a normal and lie more than half a footprint nearer
// (most texels end here, before any ray is made).
bool may_fill(uint s1, uint s2, float held, float footprint) {
    float nearer = max(ism_texel_depth(s1), ism_texel_depth(s2)) * pc.far;
    return (s1 & 4095u) >= ISM_NORMAL_CODES && (s2 & 4095u) >= ISM_NORMAL_CODES
        && nearer < held - 0.5 * footprint;
}

// The plane texels s1 and s2 either side of `local` (along `step`) hold,
// followed to its centre ray c0; 0 where they hold no one plane there.
float pair_along(uint s1, uint s2, ivec2 local, ivec2 step, vec3 c0, vec3 t, vec3 b, vec3 n, float footprint) {
    vec3 m1, m2;
    ism_texel_normal(s1, m1);
    ism_texel_normal(s2, m2);
    if (abs(dot(m1, m2)) < ISM_FILL_COS) return 0.0;
    float a1 = plane_along(s1, m1, ism_centre_ray(local - step, pc.tile, t, b, n), c0);
    float a2 = plane_along(s2, m2, ism_centre_ray(local + step, pc.tile, t, b, n), c0);
    return a1 > 0.0 && a2 > 0.0 && abs(a1 - a2) <= ISM_FILL_AGREE * footprint ? 0.5 * (a1 + a2) : 0.0;
}

#ifdef ISM_BACK_FACES
// Front texel `front` at `at`, with ISM_BACK_FLAG where its back-face map
// holds a surface nearer than ism_back_band behind its own.
uint back_flagged(uint front, ivec2 at, int height) {
    float held = ism_texel_depth(front) * pc.far;
    float back = ism_texel_depth(imageLoad(ism_depth, ism_back_texel(at, height)).r) * pc.far;
    return back < held + ism_back_band(held, pc.tile, pc.point_radius) ? front | ISM_BACK_FLAG : front;
}

// The same, stored where it takes the flag.
void flag_back(uint front, ivec2 at, int height) {
    uint flagged = back_flagged(front, at, height);
    if (flagged != front) imageStore(ism_depth, at, uvec4(flagged));
}
#endif

void main() {
    // One invocation fills the texels of this parity in a run of a row
    // (passes::ism::FILL_RUN), loading each texel once but those above and
    // below.
    uint run = pc.run;
    uint runs = pc.tile / run;
    uint i = gl_GlobalInvocationID.x;
    uint v = gl_GlobalInvocationID.y;
    if (i >= runs * pc.tile || v >= pc.vpl_count) return;
    int tile = int(pc.tile);
    int y = int(i / runs);
    int x0 = int(i % runs * run) + ((y + int(pc.parity)) & 1);
    vec4 normal_cell = vpls[v].normal;
    uint cell = floatBitsToUint(normal_cell.w);
    ivec2 origin = ivec2(cell & 0xFFFFu, cell >> 16) * tile;
    vec3 n = normal_cell.xyz;
    vec3 t, b;
    orthonormal_basis(n, t, b);
    uint left = x0 > 0 ? with_layer(imageLoad(ism_depth, origin + ivec2(x0 - 1, y)).r, v, ivec2(x0 - 1, y), t, b, n) : 0u;
#ifdef ISM_BACK_FACES
    // The second dispatch, whose texels and their neighbours are final,
    // also flags every texel of the run whose back-face map holds a
    // surface before or just behind its own (ISM_BACK_FLAG): its own
    // parity's as it writes them, the other's as it reads them (neighbours
    // read concurrently decode the same distance and code either way).
    bool flagging = pc.parity == 1u;
    int height = imageSize(ism_depth).y;
    int start = int(i % runs * run);
    if (flagging && x0 > start) flag_back(left, origin + ivec2(x0 - 1, y), height);
#endif
    for (int x = x0; x < x0 + int(run); x += 2) {
        ivec2 local = ivec2(x, y);
        uint raw = imageLoad(ism_depth, origin + local).r;
        uint stored = with_layer(raw, v, local, t, b, n);
        bool across = x > 0 && x + 1 < tile;
        bool along = y > 0 && y + 1 < tile;
        uint right = x + 1 < tile ? with_layer(imageLoad(ism_depth, origin + local + ivec2(1, 0)).r, v, local + ivec2(1, 0), t, b, n) : 0u;
        uint up = along ? with_layer(imageLoad(ism_depth, origin + local - ivec2(0, 1)).r, v, local - ivec2(0, 1), t, b, n) : 0u;
        uint down = along ? with_layer(imageLoad(ism_depth, origin + local + ivec2(0, 1)).r, v, local + ivec2(0, 1), t, b, n) : 0u;
        float held = ism_texel_depth(stored) * pc.far;
        float footprint = ism_footprint(held, pc.tile, pc.point_radius);
        bool fill_across = across && may_fill(left, right, held, footprint);
        bool fill_along = along && may_fill(up, down, held, footprint);
        uint next_left = right;
        uint final_texel = stored;
        if (fill_across || fill_along) {
            vec3 c0 = ism_centre_ray(local, pc.tile, t, b, n);
            float a = fill_across ? pair_along(left, right, local, ivec2(1, 0), c0, t, b, n, footprint) : 0.0;
            float c = fill_along ? pair_along(up, down, local, ivec2(0, 1), c0, t, b, n, footprint) : 0.0;
            // The nearer of the planes that lie a footprint nearer than
            // what the texel holds (never beyond the horizon: never read).
            float best = held - footprint;
            uint code = 0u;
            if (a > 0.0 && a < best) { best = a; code = left & 4095u; }
            if (c > 0.0 && c < best) { best = c; code = up & 4095u; }
            if (code != 0u && dot(c0, n) > 0.0) final_texel = ism_pack(best / pc.far, code);
        }
#ifdef ISM_BACK_FACES
        if (flagging) {
            final_texel = back_flagged(final_texel, origin + local, height);
            if (x + 1 < start + int(run)) flag_back(right, origin + local + ivec2(1, 0), height);
        }
#endif
        if (final_texel != raw) imageStore(ism_depth, origin + local, uvec4(final_texel));
        // (The next texel of this parity is two along: this one's right
        // neighbour is its left.)
        left = next_left;
    }
}
