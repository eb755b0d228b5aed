#version 430
// SVGF, step 2: the variance of each pixel's averaged luminance: its samples' variance from the
// temporal moments of its 7x7 neighbours on the same surface (edge-stopping on depth and normal)
// once it has four frames of history, before that (a disocclusion) from their moments' spread, as
// the SVGF paper does; over the samples the average holds, so the a-trous filter narrows as it
// converges.
#include "svgf_common.glsl"
in vec2 uv;
uniform sampler2D color;        // demodulated lighting, a: history length
uniform sampler2D moments;
uniform sampler2D g_position;
uniform sampler2D g_normal;
uniform sampler2D g_face;
uniform float phi_normal;
uniform float alpha;            // the temporal average's least weight of a new frame
uniform int of_average;         // 0 (svgf.feedback, the paper's): the samples' variance itself
out vec4 out_color;             // rgb: lighting, a: the variance of its average

// the frames' worth of independent samples in a history of `frames`: all of them while the
// average is even, then an exponential average's (2 - alpha) / alpha
float samples(float frames) { return of_average != 0 ? max(min(frames, (2.0 - alpha) / alpha), 1.0) : 1.0; }

void main() {
    ivec2 size = textureSize(color, 0);
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 c = texelFetch(color, px, 0);
    if (!covered(g_face, px)) {
        out_color = vec4(c.rgb, 0.0);
        return;
    }
    vec4 pos = texelFetch(g_position, px, 0);
    vec3 n = texelFetch(g_normal, px, 0).xyz;
    vec3 sum_c = vec3(0.0);
    vec2 sum_m = vec2(0.0);
    float sum_w = 0.0, sum_v = 0.0;
    for (int y = -3; y <= 3; y++)
        for (int x = -3; x <= 3; x++) {
            ivec2 q = px + ivec2(x, y);
            if (!inside(q, size) || !covered(g_face, q))
                continue;
            vec4 qp = texelFetch(g_position, q, 0);
            float wz = exp(-abs(dot(qp.xyz - pos.xyz, n)) / (0.01 * pos.w + 1e-6));
            float wn = pow(max(dot(texelFetch(g_normal, q, 0).xyz, n), 0.0), phi_normal);
            float w = wz * wn;
            vec2 mq = texelFetch(moments, q, 0).rg;
            sum_c += w * texelFetch(color, q, 0).rgb;
            sum_m += w * mq;
            sum_v += w * max(mq.y - mq.x * mq.x, 0.0);
            sum_w += w;
        }
    sum_w = max(sum_w, 1e-6);
    if (c.a >= 4.0) {
        // the neighbours' own temporal variances, pooled: one pixel's few samples of a binary
        // signal (1-ray AO) are often all alike, and its variance 0 would stop the filter there
        out_color = vec4(c.rgb, sum_v / sum_w / samples(c.a));
        return;
    }
    sum_m /= sum_w;
    // a short history: the spatial estimate, raised as the paper does for the first frames
    out_color = vec4(sum_c / sum_w, max(sum_m.y - sum_m.x * sum_m.x, 0.0) * (4.0 / c.a) / samples(c.a));
}
