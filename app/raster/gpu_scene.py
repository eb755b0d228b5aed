"""The scene's GPU copy: vertex buffers, per-triangle material ids, the material table,
every texture layer as one array, the environment cube map and the light list."""
from __future__ import annotations

import os

import numpy as np

from app.gl_context import program, software_gl
from scenes.model import Environment, Scene

MAT_TEXELS = 4
TRI_TEX_WIDTH = 4096
MAX_LIGHTS = 128
KIND = {"point": 0, "spot": 1, "directional": 2, "proxy": 3}
ENV_KIND = {"black": 0, "sky": 1, "constant": 2, "studio": 3, "map": 4}
IRRADIANCE_SIZE = 16  # texels of a face of a map's irradiance cube (irradiance_cube)

# GL cube map face directions for texel coordinates sc, tc in [-1, 1]
CUBE_FACES = (
    lambda s, t: (np.ones_like(s), -t, -s),
    lambda s, t: (-np.ones_like(s), -t, s),
    lambda s, t: (s, np.ones_like(s), t),
    lambda s, t: (s, -np.ones_like(s), -t),
    lambda s, t: (s, -t, np.ones_like(s)),
    lambda s, t: (-s, -t, -np.ones_like(s)),
)


def emissive_proxy_lights(scene: Scene) -> list[dict]:
    """Each emissive cluster as one point light, the way engines approximate area emitters.
    Each proxy: position, normal, intensity I0 (W/sr) and flatness.

    A flat emitter of area A and radiance Le has I(w) = Le A cos; a closed one (a bulb) has
    I = Le A / 4 in every direction; flatness = |sum A n| / sum A blends the two.
    """
    out = []
    for tris in scene.emissive_clusters():
        p = scene.positions[scene.indices[tris]].astype(np.float64)
        cross = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        area = 0.5 * np.linalg.norm(cross, axis=1)
        total = area.sum()
        if total <= 0:
            continue
        normal = cross / np.maximum(2 * area, 1e-20)[:, None]
        le = scene.triangle_emission()[tris].astype(np.float64)
        pos = (p.mean(axis=1) * area[:, None]).sum(0) / total
        nsum = (normal * area[:, None]).sum(0)
        flat = float(np.linalg.norm(nsum) / total)
        power = (le * area[:, None]).sum(0)  # sum Le A per channel
        out.append({"position": pos, "normal": nsum / max(np.linalg.norm(nsum), 1e-20),
                    "intensity": power * (flat + (1 - flat) / 4), "flatness": flat})
    return out


def ambient_lut(env: Environment, size: int = 64) -> np.ndarray:
    """Irradiance / pi of the environment on a surface with normal.y = -1..1 (no occlusion)."""
    rng = np.random.default_rng(0)
    u1, u2 = rng.random(4096), rng.random(4096)
    r, phi = np.sqrt(u1), 2 * np.pi * u2
    local = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1 - u1)], 1)  # cosine-weighted about +z
    out = np.zeros((size, 3), np.float32)
    for k, ny in enumerate(np.linspace(-1, 1, size)):
        n = np.array([np.sqrt(max(0.0, 1 - ny * ny)), ny, 0.0])
        t = np.cross(n, [0.0, 0.0, 1.0])
        t /= np.linalg.norm(t)
        b = np.cross(n, t)
        dirs = local[:, :1] * t + local[:, 1:2] * b + local[:, 2:3] * n
        out[k] = env.radiance(dirs.astype(np.float32)).mean(0)  # E/pi = mean radiance (cosine-weighted)
    return out


def cube_directions(size: int) -> np.ndarray:
    """Unit directions (6 * size * size, 3) of a GL cube map's texel centres, face by face."""
    t = (np.arange(size) + 0.5) / size * 2 - 1
    s, tc = np.meshgrid(t, t)
    d = np.concatenate([np.stack(face(s, tc), -1).reshape(-1, 3) for face in CUBE_FACES])
    return (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32)


def irradiance_cube(env: Environment, size: int = IRRADIANCE_SIZE, rows: int = 64) -> np.ndarray:
    """Irradiance / pi of an environment towards the normals of a cube map's texels (no
    occlusion): the cosine-weighted integral over a (rows x 2 rows) grid of directions, each
    weighted by its solid angle; a map averaged over each cell of the grid (split_sum's
    radiance_grid: a small sun in a large map is not missed), the others at its centres."""
    from app.raster.split_sum import radiance_grid

    dirs, radiance, omega = radiance_grid(env, rows)
    normals = cube_directions(size).astype(np.float64)
    return (np.maximum(normals @ dirs.T, 0.0) @ (radiance * omega[:, None]) / np.pi).astype(np.float32)


class GpuScene:
    def __init__(self, ctx, scene: Scene):
        self.ctx = ctx
        self.scene = scene
        self.vbo_pos = ctx.buffer(scene.positions.astype("f4").tobytes())
        self.vbo_nrm = ctx.buffer(scene.normals.astype("f4").tobytes())
        self.vbo_uv = ctx.buffer(scene.uvs.astype("f4").tobytes())
        self.vbo_tan = ctx.buffer(scene.tangents.astype("f4").tobytes()) if scene.tangents is not None else None
        self.vbo_col = ctx.buffer(scene.colors.astype("f4").tobytes()) if scene.colors is not None else None
        self.ibo = ctx.buffer(scene.indices.astype("i4").tobytes())
        t = scene.triangle_count
        rows = (t + TRI_TEX_WIDTH - 1) // TRI_TEX_WIDTH
        ids = np.zeros(rows * TRI_TEX_WIDTH, np.int32)
        ids[:t] = scene.material_ids
        self.tri_materials = ctx.texture((TRI_TEX_WIDTH, rows), 1, ids.tobytes(), dtype="i4")
        self.tri_materials.filter = (ctx.NEAREST, ctx.NEAREST)
        self._upload_materials()
        self._vaos: dict = {}
        self.env_key = None
        self.env_cube = None
        self.ambient_lut = None
        self.env_map = self.env_irradiance = None  # a map's texels and irradiance (environment_map)
        self.env_pixels = None  # the map they were made from
        self.env_specular = self.brdf_lut = None  # split-sum image-based specular (specular_light)
        self.proxies = emissive_proxy_lights(scene)

    def _upload_materials(self) -> None:
        """The material table (MAT_TEXELS RGBA32F texels a material: base colour; emission and
        base layer; roughness, metallic, double-sided, wrap; ORM, normal and emission layers and
        the alpha cutoff) and every texture layer (Material.layers) as one RGBA16F array."""
        ctx, mats = self.ctx, self.scene.materials
        layers_in = [tex for m in mats for tex in m.layers() if tex is not None]
        size = max([1] + [max(t.shape[0], t.shape[1]) for t in layers_in])
        size = int(min(1024, 2 ** int(np.ceil(np.log2(size))))) if layers_in else 1
        layers = np.zeros((max(len(layers_in), 1), size, size, 4), np.float16)
        table = np.zeros((len(mats) * MAT_TEXELS, 4), np.float32)

        def pack(count: int) -> None:  # layer `count`, resampled to size x size (nearest), alpha 1 where it has none
            tex = layers_in[count]
            h, w, c = tex.shape
            yi = (np.arange(size) * h // size)[:, None]
            xi = (np.arange(size) * w // size)[None, :]
            if c < 4:
                layers[count, :, :, 3] = 1.0
            layers[count, :, :, :min(c, 4)] = tex[yi, xi, :4]

        if len(layers_in) > 8:  # hundreds of textures (big scenes): on threads, numpy's gathers leave the GIL
            from concurrent.futures import ThreadPoolExecutor

            with ThreadPoolExecutor(min(len(layers_in), os.cpu_count() or 1)) as pool:
                list(pool.map(pack, range(len(layers_in))))
        else:
            for count in range(len(layers_in)):
                pack(count)
        count = 0
        for k, m in enumerate(mats):
            index = []
            for tex in m.layers():
                if tex is None:
                    index.append(-1.0)
                    continue
                index.append(float(count))
                count += 1
            table[k * MAT_TEXELS + 0] = m.base_color[:4] if len(m.base_color) >= 4 else (*m.base_color, 1.0)
            table[k * MAT_TEXELS + 1] = (*m.emissive, index[0])
            table[k * MAT_TEXELS + 2] = (m.roughness, m.metallic, float(m.double_sided),
                                         m.wrap[0] + 3 * m.wrap[1] + 9 * int(m.nearest))
            table[k * MAT_TEXELS + 3] = (index[1], index[2], index[3], m.alpha_cutoff if m.alpha_tested else -1.0)
        self.alpha_tested = any(m.alpha_tested for m in mats)
        # the material features this scene uses: shaders compile only those (common.glsl); a
        # scene without them gets the small shaders (llvmpipe's memory grows with shader size)
        used = [any(m.layers()[k] is not None for m in mats) for k in range(4)]
        names = ("HAS_BASE_TEXTURES", "HAS_ORM_TEXTURES", "HAS_NORMAL_MAPS", "HAS_EMISSION_TEXTURES")
        self.defines = tuple(name for name, k in zip(names, used, strict=True) if k)
        self.defines += ("HAS_ALPHA_MASKS",) if self.alpha_tested else ()
        self.defines += ("HAS_SINGLE_SIDED",) if any(not m.double_sided for m in mats) else ()
        self.defines += ("HAS_VERTEX_COLORS",) if self.scene.colors is not None else ()
        self.material_table = ctx.texture((table.shape[0], 1), 4, table.tobytes(), dtype="f4")
        self.material_table.filter = (ctx.NEAREST, ctx.NEAREST)
        self.textures = ctx.texture_array((size, size, layers.shape[0]), 4, layers, dtype="f2")  # no copy: its buffer
        self.textures.build_mipmaps()
        self.textures.filter = (ctx.LINEAR_MIPMAP_LINEAR, ctx.LINEAR)
        # anisotropic filtering on hardware GL only: llvmpipe's is pathologically slow where the
        # coarsest mips get sampled (the temple at 1280x720: 23 s a frame with it, 0.2 s without)
        self.textures.anisotropy = 1.0 if software_gl(ctx) else 8.0

    def bind_materials(self, prog, first_unit: int = 0) -> int:
        """Bind the material tables to units first_unit.. and return the next free unit."""
        for k, (name, tex) in enumerate((("material_table", self.material_table),
                                         ("triangle_materials", self.tri_materials),
                                         ("base_textures", self.textures))):
            tex.use(first_unit + k)
            if name in prog:
                prog[name].value = first_unit + k
        return first_unit + 3

    def vao(self, vertex: str, fragment: str | None, with_attributes: bool = True):
        key = (vertex, fragment)
        if key not in self._vaos:
            prog = program(self.ctx, vertex, fragment, self.defines)
            content = [(self.vbo_pos, "3f", "in_position")]
            if with_attributes:
                if "in_normal" in prog:
                    content.append((self.vbo_nrm, "3f", "in_normal"))
                if "in_uv" in prog:
                    content.append((self.vbo_uv, "2f", "in_uv"))
                if "in_tangent" in prog and self.vbo_tan is not None:  # else GL's default (0, 0, 0, 1)
                    content.append((self.vbo_tan, "4f", "in_tangent"))
                if "in_color" in prog and self.vbo_col is not None:  # only compiled in with HAS_VERTEX_COLORS
                    content.append((self.vbo_col, "3f", "in_color"))
            self._vaos[key] = (prog, self.ctx.vertex_array(prog, content, index_buffer=self.ibo, index_element_size=4))
        return self._vaos[key]

    def environment_maps(self, env: Environment, size: int = 64):
        """Cube map and ambient LUT of the environment, rebuilt only when it changes; for a map,
        also its texels and irradiance cube (environment_map)."""
        key = (env.kind, tuple(env.color), env.strength, env.rotation)
        if key != self.env_key or env.pixels is not self.env_pixels:  # the array itself: an id can be reused
            data = env.radiance(cube_directions(size)).astype("f4")
            for obj in (self.env_cube, self.ambient_lut, self.env_map, self.env_irradiance, self.env_specular):
                if obj is not None:
                    obj.release()
            self.env_map = self.env_irradiance = self.env_specular = None
            self.env_cube = self.ctx.texture_cube((size, size), 3, data.tobytes(), dtype="f4")
            self.env_cube.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
            lut = ambient_lut(env)
            self.ambient_lut = self.ctx.texture((lut.shape[0], 1), 3, lut.tobytes(), dtype="f4")
            self.ambient_lut.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
            self.ambient_lut.repeat_x = False
            if env.kind == "map":
                irr = irradiance_cube(env, IRRADIANCE_SIZE)
                self.env_irradiance = self.ctx.texture_cube((IRRADIANCE_SIZE,) * 2, 3, irr.tobytes(), dtype="f4")
                self.env_irradiance.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
                self.env_map = self.ctx.texture(env.pixels.shape[1::-1], 3, env.pixels.tobytes(), dtype="f4")
                self.env_map.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
                self.env_map.repeat_y = False
            self.env_key, self.env_pixels = key, env.pixels
        return self.env_cube, self.ambient_lut

    def environment_map(self, env: Environment) -> tuple:
        """A map's texels as a texture and its irradiance / pi as a small cube map
        (irradiance_cube: it varies with azimuth, which ambient_lut leaves out), or Nones for
        the other kinds (environment_maps makes them)."""
        self.environment_maps(env)
        return self.env_map, self.env_irradiance

    def specular_light(self, env: Environment) -> tuple:
        """The split-sum textures (app/raster/split_sum.py): the environment prefiltered per
        roughness (a texture array, one equirectangular layer a roughness) and the BRDF's lookup
        table; Nones under a black environment. Made once per environment (environment_maps)."""
        from app.raster import split_sum

        self.environment_maps(env)
        if env.kind == "black":
            return None, None
        if self.env_specular is None:
            layers = split_sum.specular_maps(env)
            self.env_specular = self.ctx.texture_array((*split_sum.SPECULAR_SIZE, split_sum.SPECULAR_LEVELS), 3,
                                                       layers.tobytes(), dtype="f4")
            self.env_specular.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
            self.env_specular.repeat_y = False
        if self.brdf_lut is None:
            lut = split_sum.brdf_lut()
            self.brdf_lut = self.ctx.texture(lut.shape[1::-1], 2, lut.tobytes(), dtype="f4")
            self.brdf_lut.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
            self.brdf_lut.repeat_x = self.brdf_lut.repeat_y = False
        return self.env_specular, self.brdf_lut

    def release(self) -> None:
        for obj in (self.vbo_pos, self.vbo_nrm, self.vbo_uv, self.vbo_tan, self.vbo_col, self.ibo, self.tri_materials,
                    self.material_table, self.textures, self.env_cube, self.ambient_lut, self.env_map,
                    self.env_irradiance, self.env_specular, self.brdf_lut):
            if obj is not None:
                obj.release()
        for _, vao in self._vaos.values():
            vao.release()
