// Shared by the raster shaders: material table lookups and the sky model.
// The sky must match scenes/model.py sky_radiance().
const float PI = 3.14159265358979;
const int MAT_TEXELS = 4;

uniform sampler2D material_table;     // RGBA32F, MAT_TEXELS texels per material (app/raster/gpu_scene.py)
uniform isampler2D triangle_materials; // R32I, one texel per triangle, 4096 wide
uniform sampler2DArray base_textures;  // every texture layer of every material (Material.layers)

int triangle_material(int prim) {
    return texelFetch(triangle_materials, ivec2(prim % 4096, prim / 4096), 0).r;
}

struct MaterialSample {
    vec3 albedo; float roughness; float metallic; vec3 emissive; int id;
    float alpha; float cutoff;     // cutoff < 0: never cut away
    bool single_sided;             // glTF doubleSided false: its back faces are not seen (HAS_SINGLE_SIDED)
    float occlusion;               // the occlusion texture (raster ambient only)
    float normal_layer; vec2 uv; int wrap;
};

// glTF's wrap modes (scenes.model.WRAP_*: 0 repeat, 1 clamp, 2 mirror) applied to uvs; the
// array's sampler repeats. (Plain texture(), not textureGrad: llvmpipe's code for explicit
// gradients costs memory per shader variant; a mirrored seam may pick a coarser mip.)
vec2 wrap_uv(vec2 uv, int wrap) {
    ivec2 mode = ivec2(wrap % 3, (wrap / 3) % 3);
    vec2 size = vec2(textureSize(base_textures, 0).xy);
    vec2 out_uv = uv;
    for (int a = 0; a < 2; ++a) {
        if (mode[a] == 1) out_uv[a] = clamp(uv[a], 0.5 / size[a], 1.0 - 0.5 / size[a]);
        if (mode[a] == 2) out_uv[a] = 1.0 - abs(mod(uv[a], 2.0) - 1.0);
    }
    return out_uv;
}

// wrap >= 9: Material.nearest, the texel the point falls in (no filtering, no mip maps)
vec4 layer_sample(float layer, vec2 uv, int wrap) {
    if (wrap >= 9) {
        ivec2 size = textureSize(base_textures, 0).xy;
        ivec2 mode = ivec2(wrap % 3, (wrap / 3) % 3);
        ivec2 t = ivec2(floor(clamp(uv, -1e6, 1e6) * vec2(size)));
        for (int a = 0; a < 2; ++a) {
            int n = size[a];
            if (mode[a] == 1) t[a] = clamp(t[a], 0, n - 1);
            else if (mode[a] == 2) { int i = ((t[a] % (2 * n)) + 2 * n) % (2 * n); t[a] = i < n ? i : 2 * n - 1 - i; }
            else t[a] = ((t[a] % n) + n) % n;
        }
        return texelFetch(base_textures, ivec3(t, int(layer + 0.5)), 0);
    }
    return texture(base_textures, vec3(wrap == 0 ? uv : wrap_uv(uv, wrap), layer));
}

// The scene's material features are #defined by app/raster/gpu_scene.py (HAS_BASE_TEXTURES,
// HAS_ORM_TEXTURES, HAS_NORMAL_MAPS, HAS_EMISSION_TEXTURES, HAS_ALPHA_MASKS): code for the others
// is left out.
MaterialSample fetch_material(int id, vec2 uv) {
    vec4 t0 = texelFetch(material_table, ivec2(id * MAT_TEXELS + 0, 0), 0);
    vec4 t1 = texelFetch(material_table, ivec2(id * MAT_TEXELS + 1, 0), 0);
    vec4 t2 = texelFetch(material_table, ivec2(id * MAT_TEXELS + 2, 0), 0);
    vec4 t3 = texelFetch(material_table, ivec2(id * MAT_TEXELS + 3, 0), 0);
    MaterialSample m;
    m.wrap = int(t2.w + 0.5);
    m.uv = uv;
    m.albedo = t0.rgb;
    m.alpha = t0.a;
#ifdef HAS_BASE_TEXTURES
    if (t1.w >= 0.0) {
        vec4 base = layer_sample(t1.w, uv, m.wrap);
        m.albedo *= base.rgb;
        m.alpha *= base.a;
    }
#endif
    m.emissive = t1.rgb;
#ifdef HAS_EMISSION_TEXTURES
    if (t3.z >= 0.0) m.emissive = layer_sample(t3.z, uv, m.wrap).rgb;
#endif
    m.roughness = t2.x;
    m.metallic = t2.y;
    m.occlusion = 1.0;
#ifdef HAS_ORM_TEXTURES
    if (t3.x >= 0.0) {
        vec3 orm = layer_sample(t3.x, uv, m.wrap).rgb;
        m.occlusion = orm.r;
        m.roughness = orm.g;
        m.metallic = orm.b;
    }
#endif
    m.normal_layer = t3.y;
    m.cutoff = -1.0;
#ifdef HAS_ALPHA_MASKS
    m.cutoff = t3.w;
#endif
    m.single_sided = false;
#ifdef HAS_SINGLE_SIDED
    m.single_sided = t2.z == 0.0;
#endif
    m.id = id;
    return m;
}

// The shading normal: the interpolated vertex normal n bent by the material's normal map in
// the frame of the vertex tangent (xyz, w: handedness), as glTF defines it.
vec3 mapped_normal(MaterialSample m, vec3 n, vec4 tangent) {
#ifdef HAS_NORMAL_MAPS
    if (m.normal_layer < 0.0 || dot(tangent.xyz, tangent.xyz) < 1e-12) return n;
    vec3 t = tangent.xyz - n * dot(n, tangent.xyz);
    if (dot(t, t) < 1e-12) return n;
    t = normalize(t);
    vec3 b = cross(n, t) * (tangent.w < 0.0 ? -1.0 : 1.0);
    vec3 mapped = layer_sample(m.normal_layer, m.uv, m.wrap).xyz;
    vec3 out_n = t * mapped.x + b * mapped.y + n * mapped.z;
    return dot(out_n, out_n) > 1e-12 ? normalize(out_n) : n;
#else
    return n;
#endif
}

// glTF's metal-rough BRDF (docs/ARCHITECTURE.md "Materials"; the same in rt/brdf.py and
// shaders/rt/brdf.slang): Lambert diffuse c_diff (1 - F) / pi plus GGX specular F D V, with
// alpha = roughness^2, Schlick's F and Smith's separable G folded into
// V = G1(v) G1(l) / (4 n.l n.v) = 1 / ((n.v + L(n.v)) (n.l + L(n.l))), L(c) = sqrt(a2 + (1 - a2) c^2)
const float GGX_MIN_ALPHA = 1e-3;

float ggx_alpha(float roughness) { return max(roughness * roughness, GGX_MIN_ALPHA); }

vec3 schlick(vec3 f0, float c) { float k = 1.0 - clamp(c, 0.0, 1.0); return f0 + (1.0 - f0) * (k * k * k * k * k); }

// f(v, l) for unit n, v, l with n.l > 0; c_diff = base (1 - metallic), f0 = mix(0.04, base, metallic)
vec3 ggx_brdf(vec3 c_diff, vec3 f0, float alpha, vec3 n, vec3 v, vec3 l) {
    vec3 h = normalize(v + l);
    float nv = max(dot(n, v), 1e-4), nl = max(dot(n, l), 1e-4), nh = max(dot(n, h), 0.0);
    float a2 = alpha * alpha;
    float k = nh * nh * (a2 - 1.0) + 1.0;
    float d = a2 / (PI * k * k);
    float vis = 1.0 / ((nv + sqrt(a2 + (1.0 - a2) * nv * nv)) * (nl + sqrt(a2 + (1.0 - a2) * nl * nl)));
    vec3 f = schlick(f0, dot(v, h));
    return c_diff * (1.0 - f) / PI + f * (d * vis);
}

const vec3 SKY_HORIZON = vec3(0.9, 0.95, 1.0);
const vec3 SKY_ZENITH = vec3(0.25, 0.45, 0.9);
const vec3 SKY_GROUND = vec3(0.25, 0.23, 0.2);
const vec3 STUDIO_HORIZON = vec3(0.5);
const vec3 STUDIO_ZENITH = vec3(1.0);
const vec3 STUDIO_GROUND = vec3(0.15);

// env_kind: 0 black, 1 sky, 2 constant, 3 studio (scenes/model.py: GRADIENTS); 4, a map, is read
// where its texture is bound (background.frag; forward.frag through its cube maps)
vec3 env_radiance(int env_kind, vec3 env_color, float env_strength, vec3 dir) {
    if (env_kind == 0) return vec3(0.0);
    if (env_kind == 2) return env_color;
    vec3 horizon = env_kind == 3 ? STUDIO_HORIZON : SKY_HORIZON;
    float y = clamp(dir.y, -1.0, 1.0);
    float up = sqrt(max(y, 0.0));
    float down = sqrt(max(-y, 0.0));
    vec3 sky = horizon * (1.0 - up) + (env_kind == 3 ? STUDIO_ZENITH : SKY_ZENITH) * up;
    vec3 ground = horizon * (1.0 - down) * 0.5 + (env_kind == 3 ? STUDIO_GROUND : SKY_GROUND) * down;
    return (y >= 0.0 ? sky : ground) * env_strength;
}
