#version 430
// SVGF, step 2: the variance of each pixel's luminance. From its temporal moments once it has
// four frames of history; before that (a disocclusion) from its 7x7 neighbours' moments, on the
// same surface (edge-stopping on depth and normal), as the SVGF paper does.
#include "svgf_common.glsl"
in vec2 uv;
uniform sampler2D color;        // demodulated lighting, a: history length
uniform sampler2D moments;
uniform sampler2D g_position;
uniform sampler2D g_normal;
uniform sampler2D g_face;
uniform float phi_normal;
out vec4 out_color;             // rgb: lighting, a: variance

void main() {
    ivec2 size = textureSize(color, 0);
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 c = texelFetch(color, px, 0);
    if (!covered(g_face, px)) {
        out_color = vec4(c.rgb, 0.0);
        return;
    }
    vec2 m = texelFetch(moments, px, 0).rg;
    if (c.a >= 4.0) {
        out_color = vec4(c.rgb, max(m.y - m.x * m.x, 0.0));
        return;
    }
    vec4 pos = texelFetch(g_position, px, 0);
    vec3 n = texelFetch(g_normal, px, 0).xyz;
    vec3 sum_c = vec3(0.0);
    vec2 sum_m = vec2(0.0);
    float sum_w = 0.0;
    for (int y = -3; y <= 3; y++)
        for (int x = -3; x <= 3; x++) {
            ivec2 q = px + ivec2(x, y);
            if (!inside(q, size) || !covered(g_face, q))
                continue;
            vec4 qp = texelFetch(g_position, q, 0);
            float wz = exp(-abs(dot(qp.xyz - pos.xyz, n)) / (0.01 * pos.w + 1e-6));
            float wn = pow(max(dot(texelFetch(g_normal, q, 0).xyz, n), 0.0), phi_normal);
            float w = wz * wn;
            sum_c += w * texelFetch(color, q, 0).rgb;
            sum_m += w * texelFetch(moments, q, 0).rg;
            sum_w += w;
        }
    sum_w = max(sum_w, 1e-6);
    sum_m /= sum_w;
    // a short history: the spatial estimate, raised as the paper does for the first frames
    out_color = vec4(sum_c / sum_w, max(sum_m.y - sum_m.x * sum_m.x, 0.0) * (4.0 / c.a));
}
