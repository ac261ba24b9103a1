#version 460
// Shadow map: depth only, one layer per draw.

layout(location = 0) in vec3 in_position;

layout(push_constant) uniform Push {
    mat4 view_proj;
} pc;

void main() {
    gl_Position = pc.view_proj * vec4(in_position, 1.0);
}
