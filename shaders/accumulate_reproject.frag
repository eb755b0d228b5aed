#version 430
// Accumulation that survives camera motion (option reproject): each pixel keeps its own count of
// frames (alpha) and blends the history texels reproject.frag found on its surface (bilinear
// weights among the valid ones), then the new frame with weight 1 / count; a pixel with no valid
// history restarts from this frame. Counts stop at max_count (0: never).
#include "reproject_common.glsl"
in vec2 uv;
uniform sampler2D current;
uniform sampler2D history;      // rgb: mean, a: frames in it
uniform sampler2D reprojection; // reproject.frag
uniform float max_count;
uniform int restart;            // no history to go on from (a reset with the camera still): this frame alone
out vec4 mean;

void main() {
    ivec2 size = textureSize(history, 0);
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec3 c = texelFetch(current, px, 0).rgb;
    vec4 r = texelFetch(reprojection, px, 0);
    vec4 hist = vec4(0.0);
    float wsum = 0.0;
    if (r.w > 0.0 && restart == 0) {
        ivec2 base = ivec2(floor(r.xy));
        vec2 f = r.xy - vec2(base);
        int mask = int(r.z + 0.5);
        for (int k = 0; k < 4; k++) {
            if ((mask & (1 << k)) == 0)
                continue;
            float w = tap_weight(k, f);
            hist += w * texelFetch(history, clamp(base + ivec2(k & 1, k >> 1), ivec2(0), size - 1), 0);
            wsum += w;
        }
    }
    if (wsum < 1e-4) {
        mean = vec4(c, 1.0);
        return;
    }
    hist /= wsum;
    float n = hist.a;
    if (max_count > 0.0 && n >= max_count) {
        mean = hist;  // converged: kept as it is
        return;
    }
    mean = vec4(mix(hist.rgb, c, 1.0 / (n + 1.0)), n + 1.0);
}
