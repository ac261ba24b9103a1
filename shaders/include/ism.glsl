// Imperfect shadow maps (Ritschel et al. 2008): one paraboloid depth tile per
// VPL, oriented along the VPL normal, in one atlas.
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

// Texels per GpuVpl in the gathers' texel view.
const uint VPL_TEXELS = 5u;

// Orthonormal basis around n (Duff et al. 2017); matches cpu::sampling::basis.
void ism_basis(vec3 n, out vec3 t, out vec3 b) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
    b = vec3(c, s + n.y * n.y * a, -n.y);
}

// Paraboloid coordinates in [0,1]^2 of unit direction w leaving a VPL with
// normal n; w must lie in the upper hemisphere.
vec2 ism_paraboloid(vec3 w, vec3 n) {
    vec3 t, b;
    ism_basis(n, t, b);
    vec3 l = vec3(dot(w, t), dot(w, b), dot(w, n));
    return l.xy / (1.0 + l.z) * 0.5 + 0.5;
}

// Texel of the atlas at paraboloid coordinate uv in the tile whose column
// and row are packed in `cell` (GpuVpl.normal.w).
ivec2 ism_texel(uint cell, vec2 uv, uint tile) {
    ivec2 origin = ivec2(cell & 0xFFFFu, cell >> 16) * int(tile);
    ivec2 local = clamp(ivec2(uv * float(tile)), ivec2(0), ivec2(int(tile) - 1));
    return origin + local;
}

// Depth tolerance of the ISM test [m]: a relative bias, plus the depth change
// of the receiver's own surface across one splat footprint (a texel or a
// point, whichever is larger) at its slope. Mirrored in renderer.rs.
float ism_tolerance(float dist, float cos_x, uint tile, float point_radius, float relative_bias) {
    float footprint = max(dist * 4.0 / float(tile), point_radius);
    float c = clamp(cos_x, 0.1, 1.0);
    float slope = sqrt(1.0 - c * c) / c;
    return relative_bias * dist + footprint * slope + 1e-3;
}

#endif
