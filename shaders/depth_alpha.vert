#version 430
// Shadow map rendering of scenes with masked materials: depth, and uvs for their alpha test.
in vec3 in_position;
in vec2 in_uv;
uniform mat4 light_view_proj;
out vec2 v_uv;
void main() {
    v_uv = in_uv;
    gl_Position = light_view_proj * vec4(in_position, 1.0);
}
