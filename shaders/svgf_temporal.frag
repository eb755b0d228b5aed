#version 430
// SVGF, step 1: temporal accumulation of the demodulated lighting (the radiance less the first
// hit's emission, over its albedo) and of its first two
// luminance moments, through the motion vectors. The previous frame's four texels around the
// reprojected point are each kept only where they saw the same surface (reproject_common.glsl:
// same_surface, as the reprojected accumulation tests it): disocclusions restart at the current
// sample.
#include "svgf_common.glsl"
in vec2 uv;
uniform sampler2D radiance;     // this frame's noisy radiance
uniform sampler2D g_position;   // xyz, w: linear depth
uniform sampler2D g_normal;
uniform sampler2D g_albedo;
uniform sampler2D g_emissive;   // the first hit's emission: not filtered (svgf_common.glsl: emission)
uniform sampler2D g_face;       // w > 0: covered
uniform sampler2D g_motion;     // pixels moved since the previous frame (no jitter)
uniform sampler2D rt_specular;  // the radiance's specular part, where split (svgf_common.glsl)
uniform sampler2D prev_color;   // demodulated lighting, a: history length (frames)
uniform sampler2D prev_moments; // luminance moments m1, m2
uniform sampler2D prev_position;
uniform sampler2D prev_normal;
uniform int has_history;
uniform float alpha;
uniform float moments_alpha;
layout(location = 0) out vec4 out_color;
layout(location = 1) out vec4 out_moments;

void main() {
    ivec2 size = textureSize(radiance, 0);
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec3 rad = texelFetch(radiance, px, 0).rgb;
    if (!covered(g_face, px)) {
        out_color = vec4(rad, 0.0);
        out_moments = vec4(0.0);
        return;
    }
    vec4 pos = texelFetch(g_position, px, 0);
    vec3 n = texelFetch(g_normal, px, 0).xyz;
    vec3 spec = split != 0 ? texelFetch(rt_specular, px, 0).rgb : vec3(0.0);
    vec3 illum = signal_part(rad, emission(g_emissive, rad, px), spec)
                 / demod_factor(texelFetch(g_albedo, px, 0), vec4(n, texelFetch(g_normal, px, 0).w), pos.xyz);
    float l = luma(illum);
    vec2 prev = previous_texel(gl_FragCoord.xy, texelFetch(g_motion, px, 0).xy);
    ivec2 base = ivec2(floor(prev));
    vec2 f = prev - vec2(base);
    vec4 sum_color = vec4(0.0);
    vec2 sum_moments = vec2(0.0);
    float sum_w = 0.0;
    if (has_history != 0) {
        for (int k = 0; k < 4; k++) {
            ivec2 q = base + ivec2(k & 1, k >> 1);
            if (!inside(q, size) || !same_surface(texelFetch(prev_position, q, 0), texelFetch(prev_normal, q, 0).xyz,
                                                  pos, n))
                continue;
            float w = tap_weight(k, f);
            sum_color += w * texelFetch(prev_color, q, 0);
            sum_moments += w * texelFetch(prev_moments, q, 0).rg;
            sum_w += w;
        }
    }
    if (sum_w > 1e-3) {
        vec4 hist = sum_color / sum_w;
        vec2 moments = sum_moments / sum_w;
        float frames = min(hist.a + 1.0, 255.0);
        float a = max(1.0 / frames, alpha), am = max(1.0 / frames, moments_alpha);
        out_color = vec4(mix(hist.rgb, illum, a), frames);
        // b: the luminance that the a-trous passes stop at: the history's, which this frame's
        // noise has no part in (with the frame's own, binary noise was biased towards a
        // pixel's likes: 1-ray AO -4 %)
        out_moments = vec4(mix(moments, vec2(l, l * l), am), luma(hist.rgb), 0.0);
    } else {
        out_color = vec4(illum, 1.0);
        out_moments = vec4(l, l * l, l, 0.0);
    }
}
