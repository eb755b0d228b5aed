#version 430
// FXAA (after Lottes' FXAA 3.11 quality preset, condensed): blends along detected edges.
in vec2 uv;
uniform sampler2D ldr;  // rgb + luma in alpha
out vec4 color;
const float EDGE_MIN = 1.0 / 24.0;
const float EDGE_REL = 1.0 / 8.0;
const float SUBPIX = 0.75;
float luma(vec2 p) { return texture(ldr, p).a; }
void main() {
    vec2 px = 1.0 / vec2(textureSize(ldr, 0));
    vec4 center = texture(ldr, uv);
    float m = center.a;
    float n = luma(uv + vec2(0, px.y)), s = luma(uv - vec2(0, px.y));
    float e = luma(uv + vec2(px.x, 0)), w = luma(uv - vec2(px.x, 0));
    float hi = max(max(max(n, s), max(e, w)), m), lo = min(min(min(n, s), min(e, w)), m);
    float range = hi - lo;
    if (range < max(EDGE_MIN, hi * EDGE_REL)) { color = vec4(center.rgb, 1.0); return; }
    float ne = luma(uv + px), nw = luma(uv + vec2(-px.x, px.y));
    float se = luma(uv + vec2(px.x, -px.y)), sw = luma(uv - px);
    float avg = (2.0 * (n + s + e + w) + ne + nw + se + sw) / 12.0;
    float sub = clamp(abs(avg - m) / range, 0.0, 1.0);
    sub = smoothstep(0.0, 1.0, sub);
    sub = sub * sub * SUBPIX;
    float horiz = abs(nw + sw - 2.0 * w) + 2.0 * abs(n + s - 2.0 * m) + abs(ne + se - 2.0 * e);
    float vert = abs(nw + ne - 2.0 * n) + 2.0 * abs(w + e - 2.0 * m) + abs(sw + se - 2.0 * s);
    bool is_h = horiz >= vert;
    float l1 = is_h ? s : w, l2 = is_h ? n : e;
    float g1 = abs(l1 - m), g2 = abs(l2 - m);
    float step_len = is_h ? px.y : px.x;
    float local_avg;
    if (g1 >= g2) { step_len = -step_len; local_avg = 0.5 * (l1 + m); } else { local_avg = 0.5 * (l2 + m); }
    float grad = 0.25 * max(g1, g2);
    vec2 cur = uv;
    if (is_h) cur.y += step_len * 0.5; else cur.x += step_len * 0.5;
    vec2 dir = is_h ? vec2(px.x, 0) : vec2(0, px.y);
    vec2 p1 = cur - dir, p2 = cur + dir;
    float e1 = luma(p1) - local_avg, e2 = luma(p2) - local_avg;
    bool d1 = abs(e1) >= grad, d2 = abs(e2) >= grad;
    const float QUALITY[10] = float[](1.0, 1.0, 1.0, 1.0, 1.5, 2.0, 2.0, 2.0, 4.0, 8.0);
    for (int i = 0; i < 10 && !(d1 && d2); ++i) {
        if (!d1) { p1 -= dir * QUALITY[i]; e1 = luma(p1) - local_avg; d1 = abs(e1) >= grad; }
        if (!d2) { p2 += dir * QUALITY[i]; e2 = luma(p2) - local_avg; d2 = abs(e2) >= grad; }
    }
    float dist1 = is_h ? uv.x - p1.x : uv.y - p1.y;
    float dist2 = is_h ? p2.x - uv.x : p2.y - uv.y;
    bool closer1 = dist1 < dist2;
    float dmin = min(dist1, dist2);
    float span = dist1 + dist2;
    bool center_smaller = m < local_avg;
    bool correct = ((closer1 ? e1 : e2) < 0.0) != center_smaller;
    float edge_off = correct ? -dmin / span + 0.5 : 0.0;
    float off = max(edge_off, sub);
    vec2 fuv = uv;
    if (is_h) fuv.y += off * step_len; else fuv.x += off * step_len;
    color = vec4(texture(ldr, fuv).rgb, 1.0);
}
