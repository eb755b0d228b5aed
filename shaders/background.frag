#version 430
#include "common.glsl"
// Environment radiance behind the geometry (rays that miss).
in vec2 uv;
uniform mat4 inv_view_proj;
uniform vec3 eye;
uniform int env_kind;
uniform vec3 env_color;
uniform float env_strength;
out vec4 radiance;
void main() {
    vec4 p = inv_view_proj * vec4(uv * 2.0 - 1.0, 1.0, 1.0);
    vec3 dir = normalize(p.xyz / p.w - eye);
    radiance = vec4(env_radiance(env_kind, env_color, env_strength, dir), 1.0);
}
