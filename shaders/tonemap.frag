#version 430
// Exposure + ACES filmic curve (Narkowicz fit) + sRGB encoding. mode 1 shows data unmapped.
in vec2 uv;
uniform sampler2D hdr;
uniform float exposure;
uniform int mode;  // 0 radiance, 1 data channel: value * data_scale + data_bias, clamped
uniform vec3 data_scale;
uniform vec3 data_bias;
out vec4 color;
vec3 aces(vec3 x) {
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}
vec3 srgb(vec3 c) {
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}
void main() {
    vec3 c = texture(hdr, uv).rgb;
    if (mode == 1) { c = clamp(c * data_scale + data_bias, 0.0, 1.0); color = vec4(c, dot(c, vec3(0.299, 0.587, 0.114))); return; }
    c = srgb(aces(max(c, vec3(0.0)) * exposure));
    // luma in alpha for FXAA
    color = vec4(c, dot(c, vec3(0.299, 0.587, 0.114)));
}
