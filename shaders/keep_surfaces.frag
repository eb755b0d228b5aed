#version 430
// The G-buffer's surfaces kept for the next frame's reprojection (app/raster/reproject.py).
in vec2 uv;
uniform sampler2D g_position;
uniform sampler2D g_normal;
uniform sampler2D g_face;
layout(location = 0) out vec4 out_position;  // w 0: nothing there
layout(location = 1) out vec4 out_normal;
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    out_position = texelFetch(g_face, px, 0).w > 0.0 ? texelFetch(g_position, px, 0) : vec4(0.0);
    out_normal = texelFetch(g_normal, px, 0);
}
