#version 430
// World-space geometry for the G-buffer and the forward pass.
in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;
in vec4 in_tangent;  // (0, 0, 0, 1) where the scene has no normal maps
uniform mat4 view_proj;
uniform mat4 prev_view_proj;
out vec3 v_position;
out vec3 v_normal;
out vec2 v_uv;
out vec4 v_tangent;
#ifdef HAS_VERTEX_COLORS
in vec3 in_color;    // glTF COLOR_0, linear: times the base colour
out vec3 v_color;
#endif
out vec4 v_clip;
out vec4 v_prev_clip;
void main() {
    v_position = in_position;
    v_normal = in_normal;
    v_uv = in_uv;
    v_tangent = in_tangent;
#ifdef HAS_VERTEX_COLORS
    v_color = in_color;
#endif
    v_clip = view_proj * vec4(in_position, 1.0);
    v_prev_clip = prev_view_proj * vec4(in_position, 1.0);
    gl_Position = v_clip;
}
