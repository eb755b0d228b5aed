// Shared by the raster shaders: material table lookups and the sky model.
// The sky must match scenes/model.py sky_radiance().
const float PI = 3.14159265358979;
const int MAT_TEXELS = 3;

uniform sampler2D material_table;     // RGBA32F, MAT_TEXELS texels per material
uniform isampler2D triangle_materials; // R32I, one texel per triangle, 4096 wide
uniform sampler2DArray base_textures;  // one layer per textured material

int triangle_material(int prim) {
    return texelFetch(triangle_materials, ivec2(prim % 4096, prim / 4096), 0).r;
}

struct MaterialSample {
    vec3 albedo; float roughness; float metallic; vec3 emissive; int id;
};

MaterialSample fetch_material(int id, vec2 uv) {
    vec4 t0 = texelFetch(material_table, ivec2(id * MAT_TEXELS + 0, 0), 0);
    vec4 t1 = texelFetch(material_table, ivec2(id * MAT_TEXELS + 1, 0), 0);
    vec4 t2 = texelFetch(material_table, ivec2(id * MAT_TEXELS + 2, 0), 0);
    MaterialSample m;
    m.albedo = t0.rgb;
    if (t1.w >= 0.0) m.albedo *= texture(base_textures, vec3(uv, t1.w)).rgb;
    m.emissive = t1.rgb;
    m.roughness = t2.x;
    m.metallic = t2.y;
    m.id = id;
    return m;
}

const vec3 SKY_HORIZON = vec3(0.9, 0.95, 1.0);
const vec3 SKY_ZENITH = vec3(0.25, 0.45, 0.9);
const vec3 SKY_GROUND = vec3(0.25, 0.23, 0.2);

// env_kind: 0 black, 1 sky, 2 constant
vec3 env_radiance(int env_kind, vec3 env_color, float env_strength, vec3 dir) {
    if (env_kind == 0) return vec3(0.0);
    if (env_kind == 2) return env_color;
    float y = clamp(dir.y, -1.0, 1.0);
    float up = sqrt(max(y, 0.0));
    float down = sqrt(max(-y, 0.0));
    vec3 sky = SKY_HORIZON * (1.0 - up) + SKY_ZENITH * up;
    vec3 ground = SKY_HORIZON * (1.0 - down) * 0.5 + SKY_GROUND * down;
    return (y >= 0.0 ? sky : ground) * env_strength;
}
