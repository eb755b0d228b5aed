// Shared by the SVGF passes (app/raster/svgf.py): luminance, the G-buffer a pixel covers, and
// the demodulation by albedo (lighting is filtered without the texture, then multiplied back).
#include "reproject_common.glsl"
float luma(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }
// what the effect's radiance holds of the first hit (rt/pass_base.py: radiance_terms): its albedo
// as a factor (else the lighting is the radiance itself: greyscale AO), its emission
uniform int has_albedo;
uniform int has_emission;
vec3 demod_albedo(vec3 albedo) { return has_albedo != 0 ? max(albedo, vec3(0.01)) : vec3(1.0); }
bool covered(sampler2D g_face, ivec2 p) { return texelFetch(g_face, p, 0).w > 0.0; }
// the first hit's own emission in a pixel's radiance: left out of the filter and added back
// after it, so that light sources stay as sharp and as bright as they are (no more than the
// radiance, where a jittered or traced primary hit saw less of the emitter than the G-buffer)
vec3 emission(sampler2D g_emissive, vec3 rad, ivec2 p) { return has_emission == 0 ? vec3(0.0) : clamp(texelFetch(g_emissive, p, 0).rgb, vec3(0.0), max(rad, vec3(0.0))); }
