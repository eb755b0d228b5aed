#version 430
// SVGF, step 3: one edge-avoiding a-trous wavelet iteration (5x5 B3-spline taps, `step` texels
// apart): weights stop at depth (the pixel's plane), normal and luminance edges, the latter
// scaled by the 3x3-blurred standard deviation, and the variance is filtered with the squared
// weights. `remodulate` multiplies the albedo back and adds the emission (the last iteration),
// or where the specular part is filtered apart (svgf_common.glsl), the diffuse run's result.
#include "svgf_common.glsl"
in vec2 uv;
uniform sampler2D color;        // rgb: demodulated lighting, a: variance
uniform sampler2D g_position;
uniform sampler2D g_normal;
uniform sampler2D g_albedo;
uniform sampler2D g_emissive;   // the first hit's emission, added back by the last iteration
uniform sampler2D g_face;
uniform sampler2D radiance;     // passed through where nothing is covered (the sky)
uniform sampler2D guide;        // b: the luminance edges stop at (svgf_temporal.frag)
uniform sampler2D diffuse;      // the diffuse run's result, which the specular run's last iteration adds to
uniform int step;
uniform float phi_color;
uniform float phi_normal;
uniform float phi_depth;
uniform int remodulate;
out vec4 out_color;

const float H[3] = float[3](3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0);

void main() {
    ivec2 size = textureSize(color, 0);
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 c = texelFetch(color, px, 0);
    if (!covered(g_face, px)) {
        out_color = remodulate != 0 ? vec4(texelFetch(radiance, px, 0).rgb, 1.0) : c;
        return;
    }
    vec4 pos = texelFetch(g_position, px, 0);
    vec3 n = texelFetch(g_normal, px, 0).xyz;
    float l = texelFetch(guide, px, 0).b;
    float blurred = 0.0;  // the variance under a 3x3 Gaussian: a steadier luminance scale
    float wsum = 0.0;
    for (int y = -1; y <= 1; y++)
        for (int x = -1; x <= 1; x++) {
            ivec2 q = clamp(px + ivec2(x, y), ivec2(0), size - 1);
            float k = (x == 0 ? 0.5 : 0.25) * (y == 0 ? 0.5 : 0.25);
            blurred += k * texelFetch(color, q, 0).a;
            wsum += k;
        }
    float sigma_l = phi_color * sqrt(max(blurred / wsum, 0.0)) + 1e-6;
    float sigma_z = phi_depth * 0.01 * pos.w * float(step) + 1e-6;
    vec4 sum = vec4(0.0);
    float sum_w = 0.0;
    for (int y = -2; y <= 2; y++)
        for (int x = -2; x <= 2; x++) {
            ivec2 q = px + ivec2(x, y) * step;
            if (!inside(q, size) || !covered(g_face, q))
                continue;
            vec4 cq = texelFetch(color, q, 0);
            float h = H[abs(x)] * H[abs(y)];
            float wz = abs(dot(texelFetch(g_position, q, 0).xyz - pos.xyz, n)) / sigma_z;
            float wl = abs(texelFetch(guide, q, 0).b - l) / sigma_l;
            float wn = pow(max(dot(texelFetch(g_normal, q, 0).xyz, n), 0.0), phi_normal);
            float w = h * exp(-wz - wl) * wn;
            sum += vec4(w * cq.rgb, w * w * cq.a);
            sum_w += w;
        }
    vec4 f = sum_w > 0.0 ? vec4(sum.rgb / sum_w, sum.a / (sum_w * sum_w)) : c;
    if (remodulate != 0) {
        vec3 rest = split != 0 && signal == 1 ? texelFetch(diffuse, px, 0).rgb
                                              : emission(g_emissive, texelFetch(radiance, px, 0).rgb, px);
        f = vec4(f.rgb * demod_factor(texelFetch(g_albedo, px, 0), texelFetch(g_normal, px, 0), pos.xyz) + rest, 1.0);
    }
    out_color = f;
}
