#version 430
// SVGF, step 4: what the next frame reprojects: the first a-trous iteration's lighting with the
// history length, the moments, and the surfaces (to test that a texel still sees the same one).
in vec2 uv;
uniform sampler2D filtered;     // the first a-trous iteration (rgb)
uniform sampler2D color;        // the temporal pass's output (a: history length)
uniform sampler2D moments;
uniform sampler2D g_position;
uniform sampler2D g_normal;
uniform sampler2D g_face;
layout(location = 0) out vec4 out_color;
layout(location = 1) out vec4 out_moments;
layout(location = 2) out vec4 out_position;
layout(location = 3) out vec4 out_normal;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    bool seen = texelFetch(g_face, px, 0).w > 0.0;
    out_color = vec4(texelFetch(filtered, px, 0).rgb, texelFetch(color, px, 0).a);
    out_moments = texelFetch(moments, px, 0);
    out_position = seen ? texelFetch(g_position, px, 0) : vec4(0.0);  // w 0: nothing to reproject
    out_normal = texelFetch(g_normal, px, 0);
}
