#version 430
// G-buffer channel views for `--pass albedo|normal|...`: raw data, shown unmapped.
in vec2 uv;
uniform sampler2D g_position;
uniform sampler2D g_normal;
uniform sampler2D g_albedo;
uniform sampler2D g_emissive;
uniform sampler2D g_face;
uniform sampler2D g_motion;
uniform int channel;      // 0 albedo 1 normal 2 position 3 depth 4 roughness 5 emissive 6 motion 7 metallic
out vec4 value;
void main() {
    vec4 pos = texture(g_position, uv);
    vec3 v = vec3(0.0);
    if (channel == 0) v = texture(g_albedo, uv).rgb;
    else if (channel == 1) v = texture(g_normal, uv).xyz;
    else if (channel == 2) v = pos.xyz;
    else if (channel == 3) v = vec3(pos.w);
    else if (channel == 4) v = vec3(texture(g_normal, uv).w);
    else if (channel == 5) v = texture(g_emissive, uv).rgb;
    else if (channel == 6) v = vec3(texture(g_motion, uv).xy, 0.0);
    else if (channel == 7) v = vec3(texture(g_albedo, uv).a);
    value = vec4(v, 1.0);
}
