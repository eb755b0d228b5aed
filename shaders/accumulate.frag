#version 430
// Temporal accumulation: running mean. weight = 1/(n+1); weight 1 restarts the mean.
in vec2 uv;
uniform sampler2D current;
uniform sampler2D history;
uniform float weight;
out vec4 mean;
void main() {
    vec4 c = texture(current, uv);
    mean = weight >= 1.0 ? c : mix(texture(history, uv), c, weight);
}
