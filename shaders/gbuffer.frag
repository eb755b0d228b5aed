#version 430
#include "common.glsl"
// G-buffer: everything a later pass needs about the primary hit, in world space.
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
#ifdef HAS_VERTEX_COLORS
in vec3 v_color;
#endif
in vec4 v_clip;
in vec4 v_prev_clip;
uniform vec2 jitter_ndc;  // this frame's subpixel jitter, in v_clip (app/frame.py)
uniform vec2 jitter_px;   // the same in pixels, as the ray-traced passes take it
uniform vec3 eye;
uniform vec3 cam_right;
uniform vec3 cam_up;
uniform vec3 cam_forward;
uniform float tan_half;
uniform vec2 viewport;
// the scene's vertex positions and triangles (the vertex array's own buffers): the linear depth
// is the pixel's camera ray meeting its triangle's plane, in double precision, rather than the
// interpolated position's, whose error grows with the triangle's size and distance (a plane
// 400 km wide seen from 500 m: points centimetres under it, AO 0.20 for 0.25)
layout(std430, binding = 6) readonly buffer Positions { float positions[]; };
layout(std430, binding = 7) readonly buffer Indices { int indices[]; };

dvec3 vertex_position(int i) { return dvec3(positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]); }

// the linear depth along the ray the ray-traced passes rebuild this pixel's point from
// (rt/embree/kernels.unpack_gbuffer, shaders/rt/unpack.slang): eye + ray * depth lies on the plane
float plane_depth(float fallback) {
    dvec3 p0 = vertex_position(indices[3 * gl_PrimitiveID]);
    dvec3 n = cross(vertex_position(indices[3 * gl_PrimitiveID + 1]) - p0,
                    vertex_position(indices[3 * gl_PrimitiveID + 2]) - p0);
    vec2 pixel = vec2(gl_FragCoord.x, viewport.y - gl_FragCoord.y) + jitter_px;  // x, row from the top
    float sx = (pixel.x / viewport.x * 2.0 - 1.0) * tan_half * (viewport.x / viewport.y);
    float sy = (1.0 - pixel.y / viewport.y * 2.0) * tan_half;
    dvec3 ray = dvec3(cam_right * sx + cam_up * sy + cam_forward);
    double along = dot(n, ray);
    double depth = dot(n, p0 - dvec3(eye)) / along;
    // edge-on or degenerate (no plane): the interpolated depth
    if (abs(along) <= 1e-9 * length(n) || !(depth > 0.0)) return fallback;
    return float(depth);
}
layout(location = 0) out vec4 out_position;   // xyz world position, w linear depth (m)
layout(location = 1) out vec4 out_normal;     // xyz shading normal (faces the eye), w roughness
layout(location = 2) out vec4 out_albedo;     // rgb albedo, a metallic
layout(location = 3) out vec4 out_emissive;   // rgb emitted radiance, a material id
layout(location = 4) out vec4 out_face;       // xyz face normal (faces the eye), w coverage
layout(location = 5) out vec2 out_motion;     // pixels moved since the previous frame
void main() {
    MaterialSample m = fetch_material(triangle_material(gl_PrimitiveID), v_uv);
#ifdef HAS_VERTEX_COLORS
    m.albedo *= v_color;
#endif
    if (m.cutoff >= 0.0 && m.alpha < m.cutoff) discard;  // alpha MASK (BLEND drawn as MASK)
    if (m.single_sided && !gl_FrontFacing) discard;  // a single-sided surface seen from behind
    vec3 to_eye = eye - v_position;
    vec3 ng = normalize(cross(dFdx(v_position), dFdy(v_position)));
    if (dot(ng, to_eye) < 0.0) ng = -ng;
    vec3 n = mapped_normal(m, normalize(v_normal), v_tangent);
    if (dot(n, ng) < 0.0) n = -n;  // double-sided: shade the side we see
    out_position = vec4(v_position, plane_depth(dot(v_position - eye, cam_forward)));
    out_normal = vec4(n, m.roughness);
    out_albedo = vec4(m.albedo, m.metallic);
    out_emissive = vec4(m.emissive, float(m.id));
    out_face = vec4(ng, 1.0);
    vec2 cur = ((v_clip.xy / v_clip.w - jitter_ndc) * 0.5 + 0.5) * viewport;  // motion without the jitter
    vec2 prev = (v_prev_clip.xy / v_prev_clip.w * 0.5 + 0.5) * viewport;
    out_motion = cur - prev;
}
