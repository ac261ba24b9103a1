// What the SSBC resolve and fallback kernels share: their lists and images
// (bindings 4..14) and how a pixel's residual is written. Included after
// ssbc_types.glsl.

#ifndef SSBC_OUTPUT_GLSL
#define SSBC_OUTPUT_GLSL

layout(set = 0, binding = 4) readonly buffer PendingIn { ListHeader header; uint items[]; } pending_in;
layout(set = 0, binding = 5) buffer PendingOut { ListHeader header; uint items[]; } pending_out;
layout(set = 0, binding = 6) buffer Requests { ListHeader header; uint items[]; } requests;
layout(set = 0, binding = 7, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 8, rg32ui) uniform readonly uimage2D g_normal;
layout(set = 0, binding = 9, rg32ui) uniform readonly uimage2D g_albedo;
layout(set = 0, binding = 10, rgba32f) uniform readonly image2D previous;   // S0 + S1 + ... + S_{k-1}
layout(set = 0, binding = 11, rgba32f) uniform image2D final_image;
layout(set = 0, binding = 12, rgba32f) uniform image2D residual;           // S_k
layout(set = 0, binding = 13, r32f) uniform image2D samples;               // texels read per pixel
layout(set = 0, binding = 14) uniform utextureBuffer point_texels;          // points[] as texels (reads)
layout(set = 0, binding = 17) uniform utextureBuffer point_tails;           // their tails (EvalPoint)
layout(set = 0, binding = 15, rgba32f) uniform writeonly image2D residual_sources; // what S_k sends

// Whether what S_k sends is kept: a last step's is never read (LAST_STEP),
// and the renderer binds its residual there instead of an image of its own.
bool keeps_sources() {
    return (pc.frame.layers & LAST_STEP) == 0u;
}

// Whether S_k is kept in an image of its own (an output layer): without
// (NO_RESIDUAL) the step binds its final image there and only adds S_k to it.
bool keeps_residual() {
    return (pc.frame.layers & NO_RESIDUAL) == 0u;
}

// S_k(p) = diffuse colour / pi * I + the glossy rest (0 on a Lambertian
// receiver); what the pixel sends in the next step, view-independent
// (brdf_source_color); final = previous + S_k; `reads`: the pixel's own.
void write_residual(ivec2 p, Brdf b, vec3 integral, vec3 rest, float reads) {
    vec3 s = brdf_diffuse_color(b) / PI * integral + rest;
    if (keeps_residual()) imageStore(residual, p, vec4(s, 1.0));
    if (keeps_sources()) imageStore(residual_sources, p, vec4(brdf_source_color(b) / PI * integral, 1.0));
    imageStore(final_image, p, vec4(imageLoad(previous, p).rgb + s, 1.0));
    imageStore(samples, p, vec4(reads));
}

// Adds a glossy rest to what write_residual wrote for the pixel (what it
// sends is unchanged: it depends on I alone); `reads`: the pixel's own.
void add_glossy_rest(ivec2 p, vec3 rest, float reads) {
    if (keeps_residual()) imageStore(residual, p, imageLoad(residual, p) + vec4(rest, 0.0));
    imageStore(final_image, p, imageLoad(final_image, p) + vec4(rest, 0.0));
    imageStore(samples, p, vec4(reads));
}

// The pixel's BRDF.
Brdf pixel_brdf(ivec2 p) {
    return receiver_brdf(unpack_gbuffer_albedo(imageLoad(g_albedo, p)), unpack_gbuffer_normal(imageLoad(g_normal, p)));
}

// The glossy rest of a nearly Lambertian receiver whose integral I came
// from evaluation points: its BRDF taken at the sources' mean direction
// (the linear form's V), where it is within NEARLY_LAMBERTIAN of anywhere.
vec3 nearly_lambertian_rest(Brdf b, vec3 n, vec3 wo, Residual blend, vec3 integral) {
    vec3 v = blend.r.xyz + blend.g.xyz + blend.b.xyz;
    vec3 w = dot(v, v) > 0.0 ? normalize(v) : n;
    if (dot(w, n) <= 0.0) w = n;
    float diffuse_weight;
    vec3 specular;
    brdf_parts(b, n, wo, w, diffuse_weight, specular);
    return (brdf_diffuse_color(b) / PI * (diffuse_weight - 1.0) + specular) * integral;
}

#endif
