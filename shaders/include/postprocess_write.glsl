// SSBC as a post-process: its result written into the host's image by a
// compute shader, in the image's format (OUTPUT_FORMAT, defined by the
// kernel that includes this): stored, or added onto what the image holds
// (the host's lighting). src/postprocess/convert.rs.

layout(local_size_x = 8, local_size_y = 8) in;

// S0 + S_1..S_K, or one residual S_k.
layout(set = 0, binding = 0, rgba32f) uniform readonly image2D result;
// S0, subtracted from `result` if pc.subtract (adding the compensation
// alone onto an image that holds S0 already); else `result` again.
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D subtract;
layout(set = 0, binding = 2, OUTPUT_FORMAT) uniform image2D host_output;

layout(push_constant) uniform WritePush {
    uvec2 size;
    uint add;        // 1: host_output += ..., 0: host_output = ...
    uint subtract;   // 1: ... result - subtract, 0: ... result
} pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(p), pc.size))) return;
    vec3 c = imageLoad(result, p).rgb;
    if (pc.subtract != 0u) c -= imageLoad(subtract, p).rgb;
    vec4 onto = pc.add != 0u ? imageLoad(host_output, p) : vec4(0.0, 0.0, 0.0, 1.0);
    imageStore(host_output, p, vec4(onto.rgb + c, onto.a));
}
