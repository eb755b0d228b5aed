#version 430
// The G-buffer packed for the CPU's ray-traced passes: 32 bytes a pixel instead of 80.
//   geometry (RGBA32UI): linear depth (float bits; 0 = nothing there), shading normal and face
//                        normal (octahedral, 2 x snorm16 each), albedo red and green (halves)
//   material (RGBA32UI): emitted radiance and roughness as four halves, albedo blue and metallic
//                        (halves), a word unused
// Halves keep the albedo within 0.05 %: 8 bits a channel made the images of the ray-traced
// passes up to 0.5 % off (tests/test_convergence.py).
// The CPU rebuilds the position from the pixel's camera ray and the depth (rt/gbuffer.py).
in vec2 uv;
uniform sampler2D g_position;
uniform sampler2D g_normal;
uniform sampler2D g_albedo;
uniform sampler2D g_emissive;
uniform sampler2D g_face;
layout(location = 0) out uvec4 out_geometry;
layout(location = 1) out uvec4 out_material;

vec2 sign_not_zero(vec2 v) { return vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0); }

uint octahedral(vec3 n) {
    n /= max(abs(n.x) + abs(n.y) + abs(n.z), 1e-20);
    vec2 p = n.z >= 0.0 ? n.xy : (1.0 - abs(n.yx)) * sign_not_zero(n.xy);
    return packSnorm2x16(p);
}

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 face = texelFetch(g_face, px, 0);
    if (face.w <= 0.0) {
        out_geometry = uvec4(0u);
        out_material = uvec4(0u);
        return;
    }
    vec4 pos = texelFetch(g_position, px, 0);
    vec4 nrm = texelFetch(g_normal, px, 0);
    vec4 alb = texelFetch(g_albedo, px, 0);
    vec4 emi = texelFetch(g_emissive, px, 0);
    out_geometry = uvec4(floatBitsToUint(max(pos.w, 1e-30)), octahedral(nrm.xyz), octahedral(face.xyz),
                         packHalf2x16(alb.rg));
    out_material = uvec4(packHalf2x16(emi.rg), packHalf2x16(vec2(emi.b, nrm.w)), packHalf2x16(alb.ba), 0u);
}
