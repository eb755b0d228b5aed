#version 430
#include "common.glsl"
// Forward-rendered baseline: all analytic lights + proxy lights for emissive surfaces,
// shadow maps with PCF, SSAO on the ambient term, environment cube map reflections; under glTF's
// BRDF the environment's specular light by the split sum (app/raster/split_sum.py).
// Lambertian albedo/pi, irradiance I cos / d^2: the same conventions as the ray-traced passes.
in vec3 v_position;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_tangent;
#ifdef HAS_VERTEX_COLORS
in vec3 v_color;
#endif
in vec4 v_clip;
in vec4 v_prev_clip;

struct Light {
    vec4 position_kind;   // xyz, kind: 0 point, 1 spot, 2 directional, 3 emissive proxy
    vec4 direction_slot;  // xyz direction light travels (spot axis, sun; proxy: emitter normal), shadow slot
    vec4 radiance_lobe;   // rgb colour * intensity (W/sr or W/m^2), proxy flatness 0..1
    vec4 cone;            // spot: cos(outer), cos(inner); point shadow: near, far
};
layout(std140) uniform Lights { Light lights[128]; };
uniform int light_count;

uniform vec3 eye;
uniform vec2 viewport;
uniform int env_kind;
uniform vec3 env_color;
uniform float env_strength;
uniform vec3 ambient_radiance;     // the scene's ambient hint (engines' ambient light)
uniform float ambient_scale;
uniform sampler2D ambient_lut;     // env irradiance / pi vs normal.y, 64 x 1
uniform samplerCube irradiance_cube;  // env irradiance / pi vs the normal (a map's: it varies with azimuth)
uniform int use_irradiance_cube;
uniform sampler2D ssao;
uniform int use_ssao;
uniform samplerCube env_cube;
uniform int use_env_reflections;
uniform sampler2DArray specular_maps;  // the environment prefiltered per roughness (app/raster/split_sum.py)
uniform sampler2D brdf_lut;            // A, B of the specular albedo f0 A + B, by n.v (s) and roughness (t)
uniform int use_split_sum;
const int SPECULAR_LEVELS = 6;
uniform float roughness_threshold;
uniform int use_shadows;
uniform int use_ggx;               // glTF's metal-rough BRDF (option brdf), else the study's Lambert
uniform sampler2DShadow sun_shadow;
uniform mat4 sun_view_proj;
uniform int sun_slot;              // index of the light that owns the sun map, -1 none
uniform float sun_texel;           // world size of one sun shadow texel
uniform sampler2DShadow point_shadow;  // atlas: 6 faces per row, one row per slot
uniform int point_shadow_rows;
uniform int pcf_radius;
// hybrid: ray-traced pieces computed on the CPU for the same pixels (0 = use raster)
uniform int use_rt_direct;       // rt_direct: irradiance x cos from all lights, RT visibility
                                 // (with use_ggx: the direct radiance, the BRDF applied)
uniform int use_rt_ao;           // rt_ao: AO instead of SSAO
uniform int use_rt_reflection;   // rt_reflection: reflected radiance, alpha 1 where traced
uniform int use_rt_indirect;     // rt_indirect: mean incoming indirect radiance
uniform sampler2D rt_direct;
uniform sampler2D rt_ao;
uniform sampler2D rt_reflection;
uniform sampler2D rt_indirect;
out vec4 radiance;

const vec3 FACE_F[6] = vec3[](vec3(1,0,0), vec3(-1,0,0), vec3(0,1,0), vec3(0,-1,0), vec3(0,0,1), vec3(0,0,-1));
const vec3 FACE_U[6] = vec3[](vec3(0,-1,0), vec3(0,-1,0), vec3(0,0,1), vec3(0,0,-1), vec3(0,-1,0), vec3(0,-1,0));

float pcf(sampler2DShadow map, vec3 coord, vec2 lo, vec2 hi) {
    vec2 texel = 1.0 / vec2(textureSize(map, 0));
    float sum = 0.0;
    float n = 0.0;
    for (int x = -pcf_radius; x <= pcf_radius; ++x)
        for (int y = -pcf_radius; y <= pcf_radius; ++y) {
            vec2 p = clamp(coord.xy + vec2(x, y) * texel, lo, hi);
            sum += texture(map, vec3(p, coord.z));
            n += 1.0;
        }
    return sum / n;
}

float sun_visibility(vec3 p, vec3 ng, vec3 l) {
    float slope = sqrt(max(1.0 - dot(ng, l) * dot(ng, l), 0.0));
    vec3 q = p + ng * sun_texel * (1.5 + 2.0 * slope);  // normal offset against acne
    vec4 c = sun_view_proj * vec4(q, 1.0);
    vec3 s = c.xyz / c.w * 0.5 + 0.5;
    if (any(lessThan(s.xy, vec2(0.0))) || any(greaterThan(s.xy, vec2(1.0))) || s.z > 1.0) return 1.0;
    vec2 texel = 1.0 / vec2(textureSize(sun_shadow, 0));
    return pcf(sun_shadow, s - vec3(0, 0, 0.0005), texel * 0.5, 1.0 - texel * 0.5);
}

float point_visibility(int slot, vec3 light_pos, vec3 p, vec3 ng, float near, float far) {
    vec3 d0 = p - light_pos;
    float dist = length(d0);
    vec3 q = p + ng * max(dist * 0.004, 0.002);
    vec3 d = q - light_pos;
    vec3 a = abs(d);
    int face = a.x >= a.y && a.x >= a.z ? (d.x > 0.0 ? 0 : 1) : (a.y >= a.z ? (d.y > 0.0 ? 2 : 3) : (d.z > 0.0 ? 4 : 5));
    vec3 f = FACE_F[face], u = FACE_U[face], r = cross(f, u);
    float z = dot(f, d);
    vec2 ndc = vec2(dot(r, d), dot(u, d)) / z;
    float A = (far + near) / (near - far), B = 2.0 * far * near / (near - far);
    float depth = ((A * -z + B) / z) * 0.5 + 0.5;
    vec2 tile = vec2(1.0 / 6.0, 1.0 / float(point_shadow_rows));
    vec2 texel = 1.0 / vec2(textureSize(point_shadow, 0));
    vec2 lo = vec2(face, slot) * tile + texel * 0.5, hi = vec2(face + 1, slot + 1) * tile - texel * 0.5;
    vec2 uv = (vec2(face, slot) + (ndc * 0.5 + 0.5)) * tile;
    return pcf(point_shadow, vec3(uv, depth - 0.0002), lo, hi);
}

// the split sum's first factor: the environment averaged over the GGX lobe of this roughness
// about the reflection direction r, between the two nearest prefiltered layers
vec3 prefiltered(vec3 r, float roughness) {
    vec2 uv = vec2(atan(r.x, -r.z) * 0.15915494309189535, acos(clamp(r.y, -1.0, 1.0)) * 0.3183098861837907);
    float x = clamp(roughness, 0.0, 1.0) * float(SPECULAR_LEVELS - 1);
    float k = min(floor(x), float(SPECULAR_LEVELS - 2));
    return mix(texture(specular_maps, vec3(uv, k)).rgb, texture(specular_maps, vec3(uv, k + 1.0)).rgb, x - k);
}

void main() {
    MaterialSample m = fetch_material(triangle_material(gl_PrimitiveID), v_uv);
#ifdef HAS_VERTEX_COLORS
    m.albedo *= v_color;
#endif
    if (m.cutoff >= 0.0 && m.alpha < m.cutoff) discard;  // alpha MASK, as in the G-buffer
    if (m.single_sided && !gl_FrontFacing) discard;  // a single-sided surface seen from behind
    vec3 v = normalize(eye - v_position);
    vec3 ng = normalize(cross(dFdx(v_position), dFdy(v_position)));
    if (dot(ng, v) < 0.0) ng = -ng;
    vec3 n = mapped_normal(m, normalize(v_normal), v_tangent);
    if (dot(n, ng) < 0.0) n = -n;
    vec3 brdf = m.albedo / PI;
    vec3 f0 = mix(vec3(0.04), m.albedo, m.metallic);
    vec3 c_diff = m.albedo * (1.0 - m.metallic);
    float alpha = ggx_alpha(m.roughness);
    vec3 direct = vec3(0.0);
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    for (int i = 0; i < (use_rt_direct == 1 ? 0 : light_count); ++i) {
        Light L = lights[i];
        int kind = int(L.position_kind.w);
        int slot = int(L.direction_slot.w);
        vec3 l;
        vec3 e;  // irradiance on a surface facing the light
        if (kind == 2) {
            l = -L.direction_slot.xyz;
            e = L.radiance_lobe.rgb;
        } else {
            vec3 d = L.position_kind.xyz - v_position;
            float dist2 = max(dot(d, d), 1e-8);
            l = d * inversesqrt(dist2);
            float k = 1.0;
            if (kind == 1) {
                float t = clamp((dot(-l, L.direction_slot.xyz) - L.cone.x) / max(L.cone.y - L.cone.x, 1e-3), 0.0, 1.0);
                k = t * t;
            } else if (kind == 3) {
                float c = max(dot(-l, L.direction_slot.xyz), 0.0);
                k = mix(1.0, c, L.radiance_lobe.w);
            }
            e = L.radiance_lobe.rgb * k / dist2;
        }
        float cos_theta = dot(n, l);
        if (cos_theta <= 0.0 || dot(ng, l) <= 0.0) continue;
        float vis = 1.0;
        if (use_shadows == 1) {
            if (kind == 2 && i == sun_slot) vis = sun_visibility(v_position, ng, l);
            else if (slot >= 0) vis = point_visibility(slot, L.position_kind.xyz, v_position, ng, L.cone.z, L.cone.w);
        }
        direct += (use_ggx == 1 ? ggx_brdf(c_diff, f0, alpha, n, v, l) : brdf) * e * cos_theta * vis;
    }
    if (use_rt_direct == 1) direct = (use_ggx == 1 ? vec3(1.0) : brdf) * texelFetch(rt_direct, pixel, 0).rgb;
    vec3 amb = (use_irradiance_cube == 1 ? texture(irradiance_cube, n).rgb
                                         : texture(ambient_lut, vec2(n.y * 0.5 + 0.5, 0.5)).rgb) + ambient_radiance;
    float occlusion = use_ssao == 1 ? texture(ssao, gl_FragCoord.xy / viewport).r : 1.0;
    if (use_rt_ao == 1) occlusion = texelFetch(rt_ao, pixel, 0).r;
    vec3 incoming = amb * ambient_scale * occlusion * m.occlusion;  // glTF occlusion: ambient only
    if (use_rt_indirect == 1) incoming = texelFetch(rt_indirect, pixel, 0).rgb;
    vec3 fresnel = schlick(f0, dot(n, v));
    if (use_ggx == 1) {
        // diffuse ambient, and the specular lobe's: a surface smoother than the threshold
        // reflects the environment (or the traced reflection), a rougher one the ambient, with
        // Fresnel's roughness-damped average at this angle
        vec3 f_avg = f0 + (max(vec3(1.0 - m.roughness), f0) - f0) * pow(1.0 - max(dot(n, v), 0.0), 5.0);
        vec3 color = direct + c_diff * (1.0 - f_avg) * incoming;
        vec4 rt = use_rt_reflection == 1 ? texelFetch(rt_reflection, pixel, 0) : vec4(0.0);
        if (rt.a > 0.0)
            color += fresnel * rt.rgb;
        else if (use_env_reflections == 1 && m.roughness < roughness_threshold)
            color += fresnel * texture(env_cube, reflect(-v, n)).rgb;
        else if (use_split_sum == 1) {  // the split sum, shadowed as the diffuse ambient is (SSAO, glTF occlusion)
            vec2 ab = texture(brdf_lut, vec2(max(dot(n, v), 0.0), m.roughness)).rg;
            color += prefiltered(reflect(-v, n), m.roughness) * (f0 * ab.x + ab.y) * ambient_scale * occlusion
                     * m.occlusion;
        } else
            color += f_avg * incoming;
        radiance = vec4(m.emissive + color, 1.0);
        return;
    }
    vec3 color = direct + m.albedo * incoming;
    // Schlick's Fresnel blends the reflection with the (non-emitted) local colour
    if (use_rt_reflection == 1) {
        vec4 rt = texelFetch(rt_reflection, pixel, 0);
        if (rt.a > 0.0) color = (1.0 - fresnel) * color + fresnel * rt.rgb;
    } else if (use_env_reflections == 1 && m.roughness < roughness_threshold) {
        color = (1.0 - fresnel) * color + fresnel * texture(env_cube, reflect(-v, n)).rgb;
    }
    radiance = vec4(m.emissive + color, 1.0);
}
