#version 430
// Shadow map rendering: depth only.
in vec3 in_position;
uniform mat4 light_view_proj;
void main() { gl_Position = light_view_proj * vec4(in_position, 1.0); }
