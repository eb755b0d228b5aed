#version 430
#include "common.glsl"
// Shadow maps of scenes with masked materials: depth only where a surface is not cut away.
in vec2 v_uv;
void main() {
    MaterialSample m = fetch_material(triangle_material(gl_PrimitiveID), v_uv);
    if (m.cutoff >= 0.0 && m.alpha < m.cutoff) discard;
}
