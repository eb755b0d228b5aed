#version 430
// SVGF, step 4 (svgf.resolve): the filtered frame averaged over frames, as raw accumulation
// averages its jittered frames: a single frame's G-buffer sees each pixel through one jittered
// sample, so its edges (sky against geometry, albedo and emission boundaries) alias where the
// converged image blends them. The previous resolved frame is read through the motion vectors
// (bilinear) and mixed with this one by max(1/frames, alpha); where the camera moved, it is first
// clamped to this frame's 3x3 neighbourhood so that it cannot ghost.
#include "svgf_common.glsl"
in vec2 uv;
uniform sampler2D current;      // this frame's filtered radiance
uniform sampler2D previous;     // rgb: the last resolved frame, a: frames it holds
uniform sampler2D g_motion;     // pixels moved since the previous frame (no jitter)
uniform int has_history;
uniform float alpha;
out vec4 out_color;

void main() {
    ivec2 size = textureSize(current, 0);
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec3 cur = texelFetch(current, px, 0).rgb;
    vec2 motion = texelFetch(g_motion, px, 0).xy;
    vec2 prev = previous_texel(gl_FragCoord.xy, motion);
    ivec2 base = ivec2(floor(prev));
    vec2 f = prev - vec2(base);
    vec4 hist = vec4(0.0);
    float sum_w = 0.0;
    if (has_history != 0) {
        for (int k = 0; k < 4; k++) {
            ivec2 q = base + ivec2(k & 1, k >> 1);
            if (!inside(q, size))
                continue;
            float w = tap_weight(k, f);
            hist += w * texelFetch(previous, q, 0);
            sum_w += w;
        }
    }
    if (sum_w < 1e-3) {
        out_color = vec4(cur, 1.0);
        return;
    }
    hist /= sum_w;
    float frames = min(hist.a + 1.0, 255.0);
    if (dot(motion, motion) > 1e-4) {  // moved: the history is kept within what this frame sees around it
        vec3 lo = cur, hi = cur;
        for (int y = -1; y <= 1; y++)
            for (int x = -1; x <= 1; x++) {
                vec3 c = texelFetch(current, clamp(px + ivec2(x, y), ivec2(0), size - 1), 0).rgb;
                lo = min(lo, c);
                hi = max(hi, c);
            }
        hist.rgb = clamp(hist.rgb, lo, hi);
        frames = min(frames, 1.0 / alpha);
    }
    float a = max(1.0 / frames, alpha);
    out_color = vec4(hist.rgb + (cur - hist.rgb) * a, frames);
}
