// Imperfect shadow maps (Ritschel et al. 2008): one depth tile per VPL over
// the hemisphere about its normal, in one atlas, by projected solid angle
// (ism_map).
#ifndef SSBC_ISM_GLSL
#define SSBC_ISM_GLSL

// A VPL (mirrors GpuVpl in src/gpu_types.rs). The gathers read it as five
// RGBA32F texels (vpl_gather.glsl), the splat as a struct.
struct GpuVpl {
    vec4 position;   // xyz position; w: bits of its ISM point block (uint)
    vec4 normal;     // xyz unit normal (hemisphere it emits into); w: bits of
                     // its atlas tile's column | row << 16 (uint)
    vec4 power;      // rgb: Lambertian: albedo x flux Phi [W] (f_r(z) Phi x pi); glossy:
                     // Phi. w: -1 Lambertian, -2 Lambertian with a shading
                     // normal (in incident.xyz), else metallic
    vec4 base;       // glossy: rgb base colour, w roughness
    vec4 incident;   // glossy: xyz direction the light arrived from (lobe
                     // turned to the shading normal's); Lambertian with -2:
                     // its shading normal; w: radius (m), which widens
                     // glossy lobes towards and from it
};

#include "octahedral.glsl"

// A unit normal in 32 bits (pack_normal in src/cpu/points.rs): its
// octahedral map, 15 bits a coordinate, the top bit set (0: no normal).
uint ism_pack_normal(vec3 n) {
    uvec2 q = uvec2(round(clamp(octahedral(n) * 0.5 + 0.5, 0.0, 1.0) * 32767.0));
    return 0x80000000u | (q.x << 15) | q.y;
}

vec3 ism_unpack_normal(uint bits) {
    vec2 e = vec2(uvec2((bits >> 15) & 32767u, bits & 32767u)) * (2.0 / 32767.0) - 1.0;
    return from_octahedral(e);
}

// A point's disc in 32 bits (pack_disc in src/cpu/point_discs.rs), its
// lengths as fractions of the reach (the widest disc's radius): the
// in-plane direction towards the edge where it ends, octahedral, 10 bits a
// coordinate; its radius in 15ths of the reach (4 bits); in the top 8 the
// edge's distance in 255ths of the reach (0: no edge, the disc is whole).
uint ism_pack_disc(vec3 dir, uint codes) {
    uvec2 q = uvec2(round(clamp(octahedral(dir) * 0.5 + 0.5, 0.0, 1.0) * 1023.0));
    return (codes & 0xFFF00000u) | (q.x << 10) | q.y;
}

vec3 ism_unpack_clip_dir(uint disc) {
    return from_octahedral(vec2(uvec2((disc >> 10) & 1023u, disc & 1023u)) * (2.0 / 1023.0) - 1.0);
}

// Beyond the disc where it has no edge.
float ism_clip_distance(uint disc, float reach) {
    uint code = disc >> 24;
    return code == 0u ? 2.0 * reach : float(code) * (reach / 255.0);
}

float ism_disc_radius(uint disc, float reach) {
    return float((disc >> 20) & 15u) * (reach / 15.0);
}

// Texels per GpuVpl in the gathers' texel view.
const uint VPL_TEXELS = 5u;

// How a tile maps its VPL's hemisphere: by projected solid angle, a
// direction at theta from the normal landing at its projection onto the
// VPL's plane, sin(theta) from the tile's centre (Nusselt's analogue: the
// disc inscribed in the tile, every texel the same share of a Lambertian
// VPL's flux). Its texels are 3.6 degrees across at the pole of a 32-texel
// tile, 3.6 x 5.1 at 45 degrees, and 20 degrees radially in the last ring,
// which holds 12% of the flux. The seed's paraboloid (Brabec et al.) had
// its coarsest texels at the pole, where a VPL sends most of its light
// (7.2 degrees), and a fifth of them beyond the horizon: its bias was a
// texel's size there (docs/accuracy.md, "ISM tiles by projected solid
// angle").

// Tile coordinates in [0,1]^2 of unit direction w leaving a VPL with normal
// n (w in the upper hemisphere).
vec2 ism_map(vec3 w, vec3 n) {
    vec3 t, b;
    orthonormal_basis(n, t, b);
    return vec2(dot(w, t), dot(w, b)) * 0.5 + 0.5;
}

// Texel of the atlas at tile coordinate uv (ism_map) in the tile whose column
// and row are packed in `cell` (GpuVpl.normal.w).
ivec2 ism_texel(uint cell, vec2 uv, uint tile) {
    ivec2 origin = ivec2(cell & 0xFFFFu, cell >> 16) * int(tile);
    ivec2 local = clamp(ivec2(uv * float(tile)), ivec2(0), ivec2(int(tile) - 1));
    return origin + local;
}

// An atlas texel: the nearest distance (/ far, below ISM_DEPTH_RANGE) in
// its high 19 bits, so that atomicMin keeps the nearest; ISM_BACK_FLAG;
// and in its low 12 what is known of the surface stored: 0 nothing; 1-255
// how squarely it faces the VPL, 1 + 254 |cos| between its normal and the
// ray (the ray-cast layer's blocks); 256 and up its normal up to sign
// (ism_normal_code), so that the test can follow its plane to the
// receiver's ray (a splatted point's).
const float ISM_DEPTH_RANGE = 4.0;
const float ISM_DEPTH_STEPS = 524287.0;  // 2^19 - 1
const uint ISM_NORMAL_CODES = 256u;
// Set in a front texel (by ism_fill, after the splat) whose back-face map
// texel holds a surface nearer than the front one or within
// ism_back_band of it behind: the only texels where the gathers' back-face
// test can hide a receiver the front test passed, so that the others skip
// its load (most texels of most scenes: docs/performance.md).
const uint ISM_BACK_FLAG = 0x1000u;

uint ism_pack(float depth, uint code) {
    float q = clamp(depth * (ISM_DEPTH_STEPS / ISM_DEPTH_RANGE), 0.0, ISM_DEPTH_STEPS);
    return (uint(q) << 13) | code;
}

uint ism_facing_code(float facing) {
    // (A facing that is not a number, from a degenerate transform, is not known.)
    return facing >= 0.0 ? 1u + uint(round(min(facing, 1.0) * 254.0)) : 0u;
}

// A unit normal up to sign: turned to z >= 0, its octahedral map fills a
// diamond, turned by 45 degrees to fill the square (about 1 degree a step),
// in 6 bits a coordinate: 4-63 (60 steps) above the facing codes, then 0-63.
uint ism_normal_code(vec3 m) {
    vec2 e = octahedral(m.z < 0.0 ? -m : m);
    vec2 q = round(clamp(vec2(e.x + e.y, e.x - e.y) * 0.5 + 0.5, 0.0, 1.0) * vec2(59.0, 63.0));
    return ((4u + uint(q.x)) << 6) | uint(q.y);
}

// The atlas's lower half holds every tile's back-face map: per texel the
// nearest surface seen from behind (a splatted point whose normal faces
// away from the VPL: where its ray leaves a closed solid), packed the same
// way. A receiver faces the VPL, so it is never that surface itself: a
// ray that left a solid before reaching it passed through the solid (a
// wall's thickness), which the front map's tolerance, sized for the
// receiver's own surface, cannot tell from the receiver.
ivec2 ism_back_texel(ivec2 front, int atlas_height) {
    return front + ivec2(0, atlas_height / 2);
}

// A texel that holds nothing: ism_pack(ISM_DEPTH_RANGE, 0).
const uint ISM_EMPTY = 0xFFFFE000u;

float ism_texel_depth(uint texel) {
    return float(texel >> 13) * (ISM_DEPTH_RANGE / ISM_DEPTH_STEPS);
}

// The stored surface's normal (up to sign), if the texel has one.
bool ism_texel_normal(uint texel, out vec3 m) {
    uint code = texel & 4095u;
    vec2 q = vec2(float(int(code >> 6u) - 4), float(code & 63u)) * vec2(2.0 / 59.0, 2.0 / 63.0) - 1.0;
    m = from_octahedral(vec2(q.x + q.y, q.x - q.y) * 0.5);
    return code >= ISM_NORMAL_CODES;
}

// |cos| of the stored surface to the VPL's ray where only that is known
// (codes 1-255), or -1.
float ism_texel_facing(uint texel) {
    uint code = texel & 4095u;
    return code == 0u || code >= ISM_NORMAL_CODES ? -1.0 : float(code - 1u) * (1.0 / 254.0);
}

// The unit ray through the centre of a tile's texel `local` in its VPL's
// frame (t, b, n as x, y, z): ism_map inverted; z < 0 beyond the horizon
// (the tile's corners, which no direction maps to).
vec3 ism_projected_local(ivec2 local, uint tile) {
    vec2 a = (vec2(local) + 0.5) * (2.0 / float(tile)) - 1.0;  // a power of two: exact
    float r2 = dot(a, a);
    return vec3(a, r2 < 1.0 ? sqrt(1.0 - r2) : -1.0);
}

// The same in world space (t, b, n the VPL's basis).
vec3 ism_centre_ray(ivec2 local, uint tile, vec3 t, vec3 b, vec3 n) {
    vec3 l = ism_projected_local(local, tile);
    return t * l.x + b * l.y + n * l.z;
}

// tan of the angle whose cosine is c, c clamped to [0.1, 1].
float ism_slope(float c) {
    c = clamp(c, 0.1, 1.0);
    return sqrt(1.0 - c * c) / c;
}

// How much slope a texel's stored surface allows (see ism_tolerance):
// ISM_SLOPE_MARGIN x its own, because the nearest point of the receiver's
// own surface in a texel faces the VPL a little more squarely than the
// receiver does (measured: docs/accuracy.md, "Tuned constants"). (Half a
// footprint more for a surface that curves within one let a wall that
// faces the VPL squarely hide nothing for 15-25 cm behind it: "The
// stored plane's own tolerance".)
const float ISM_SLOPE_MARGIN = 1.5;

// One splat footprint at distance `dist`: a texel or a point, whichever is
// larger [m]. 4 / tile radians: two of the map's texels at the pole (the
// seed paraboloid's one, which the test's tolerances were tuned with).
float ism_footprint(float dist, uint tile, float point_radius) {
    return max(dist * 4.0 / float(tile), point_radius);
}

// How far behind a front texel's surface its back-face map's may lie for
// the texel to take ISM_BACK_FLAG [m]: past that the front test's own
// tolerance (a relative bias, a footprint at the slopes it allows) has
// already hidden a receiver beyond the back face (measured: docs/accuracy.md,
// "A back-face map").
const float ISM_BACK_BAND_RELATIVE = 0.1;
const float ISM_BACK_BAND_FOOTPRINTS = 1.0;

float ism_back_band(float depth, uint tile, float point_radius) {
    return ISM_BACK_BAND_RELATIVE * depth + ISM_BACK_BAND_FOOTPRINTS * ism_footprint(depth, tile, point_radius);
}

// One block of a VPL's ray-cast layer (LayerBlock in src/cpu/ism_rays.rs):
// d >= 0: its farthest corner's distance [m], that corner's facing code in
// the top 8 bits of `bits`; d < 0: its four corners met one plane, -d
// from the VPL [m], whose normal towards the VPL is an octahedral map in
// the low 24 bits (12 a coordinate), and the farthest corner lies
// 2^(top 8 bits / 32) times as far.
struct LayerBlock {
    float d;
    uint bits;
};

// The block's farthest corner's distance [m].
float ism_layer_far(LayerBlock b) {
    return b.d >= 0.0 ? b.d : -b.d * exp2(float(b.bits >> 24) * (1.0 / 32.0));
}

// The block's plane's unit normal (where b.d < 0).
vec3 ism_layer_normal(LayerBlock b) {
    vec2 q = vec2(b.bits & 0xFFFu, (b.bits >> 12) & 0xFFFu) * (2.0 / 4095.0) - 1.0;
    return from_octahedral(q);
}

// What texel `local` of a tile starts from (distances over `far`; `beyond`
// the block's ism_layer_far). Where
// its layer block's corners met one plane, that plane along the texel's
// centre ray with its normal code `code` (the block's normal's
// ism_normal_code; `m_local` its components in the VPL's frame), at most
// as far as the farthest corner: a texel of a wall that faces the VPL
// holds the wall itself, which the ISM test follows to the receiver's ray,
// not the farthest corner up to a block behind it (docs/accuracy.md, "The
// ray-cast layer's planes"). Else the farthest corner and its facing.
uint ism_layer_texel(LayerBlock b, float beyond, ivec2 local, uint tile, vec3 m_local, uint code, float far) {
    vec3 l = ism_projected_local(local, tile);
    float mr = -dot(m_local, l);
    bool on_plane = b.d < 0.0 && l.z > 0.0 && -b.d < beyond * mr;
    float d = on_plane ? -b.d / mr : beyond;
    uint c = on_plane ? code : (b.d >= 0.0 ? b.bits >> 24 : ism_facing_code(mr));
    return ism_pack(d / far, c);
}

// The ISM test's absolute tolerance [m]: 1 mm, or a thousandth of the
// scene's diagonal (`far`) in scenes under a metre across (a 2 mm box of
// 0.13 mm slabs was lit through them). Mirrored in renderer/readback.rs.
float ism_floor(float far) {
    return 1e-3 * min(1.0, far);
}

// Depth tolerance of the ISM test [m]: a relative bias, plus the depth change
// of a surface across one splat footprint (a texel or a point, whichever is
// larger) at its slope to the VPL's ray. The receiver's own surface lands
// in its texel, so its slope (cos_x) is enough for it; but at grazing
// angles that let any occluder within several footprints through (a
// mirror-like floor before a plinth reflected the VPLs the plinth hides).
// Where the texel says how the surface it stores faces the ray (`facing` >=
// 0), the slope is at most that surface's (with a margin, above): the
// receiver's own surface still gets what it needs, and an occluder facing
// the VPL shadows (measured: docs/accuracy.md, "Tuned constants"). Mirrored in renderer/readback.rs.
float ism_tolerance(float dist, float cos_x, float facing, uint tile, float point_radius, float relative_bias, float far) {
    float footprint = ism_footprint(dist, tile, point_radius);
    float slope = ism_slope(cos_x);
    if (facing >= 0.0) slope = min(slope, ISM_SLOPE_MARGIN * ism_slope(facing));
    return relative_bias * dist + footprint * slope + ism_floor(far);
}

#endif
