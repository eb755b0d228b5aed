#version 430
// Screen-space ambient occlusion: hemisphere kernel around the G-buffer normal.
// The raster counterpart of rt/ao.py; output 1 = fully open, like RT AO.
in vec2 uv;
uniform sampler2D g_position;  // xyz world, w linear depth
uniform sampler2D g_normal;
uniform sampler2D g_face;
uniform sampler2D noise;       // 4x4 random rotation vectors
uniform vec3 kernel[64];
uniform int samples;
uniform float radius;
uniform mat4 view_proj;
uniform vec3 eye;
uniform vec3 cam_forward;
uniform vec2 viewport;
out float ao;
void main() {
    vec4 face = texture(g_face, uv);
    if (face.w == 0.0) { ao = 1.0; return; }
    vec3 p = texture(g_position, uv).xyz;
    vec3 n = normalize(texture(g_normal, uv).xyz);
    vec3 r = normalize(texture(noise, gl_FragCoord.xy / 4.0).xyz * 2.0 - 1.0);
    vec3 t = normalize(r - n * dot(r, n));
    if (any(isnan(t))) t = normalize(abs(n.x) < 0.9 ? cross(n, vec3(1, 0, 0)) : cross(n, vec3(0, 1, 0)));
    mat3 tbn = mat3(t, cross(n, t), n);
    float occluded = 0.0;
    float depth_here = texture(g_position, uv).w;
    for (int i = 0; i < samples; ++i) {
        vec3 s = p + tbn * kernel[i] * radius;
        vec4 c = view_proj * vec4(s, 1.0);
        if (c.w <= 0.0) continue;
        vec2 suv = c.xy / c.w * 0.5 + 0.5;
        if (any(lessThan(suv, vec2(0.0))) || any(greaterThan(suv, vec2(1.0)))) continue;
        vec4 scene = texture(g_position, suv);
        if (texture(g_face, suv).w == 0.0) continue;
        float sample_depth = dot(s - eye, cam_forward);
        float bias = 0.02 * radius;
        float range = smoothstep(0.0, 1.0, radius / max(abs(depth_here - scene.w), 1e-4));
        occluded += (scene.w < sample_depth - bias ? 1.0 : 0.0) * range;
    }
    ao = 1.0 - occluded / float(samples);
}
