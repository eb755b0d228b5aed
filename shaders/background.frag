#version 430
#include "common.glsl"
// Environment radiance behind the geometry (rays that miss).
in vec2 uv;
uniform mat4 inv_view_proj;
uniform vec3 eye;
uniform int env_kind;
uniform vec3 env_color;
uniform float env_strength;
uniform sampler2D env_map;  // env_kind 4: the equirectangular map (rows from +Y down), linear, repeat in s
uniform float env_shift;    // its u shift (option env.rotation)
out vec4 radiance;
void main() {
    vec4 p = inv_view_proj * vec4(uv * 2.0 - 1.0, 1.0, 1.0);
    vec3 dir = normalize(p.xyz / p.w - eye);
    if (env_kind == 4) {  // as scenes/model.py equirect_uv reads a map
        float u = atan(dir.x, -dir.z) * 0.15915494309189535 + env_shift;
        float v = acos(clamp(dir.y, -1.0, 1.0)) * 0.3183098861837907;
        radiance = vec4(texture(env_map, vec2(u - floor(u), v)).rgb * env_strength, 1.0);
    } else {
        radiance = vec4(env_radiance(env_kind, env_color, env_strength, dir), 1.0);
    }
}
