// Shared by the SVGF passes (app/raster/svgf.py): luminance, the G-buffer a pixel covers, and
// the demodulation by albedo (lighting is filtered without the texture, then multiplied back).
#include "reproject_common.glsl"
float luma(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }
// what the effect's radiance holds of the first hit (rt/pass_base.py: radiance_terms): its albedo
// as a factor (else the lighting is the radiance itself: greyscale AO), its emission
uniform int has_albedo;
uniform int has_emission;
vec3 demod_albedo(vec3 albedo) { return has_albedo != 0 ? max(albedo, vec3(0.01)) : vec3(1.0); }
// With glTF's BRDF the radiance's specular part comes apart (rt_specular; rt/pass_base.py
// SPECULAR) and the passes run twice, each on one part over its own albedo (`signal` 0: the
// diffuse, over base x (1 - metallic); 1: the specular, over the specular albedo), so that
// highlights and reflections are not divided by the texture nor blurred with the diffuse light.
uniform int split;
uniform int signal;
uniform vec3 eye;
// the GGX lobe's directional albedo F0 A + B (Karis's fit of the split sum's scale and bias),
// at n.v = nv, perceptual roughness r; shaders/rt/svgf.slang and rt/oidn.py have the same
vec3 specular_albedo(vec3 base, float metallic, float r, float nv) {
    vec4 k = r * vec4(-1.0, -0.0275, -0.572, 0.022) + vec4(1.0, 0.0425, 1.04, -0.04);
    float a004 = min(k.x * k.x, exp2(-9.28 * nv)) * k.x + k.y;
    vec2 ab = vec2(-1.04, 1.04) * a004 + k.zw;
    return mix(vec3(0.04), base, metallic) * ab.x + ab.y;
}
// what this run's lighting is divided by at a pixel (g_albedo: base, metallic; g_normal: n,
// roughness; position: the point)
vec3 demod_factor(vec4 albedo, vec4 normal, vec3 position) {
    if (split == 0)
        return demod_albedo(albedo.rgb);
    if (signal == 0)
        return max(albedo.rgb * (1.0 - albedo.a), vec3(0.01));
    float nv = clamp(dot(normal.xyz, normalize(eye - position)), 0.0, 1.0);
    return max(specular_albedo(albedo.rgb, albedo.a, normal.w, nv), vec3(0.01));
}
// this run's part of the radiance, less the emission em; spec: the specular part (rt_specular)
vec3 signal_part(vec3 rad, vec3 em, vec3 spec) {
    if (split == 0)
        return rad - em;
    return signal == 0 ? rad - em - spec : spec;
}
bool covered(sampler2D g_face, ivec2 p) { return texelFetch(g_face, p, 0).w > 0.0; }
// the first hit's own emission in a pixel's radiance: left out of the filter and added back
// after it, so that light sources stay as sharp and as bright as they are (no more than the
// radiance, where a jittered or traced primary hit saw less of the emitter than the G-buffer)
vec3 emission(sampler2D g_emissive, vec3 rad, ivec2 p) { return has_emission == 0 ? vec3(0.0) : clamp(texelFetch(g_emissive, p, 0).rgb, vec3(0.0), max(rad, vec3(0.0))); }
