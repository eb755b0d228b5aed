// Shared by the passes that carry history through camera motion (SVGF's temporal pass,
// app/raster/svgf.py; the reprojection, app/raster/reproject.py): where a pixel's point was in
// the previous frame, whether a texel there saw the same surface, and the bilinear weights of
// the four texels around that place.
bool inside(ivec2 p, ivec2 size) { return all(greaterThanEqual(p, ivec2(0))) && all(lessThan(p, size)); }

// the previous frame's position of this pixel's point, in texel-centre coordinates
vec2 previous_texel(vec2 frag_coord, vec2 motion) { return frag_coord - motion - 0.5; }

// a texel of the last frame (its position, w 0: nothing there; its normal) saw the surface at
// pos (w: linear depth) with normal n: its plane within 1 % of the depth, the point within 5 %,
// normals within ~25 degrees
bool same_surface(vec4 prev_pos, vec3 prev_n, vec4 pos, vec3 n) {
    vec3 d = prev_pos.xyz - pos.xyz;
    return prev_pos.w > 0.0 && abs(dot(d, n)) <= 0.01 * pos.w && length(d) <= 0.05 * pos.w && dot(prev_n, n) >= 0.9;
}

// the bilinear weight of tap k (offsets (k & 1, k >> 1) from the base texel) at fraction f
float tap_weight(int k, vec2 f) { return ((k & 1) == 1 ? f.x : 1.0 - f.x) * ((k >> 1) == 1 ? f.y : 1.0 - f.y); }
