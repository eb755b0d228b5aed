#version 430
// Reprojection of the accumulated history (option reproject): for each pixel, where its point
// was in the previous frame (through the motion vectors) and which of the four texels around
// that place saw the same surface (reproject_common.glsl). The accumulation pass
// (accumulate_reproject.frag) blends those.
#include "reproject_common.glsl"
in vec2 uv;
uniform sampler2D g_position;   // xyz, w: linear depth
uniform sampler2D g_normal;
uniform sampler2D g_face;       // w > 0: covered
uniform sampler2D g_motion;     // pixels moved since the previous frame (no jitter)
uniform sampler2D prev_position;
uniform sampler2D prev_normal;
uniform int moved;              // the camera moved since the previous frame
out vec4 where;                 // xy: the previous frame's texel coordinates, z: mask of valid taps, w: 1 if any

void main() {
    ivec2 size = textureSize(g_position, 0);
    ivec2 px = ivec2(gl_FragCoord.xy);
    if (moved == 0) {  // a still camera: every pixel continues its own mean, covered or not
        where = vec4(vec2(px), 1.0, 1.0);
        return;
    }
    if (texelFetch(g_face, px, 0).w <= 0.0) {  // the sky moved with the camera: restart
        where = vec4(0.0);
        return;
    }
    vec4 pos = texelFetch(g_position, px, 0);
    vec3 n = texelFetch(g_normal, px, 0).xyz;
    vec2 prev = previous_texel(gl_FragCoord.xy, texelFetch(g_motion, px, 0).xy);
    ivec2 base = ivec2(floor(prev));
    float mask = 0.0;
    for (int k = 0; k < 4; k++) {
        ivec2 q = base + ivec2(k & 1, k >> 1);
        if (inside(q, size) && same_surface(texelFetch(prev_position, q, 0), texelFetch(prev_normal, q, 0).xyz, pos, n))
            mask += float(1 << k);
    }
    where = vec4(prev, mask, mask > 0.0 ? 1.0 : 0.0);
}
