// glTF 2.0's metallic-roughness BRDF (specification, appendix B); the CPU
// twin, with the formulas, is src/cpu/brdf.rs:
//   f = (1 - m) (1 - w Fd) base / pi + ((1 - m) w Fd + m Fm) D V
// with Schlick Fresnel (Fd for ior 1.5, Fm with F0 = base), GGX D and
// height-correlated Smith V; w = 0 makes it Lambertian.
#ifndef SSBC_BRDF_GLSL
#define SSBC_BRDF_GLSL

#include "common.glsl"

// Smallest roughness used (MIN_ROUGHNESS in brdf.rs).
const float BRDF_MIN_ROUGHNESS = 0.05;

struct Brdf {
    vec3 base;        // linear base colour
    float metallic;   // [0, 1]
    float roughness;  // perceptual [0, 1]
    float specular;   // dielectric specular layer: 1 (glTF) or 0 (Lambertian)
};

Brdf brdf_lambertian(vec3 base) {
    return Brdf(base, 0.0, 1.0, 0.0);
}

bool brdf_is_lambertian(Brdf b) {
    return b.specular == 0.0 && b.metallic == 0.0;
}

// The G-buffer's encoding: albedo.rgb base, albedo.w metallic, normal.w
// roughness (< 0: Lambertian).
Brdf brdf_from_gbuffer(vec4 albedo, vec4 normal) {
    if (normal.w < 0.0) return brdf_lambertian(albedo.rgb);
    return Brdf(albedo.rgb, albedo.w, normal.w, 1.0);
}

float brdf_alpha(Brdf b) {
    float r = clamp(b.roughness, BRDF_MIN_ROUGHNESS, 1.0);
    return r * r;
}

// alpha^2 of a GGX lobe of alpha `a` widened by spread2 >= 0 (below).
float widened_a2(float a, float spread2) {
    return min(a * a + spread2, 1.0);
}

// GGX alpha of the same BRDF with its lobe widened: alpha^2 grows by
// spread2 (an angle squared, rad^2). Brdf::widened in brdf.rs, whose
// roughness is the square root of this (taken here as alpha directly:
// the gather evaluates two widened lobes per VPL and receiver, and the
// round trip cost a square root and a clamp each).
float brdf_widened_alpha(Brdf b, float spread2) {
    float a = brdf_alpha(b);
    return brdf_is_lambertian(b) || !(spread2 > 0.0) ? a : sqrt(widened_a2(a, spread2));
}

// GGX D times height-correlated Smith V for unit n, nv = n . wo and
// nl = n . wi (both > 0), alpha^2 a2, and the half vector's unnormalised
// sum = wo + wi (len2 = |sum|^2), in one division. 1 - (n.h)^2 is
// |n x h|^2: near the peak of a narrow lobe the difference cancelled to a
// few bits in f32, and GPUs' normalize (NVIDIA: 1.9e-3 against the CPU)
// moved D with them. With n.h = (nv + nl) / |sum|:
//   D = a^2 / (pi d^2), d = |n x h|^2 + (n.h)^2 a^2 = e / |sum|^2,
//   e = |n x sum|^2 + (nv + nl)^2 a^2
//   V = 0.5 / (nl sqrt(nv^2 (1 - a^2) + a^2) + nv sqrt(nl^2 (1 - a^2) + a^2))
float ggx_dv(vec3 n, vec3 sum, float len2, float a2, float nv, float nl) {
    vec3 c = cross(n, sum);
    float nvl = nv + nl;
    float e = dot(c, c) + nvl * nvl * a2;
    float gv = nl * sqrt(nv * nv * (1.0 - a2) + a2);
    float gl = nv * sqrt(nl * nl * (1.0 - a2) + a2);
    return 0.5 * a2 * len2 * len2 / (PI * e * e * (gv + gl));
}

// The diffuse colour (1 - m) base: f's diffuse lobe is that / pi times
// the weight brdf_parts gives.
vec3 brdf_diffuse_color(Brdf b) {
    return b.base * (1.0 - b.metallic);
}

// What a surface sends as an SSBC source per unit of irradiance / pi: its
// hemispherical albedo (what it reflects, averaged over cosine-weighted
// views), spread evenly as if it were diffuse. Its specular lobe reflects
// F0 A(r) + B(r) (Schlick is linear in F0; single scattering, so A falls
// with roughness), tabulated over perceptual roughness r in steps of 0.1
// from the CPU BRDF (tests/glossy.rs checks the table); its diffuse lobe
// (1 - m) base times the mean of 1 - specular fd(wo.h), 1 - 0.0436 specular.
// A Lambertian surface sends its base colour, as before.
const float SPECULAR_ALBEDO_A[11] = float[](
    0.9524, 0.9526, 0.9509, 0.9410, 0.9138, 0.8635, 0.7902, 0.6989, 0.5984, 0.4984, 0.4064);
const float SPECULAR_ALBEDO_B[11] = float[](
    0.0476, 0.0470, 0.0431, 0.0354, 0.0265, 0.0187, 0.0127, 0.0086, 0.0058, 0.0040, 0.0027);
const float DIFFUSE_ALBEDO_LOSS = 0.0436;

vec3 brdf_source_color(Brdf b) {
    if (brdf_is_lambertian(b)) return b.base;
    float x = clamp(b.roughness, 0.0, 1.0) * 10.0;
    int i = min(int(x), 9);
    float t = x - float(i);
    float a = mix(SPECULAR_ALBEDO_A[i], SPECULAR_ALBEDO_A[i + 1], t);
    float c = mix(SPECULAR_ALBEDO_B[i], SPECULAR_ALBEDO_B[i + 1], t);
    vec3 diffuse = brdf_diffuse_color(b) * (1.0 - DIFFUSE_ALBEDO_LOSS * b.specular);
    vec3 specular = (1.0 - b.metallic) * b.specular * (0.04 * a + c) + b.metallic * (b.base * a + c);
    return diffuse + specular;
}

// What f depends on for one receiver (unit normal n, view wo), for
// brdf_view_parts: a walk evaluates it towards many wi at one receiver.
// Schlick is linear in its F0: the specular colour
//   (1 - m) w Fd + m Fm = f0 + (f90 - f0) s,  s = (1 - wo.h)^5,
//   f0 = (1 - m) w 0.04 + m base,  f90 = (1 - m) w + m,
// and the diffuse weight 1 - w Fd = 1 - w (0.04 + 0.96 s).
struct BrdfView {
    vec3 n;
    vec3 wo;
    float nv;            // n . wo: f is 0 unless > 0
    vec3 f0;
    vec3 f90_minus_f0;
    float specular;      // the dielectric layer w
    bool lambertian;
};

BrdfView brdf_view(Brdf b, vec3 n, vec3 wo) {
    float m = b.metallic;
    vec3 f0 = (1.0 - m) * b.specular * 0.04 + m * b.base;
    float f90 = (1.0 - m) * b.specular + m;
    return BrdfView(n, wo, dot(n, wo), f0, vec3(f90) - f0, b.specular, brdf_is_lambertian(b));
}

// f(wo, wi) split as brdf_diffuse_color(b) / pi * diffuse_weight + specular,
// for the receiver `v`, with the GGX lobe's alpha^2 `a2` (brdf_alpha(b)^2,
// or widened); both zero unless wo and wi are above the surface.
void brdf_view_parts(BrdfView v, float a2, vec3 wi, out float diffuse_weight, out vec3 specular) {
    float nl = dot(v.n, wi);
    vec3 sum = v.wo + wi;
    float len2 = dot(sum, sum);
    // wo . h = (1 + wo . wi) / |sum| = |sum| / 2.
    float s1 = clamp(1.0 - 0.5 * sqrt(len2), 0.0, 1.0);
    float s2 = s1 * s1;
    float schlick = s2 * s2 * s1;
    // Selected, not branched on: lavapipe runs every branch anyway, and
    // its early returns here cost masks on every output (measured: docs/accuracy.md, "Tuned constants"). A
    // Lambertian view (w = 0, f0 = f90 = 0) takes diffuse weight 1 and no
    // specular, whatever D V is at grazing angles.
    bool lit = v.nv > 0.0 && nl > 0.0;
    diffuse_weight = lit ? 1.0 - v.specular * (0.04 + 0.96 * schlick) : 0.0;
    float dv = ggx_dv(v.n, sum, len2, a2, v.nv, nl);
    specular = lit && !v.lambertian ? (v.f0 + v.f90_minus_f0 * schlick) * dv : vec3(0.0);
}

// brdf_view_parts around unit normal n seen from wo, with the lobe's alpha `a`.
void brdf_parts_alpha(Brdf b, float a, vec3 n, vec3 wo, vec3 wi, out float diffuse_weight, out vec3 specular) {
    brdf_view_parts(brdf_view(b, n, wo), a * a, wi, diffuse_weight, specular);
}

void brdf_parts(Brdf b, vec3 n, vec3 wo, vec3 wi, out float diffuse_weight, out vec3 specular) {
    brdf_parts_alpha(b, brdf_alpha(b), n, wo, wi, diffuse_weight, specular);
}

// f(wo, wi) around unit normal n (no cosine) with the lobe's alpha `a`;
// zero unless both are above.
vec3 brdf_eval_alpha(Brdf b, float a, vec3 n, vec3 wo, vec3 wi) {
    float diffuse_weight;
    vec3 specular;
    brdf_parts_alpha(b, a, n, wo, wi, diffuse_weight, specular);
    return brdf_diffuse_color(b) / PI * diffuse_weight + specular;
}

vec3 brdf_eval(Brdf b, vec3 n, vec3 wo, vec3 wi) {
    return brdf_eval_alpha(b, brdf_alpha(b), n, wo, wi);
}

#endif
