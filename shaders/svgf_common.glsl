// Shared by the SVGF passes (app/raster/svgf.py): luminance, the G-buffer a pixel covers, and
// the demodulation by albedo (lighting is filtered without the texture, then multiplied back).
#include "reproject_common.glsl"
float luma(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }
vec3 demod_albedo(vec3 albedo) { return max(albedo, vec3(0.01)); }
bool covered(sampler2D g_face, ivec2 p) { return texelFetch(g_face, p, 0).w > 0.0; }
