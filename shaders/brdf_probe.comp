#version 460
// A test probe: brdf.glsl evaluated at the inputs the host gives, which
// tests/glossy.rs checks against the CPU twin (src/cpu/brdf.rs): per input
// f(wo, wi), then what the surface sends as an SSBC source.
#include "common.glsl"
#include "brdf.glsl"

layout(local_size_x = 64) in;

struct ProbeInput {
    vec4 base_metallic;   // rgb base colour, w metallic
    vec4 n_roughness;     // xyz unit normal, w roughness
    vec4 wo_specular;     // xyz unit view direction, w specular layer
    vec4 wi;              // xyz unit light direction
};

layout(set = 0, binding = 0) readonly buffer Inputs { ProbeInput inputs[]; };
layout(set = 0, binding = 1) writeonly buffer Outputs { vec4 outputs[]; };

layout(push_constant) uniform Push {
    uint count;
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    ProbeInput p = inputs[i];
    Brdf b = Brdf(p.base_metallic.rgb, p.base_metallic.w, p.n_roughness.w, p.wo_specular.w);
    outputs[2u * i] = vec4(brdf_eval(b, p.n_roughness.xyz, p.wo_specular.xyz, p.wi.xyz), 0.0);
    outputs[2u * i + 1u] = vec4(brdf_source_color(b), 0.0);
}
