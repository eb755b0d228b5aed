#version 430
// 4x4 box blur matching the 4x4 noise tile, so the rotation pattern averages out.
in vec2 uv;
uniform sampler2D ao_raw;
out float ao;
void main() {
    vec2 texel = 1.0 / vec2(textureSize(ao_raw, 0));
    float sum = 0.0;
    for (int x = -2; x < 2; ++x)
        for (int y = -2; y < 2; ++y)
            sum += texture(ao_raw, uv + (vec2(x, y) + 0.5) * texel).r;
    ao = sum / 16.0;
}
