"""The one in-memory scene form that both the rasteriser and the tracer consume.

Units follow DESIGN.md: right-handed, +Y up, metres; point/spot intensity in W/sr,
directional irradiance in W/m^2, emissive triangles emit radiance Le.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from core.errors import UserError

MAX_EXTENT = 1e9  # metres; a scene's diagonal


ALPHA_MODES = ("OPAQUE", "MASK", "BLEND")
WRAP_REPEAT, WRAP_CLAMP, WRAP_MIRROR = 0, 1, 2


@dataclass
class Material:
    """glTF's metallic-roughness material. The base colour texture is multiplied with
    base_color (alpha too); the other layers have their factors baked in at load (a texel is
    the final value) and, where present, replace the constant. Every layer is sampled with the
    same uvs and wrap mode."""

    name: str = "default"
    base_color: tuple = (0.8, 0.8, 0.8, 1.0)  # linear RGBA factor
    texture: np.ndarray | None = None  # base colour: H x W x 3 (or 4: alpha) linear, multiplied with base_color
    roughness: float = 0.5
    metallic: float = 0.0
    emissive: tuple = (0.0, 0.0, 0.0)  # radiance Le (factor x strength), W/(sr m^2)
    double_sided: bool = True
    orm: np.ndarray | None = None  # H x W x 3: occlusion (strength applied), roughness, metallic (factors applied)
    normal_map: np.ndarray | None = None  # H x W x 3: tangent-space normal, scale applied, unit length
    emissive_map: np.ndarray | None = None  # H x W x 3: radiance (factor x strength applied)
    alpha_mode: str = "OPAQUE"  # OPAQUE | MASK (alpha_cutoff) | BLEND (drawn as MASK at alpha_cutoff 0.5)
    alpha_cutoff: float = 0.5
    wrap: tuple = (WRAP_REPEAT, WRAP_REPEAT)  # u, v
    nearest: bool = False  # glTF magFilter NEAREST: every layer read at its nearest texel (else bilinear)

    @property
    def is_emissive(self) -> bool:
        if self.emissive_map is not None:
            return bool(self.emissive_map.max() > 0.0)
        return max(self.emissive) > 0.0

    @property
    def alpha_tested(self) -> bool:
        """True where some of the surface may be cut away: a MASK or BLEND material whose alpha
        (factor x texture) is not 1 everywhere."""
        if self.alpha_mode == "OPAQUE":
            return False
        tex = self.texture
        has_alpha = tex is not None and tex.shape[-1] == 4 and float(tex[..., 3].min()) < 1.0
        return has_alpha or self.base_color[3] < 1.0

    def layers(self) -> tuple:
        """The texture layers in the order every backend stores them: base colour (RGBA),
        occlusion-roughness-metallic, normal, emission; None where the constant applies."""
        return (self.texture, self.orm, self.normal_map, self.emissive_map)


@dataclass
class Light:
    kind: str  # "point" | "spot" | "directional"
    color: tuple = (1.0, 1.0, 1.0)
    intensity: float = 1.0  # W/sr (point, spot) or W/m^2 (directional)
    position: tuple = (0.0, 0.0, 0.0)
    direction: tuple = (0.0, -1.0, 0.0)  # direction the light travels (spot axis, sun rays)
    angular_radius: float = 0.0  # radians; sun disc size for soft shadows
    inner_cone: float = 0.0  # radians (spot)
    outer_cone: float = np.pi / 4  # radians (spot)
    name: str = ""

    @property
    def radiance_scale(self) -> np.ndarray:
        """Colour times intensity: radiant intensity (W/sr) or irradiance (W/m^2) per channel."""
        return np.asarray(self.color, np.float32) * np.float32(self.intensity)


@dataclass
class View:
    name: str
    eye: tuple
    target: tuple
    up: tuple = (0.0, 1.0, 0.0)
    fov: float = 60.0  # vertical, degrees

    def to_string(self) -> str:
        f = lambda v: ",".join(f"{x:.4g}" for x in v)  # noqa: E731
        return f"eye={f(self.eye)};target={f(self.target)};up={f(self.up)};fov={self.fov:.4g}"


ENV_KINDS = ("black", "sky", "studio", "constant", "map")


@dataclass
class Environment:
    """Radiance returned by rays that miss. 'sky' is a simple analytic gradient; 'studio' a
    neutral grey one (a bright ceiling, a mid-grey horizon, a dark floor) that lights scene
    files with no lights of their own (scenes.loaders.load_scene); 'map' an equirectangular
    image of linear radiance (scenes/loaders/envmap.py), turned `rotation` degrees about +Y."""

    kind: str = "black"
    color: tuple = (0.0, 0.0, 0.0)  # for "constant"; zenith tint scale for "sky"
    strength: float = 1.0
    pixels: np.ndarray | None = field(default=None, repr=False, compare=False)  # "map": (H, W, 3) float32
    rotation: float = 0.0  # "map": degrees about +Y
    source: str = ""  # "map": the file it came from

    @property
    def rotation_u(self) -> float:
        """The rotation as a shift of the map's u coordinate (equirect_uv)."""
        return float(self.rotation) / 360.0 % 1.0

    def radiance(self, dirs: np.ndarray) -> np.ndarray:
        """Radiance (N,3) float32 for unit directions (N,3)."""
        n = dirs.shape[0]
        if self.kind == "black":
            return np.zeros((n, 3), np.float32)
        if self.kind == "constant":
            return np.broadcast_to(np.asarray(self.color, np.float32), (n, 3)).copy()
        if self.kind == "map":
            return equirect_lookup(self.pixels, dirs, self.rotation_u) * np.float32(self.strength)
        y = np.clip(dirs[:, 1:2], -1.0, 1.0)
        return sky_radiance(y, *GRADIENTS[self.kind]) * np.float32(self.strength)

    @staticmethod
    def parse(text: str) -> Environment:
        """A named environment or R,G,B (a map file: scenes/loaders/envmap.py parse_env)."""
        t = text.strip().lower()
        if t in ("black", "sky", "studio"):
            return Environment(t)
        parts = t.split(",")
        try:
            rgb = tuple(float(p) for p in parts)
        except ValueError:
            rgb = ()
        if len(rgb) != 3 or not all(np.isfinite(rgb)) or min(rgb) < 0:
            raise UserError(f"env: expected black, sky, studio, R,G,B with non-negative numbers or an .hdr/.exr "
                            f"file, got {text!r}")
        return Environment("constant", rgb)

    def to_string(self) -> str:
        if self.kind == "map":
            return self.source
        if self.kind == "constant":
            return ",".join(f"{c:g}" for c in self.color)
        return self.kind


SKY_HORIZON = np.array([0.9, 0.95, 1.0], np.float32)
SKY_ZENITH = np.array([0.25, 0.45, 0.9], np.float32)
SKY_GROUND = np.array([0.25, 0.23, 0.2], np.float32)
# the studio: a white ceiling, a grey horizon, a dark grey floor (neutral: no colour cast)
STUDIO_HORIZON = np.array([0.5, 0.5, 0.5], np.float32)
STUDIO_ZENITH = np.array([1.0, 1.0, 1.0], np.float32)
STUDIO_GROUND = np.array([0.15, 0.15, 0.15], np.float32)
# kind: its (horizon, zenith, ground); the same gradient in every backend (shaders/common.glsl,
# rt/environment.py)
GRADIENTS = {"sky": (SKY_HORIZON, SKY_ZENITH, SKY_GROUND), "studio": (STUDIO_HORIZON, STUDIO_ZENITH, STUDIO_GROUND)}


def equirect_uv(dirs: np.ndarray, rotation_u: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Where unit directions (N,3) fall on an equirectangular map, as Mitsuba 3's envmap reads
    it: u = atan2(x, -z) / 2pi + rotation_u (mod 1; -Z at the left edge, turning towards +X),
    v = acos(y) / pi (+Y at the top row). Every backend reads the map this way."""
    u = np.arctan2(dirs[:, 0], -dirs[:, 2]) * (0.5 / np.pi) + rotation_u
    return u - np.floor(u), np.arccos(np.clip(dirs[:, 1], -1.0, 1.0)) / np.pi


def equirect_lookup(pixels: np.ndarray, dirs: np.ndarray, rotation_u: float = 0.0) -> np.ndarray:
    """Bilinear radiance (N,3) of an equirectangular map (H,W,3) towards unit directions:
    texel centres at (i + 0.5) / W, wrapping in u, clamped in v (as a GL texture with
    repeat in s and clamp to edge in t)."""
    h, w = pixels.shape[:2]
    u, v = equirect_uv(dirs.astype(np.float64), rotation_u)
    fx, fy = u * w - 0.5, v * h - 0.5
    x0, y0 = np.floor(fx), np.floor(fy)
    tx, ty = (fx - x0)[:, None], (fy - y0)[:, None]
    ix0 = x0.astype(np.int64) % w
    ix1 = (ix0 + 1) % w
    iy0 = np.clip(y0.astype(np.int64), 0, h - 1)
    iy1 = np.clip(y0.astype(np.int64) + 1, 0, h - 1)
    top = pixels[iy0, ix0] * (1 - tx) + pixels[iy0, ix1] * tx
    bottom = pixels[iy1, ix0] * (1 - tx) + pixels[iy1, ix1] * tx
    return (top * (1 - ty) + bottom * ty).astype(np.float32)


def sky_radiance(y: np.ndarray, horizon=SKY_HORIZON, zenith=SKY_ZENITH, ground=SKY_GROUND) -> np.ndarray:
    """The analytic gradient (the sky's by default: blue zenith, bright horizon, dim ground),
    from the horizon to the zenith above and from half the horizon to the ground below.
    Shared with shaders/common.glsl."""
    y = y.astype(np.float32)
    up = np.clip(y, 0.0, 1.0) ** 0.5
    down = np.clip(-y, 0.0, 1.0) ** 0.5
    sky = horizon * (1 - up) + zenith * up
    ground = horizon * (1 - down) * 0.5 + ground * down
    return np.where(y >= 0, sky, ground).astype(np.float32)


@dataclass
class Scene:
    name: str
    positions: np.ndarray  # (V,3) float32
    normals: np.ndarray  # (V,3) float32, unit
    uvs: np.ndarray  # (V,2) float32
    indices: np.ndarray  # (T,3) int32
    material_ids: np.ndarray  # (T,) int32
    materials: list
    lights: list = field(default_factory=list)
    environment: Environment = field(default_factory=Environment)
    views: dict = field(default_factory=dict)  # name -> View, first is the default
    source: str = "builtin"
    # ambient radiance an artist would set for a raster engine; only the forward baseline uses it
    ambient: tuple = (0.0, 0.0, 0.0)
    tangents: np.ndarray | None = None  # (V,4) float32 xyz tangent, w handedness; where normal maps are used
    colors: np.ndarray | None = None  # (V,3) float32 linear vertex colours (glTF COLOR_0), times the base colour
    # the surface model its materials were made for (option `brdf=auto`): "lambert", the study's
    # (Lambert diffuse, mirror reflections below the roughness threshold), or "ggx", glTF's
    # metal-rough BRDF (Lambert diffuse + GGX specular, docs/ARCHITECTURE.md "Materials")
    brdf: str = "lambert"

    def __getstate__(self) -> dict:
        """Pickled (the scene cache) without what is kept beside the fields ("_" keys: the
        bounds, texture-limited copies, a prefetch of the ray-tracing arrays)."""
        return {k: v for k, v in self.__dict__.items() if not k.startswith("_")}

    # -- derived data -----------------------------------------------------------------
    def uses_ggx(self, brdf_option: str = "auto") -> bool:
        """Whether surfaces shade with glTF's GGX BRDF under option `brdf` (auto: the scene's own)."""
        return (self.brdf if brdf_option == "auto" else brdf_option) == "ggx"

    @property
    def triangle_count(self) -> int:
        return int(self.indices.shape[0])

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The vertices' box; kept while the positions are the same array (0.3 s a call at 10 M)."""
        key = (id(self.positions), self.positions.shape)
        kept = self.__dict__.get("_bounds")
        if kept is not None and kept[0] == key:
            return kept[1][0].copy(), kept[1][1].copy()
        if self.positions.shape[0] == 0:
            z = np.zeros(3, np.float32)
            box = (z, z)
        else:
            box = (self.positions.min(axis=0), self.positions.max(axis=0))
        self.__dict__["_bounds"] = (key, box)
        return box[0].copy(), box[1].copy()

    @property
    def diagonal(self) -> float:
        lo, hi = self.bounds()
        return float(np.linalg.norm(hi - lo))

    def emissive_triangles(self) -> np.ndarray:
        """Indices of triangles that emit: they are area lights."""
        flags = np.array([m.is_emissive for m in self.materials], bool)
        if flags.size == 0 or not flags.any():
            return np.zeros(0, np.int64)
        tris = np.nonzero(flags[self.material_ids])[0]
        return tris[self.triangle_emission()[tris].max(axis=1) > 0.0]

    def triangle_emission(self) -> np.ndarray:
        """(T,3) float32 radiance each triangle emits as a light: its material's constant, or
        where an emission texture applies, the texture's mean over the triangle's uv footprint
        (so a panel that glows in one corner of its texture is a dim light, not a bright one)."""
        if getattr(self, "_emission", None) is not None:
            return self._emission
        out = np.asarray([m.emissive for m in self.materials], np.float32).reshape(-1, 3)[self.material_ids]
        for k, m in enumerate(self.materials):  # only the textured ones need their triangles found
            if m.emissive_map is not None:
                tris = np.nonzero(self.material_ids == k)[0]
                out[tris] = footprint_mean(m.emissive_map, self.uvs[self.indices[tris]], m.wrap)
        self._emission = out
        return out

    def emissive_clusters(self, max_clusters: int = 32) -> list[np.ndarray]:
        """Emissive triangles grouped by material and grid cell, the grid as fine as keeps at most
        `max_clusters` groups: each group is one light for the rasteriser's proxies and the
        tracer's light sampling."""
        if getattr(self, "_clusters", None) is not None and self._clusters[0] == max_clusters:
            return self._clusters[1]
        groups = []
        for cells in (24, 16, 12, 8, 6, 4, 3, 2, 1):
            groups = self._emissive_grid(cells)
            if len(groups) <= max_clusters:
                break
        self._clusters = (max_clusters, groups)
        return groups

    def _emissive_grid(self, cells: int) -> list[np.ndarray]:
        tris = self.emissive_triangles()
        if tris.size == 0:
            return []
        centre = self.positions[self.indices[tris]].astype(np.float64).mean(axis=1)
        lo, hi = self.bounds()
        size = max(float(np.max(hi - lo)) / cells, 1e-6)
        cell = np.clip(np.floor((centre - lo) / size).astype(np.int64), 0, cells)
        key = ((cell[:, 0] * (cells + 1) + cell[:, 1]) * (cells + 1) + cell[:, 2]) * len(self.materials)
        key = key + self.material_ids[tris]  # never merge different materials
        _, inverse = np.unique(key, return_inverse=True)
        order = np.argsort(inverse, kind="stable")
        splits = np.nonzero(np.diff(inverse[order]))[0] + 1
        return [tris[g] for g in np.split(order, splits)]

    def triangle_areas(self, tris: np.ndarray | None = None) -> np.ndarray:
        idx = self.indices if tris is None else self.indices[tris]
        p = self.positions
        e1 = p[idx[:, 1]] - p[idx[:, 0]]
        e2 = p[idx[:, 2]] - p[idx[:, 0]]
        return 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)

    @property
    def has_light(self) -> bool:
        return bool(self.lights) or self.emissive_triangles().size > 0

    def default_view(self) -> View:
        if self.views:
            return next(iter(self.views.values()))
        return auto_view(self)

    def stats(self) -> dict:
        lo, hi = self.bounds()
        kinds = {}
        for light in self.lights:
            kinds[light.kind] = kinds.get(light.kind, 0) + 1
        return {
            "name": self.name,
            "source": self.source,
            "triangles": self.triangle_count,
            "vertices": int(self.positions.shape[0]),
            "materials": len(self.materials),
            "lights": len(self.lights),
            "light_kinds": kinds,
            "emissive_triangles": int(self.emissive_triangles().size),
            "textures": sum(layer is not None for m in self.materials for layer in m.layers()),
            "alpha_tested_materials": sum(m.alpha_tested for m in self.materials),
            "bounds_min": [round(float(x), 4) for x in lo],
            "bounds_max": [round(float(x), 4) for x in hi],
            "environment": self.environment.to_string(),
            "views": list(self.views),
        }

    # -- invariants ---------------------------------------------------------------------
    def validate(self) -> None:
        """Raise UserError for data neither renderer can use; normalise dtypes in place."""
        self.positions = np.ascontiguousarray(self.positions, np.float32).reshape(-1, 3)
        self.normals = np.ascontiguousarray(self.normals, np.float32).reshape(-1, 3)
        self.uvs = np.ascontiguousarray(self.uvs, np.float32).reshape(-1, 2)
        self.indices = np.ascontiguousarray(self.indices).reshape(-1, 3)
        self.material_ids = np.ascontiguousarray(self.material_ids, np.int32).reshape(-1)
        v = self.positions.shape[0]
        if self.indices.shape[0] == 0:
            raise UserError(f"{self.name}: the scene has no triangles")
        if not np.isfinite(self.positions).all():
            raise UserError(f"{self.name}: non-finite vertex positions")
        extent = np.ptp(self.positions.astype(np.float64), axis=0) if v else np.zeros(3)
        if float(np.linalg.norm(extent)) > MAX_EXTENT:
            raise UserError(f"{self.name}: the scene spans {float(np.linalg.norm(extent)):.3g} m; rtlab renders scenes "
                            f"up to {MAX_EXTENT:.0e} m across (float32 positions lose all precision beyond)")
        if self.indices.min() < 0 or self.indices.max() >= v:
            raise UserError(f"{self.name}: triangle indices out of range (vertex count {v})")
        self.indices = self.indices.astype(np.int32)
        if self.normals.shape[0] != v or self.uvs.shape[0] != v:
            raise UserError(f"{self.name}: normals/uvs do not match the vertex count")
        if self.material_ids.shape[0] != self.indices.shape[0]:
            raise UserError(f"{self.name}: one material id per triangle expected")
        if not self.materials or self.material_ids.min() < 0 or self.material_ids.max() >= len(self.materials):
            raise UserError(f"{self.name}: material ids out of range")
        self.normals = fix_normals(self.normals)
        if self.colors is not None:
            self.colors = np.ascontiguousarray(self.colors, np.float32).reshape(-1, 3)
            if self.colors.shape[0] != v:
                raise UserError(f"{self.name}: vertex colours do not match the vertex count")
            self.colors = np.clip(np.where(np.isfinite(self.colors), self.colors, 1.0), 0.0, 1.0).astype(np.float32)
        if self.tangents is not None:
            self.tangents = np.ascontiguousarray(self.tangents, np.float32).reshape(-1, 4)
            if self.tangents.shape[0] != v or not np.isfinite(self.tangents).all():
                raise UserError(f"{self.name}: tangents do not match the vertex count or are not finite")


def fix_normals(normals: np.ndarray) -> np.ndarray:
    """Unit normals; zero or non-finite ones become +Y so shading never sees NaN."""
    n = np.where(np.isfinite(normals), normals, 0.0).astype(np.float32)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    bad = length[:, 0] < 1e-12
    n = n / np.maximum(length, 1e-12)
    n[bad] = (0.0, 1.0, 0.0)
    return n.astype(np.float32)


# barycentric points at which a triangle's texture footprint is averaged (a 6-level grid)
_LEVELS = 6
_BARY = np.array([((i + 1 / 3) / _LEVELS, (j + 1 / 3) / _LEVELS) for i in range(_LEVELS) for j in range(_LEVELS - i)]
                 + [((i + 2 / 3) / _LEVELS, (j + 2 / 3) / _LEVELS) for i in range(_LEVELS - 1)
                    for j in range(_LEVELS - 1 - i)], np.float64)


def sample_texture(tex: np.ndarray, uv: np.ndarray, wrap=(0, 0)) -> np.ndarray:
    """Bilinear samples of an H x W x C texture at uvs (..., 2): glTF's convention (v down,
    texel centres at half-integers), wrap modes per axis as Material.wrap."""
    h, w = tex.shape[:2]
    x = uv[..., 0] * w - 0.5
    y = uv[..., 1] * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]

    def index(i, n, mode):
        i = i.astype(np.int64)
        if mode == WRAP_CLAMP:
            return np.clip(i, 0, n - 1)
        if mode == WRAP_MIRROR:
            i = np.mod(i, 2 * n)
            return np.where(i < n, i, 2 * n - 1 - i)
        return np.mod(i, n)

    xa, xb = index(x0, w, wrap[0]), index(x0 + 1, w, wrap[0])
    ya, yb = index(y0, h, wrap[1]), index(y0 + 1, h, wrap[1])
    top = tex[ya, xa] * (1 - fx) + tex[ya, xb] * fx
    bottom = tex[yb, xa] * (1 - fx) + tex[yb, xb] * fx
    return top * (1 - fy) + bottom * fy


def footprint_mean(tex: np.ndarray, corner_uvs: np.ndarray, wrap=(0, 0)) -> np.ndarray:
    """(T, C) mean of a texture over triangles given their corner uvs (T, 3, 2), from a fixed
    grid of barycentric points (uniform over the triangle's area)."""
    a, b = _BARY[:, 0], _BARY[:, 1]
    weights = np.stack([1 - a - b, a, b], 1)  # (S, 3)
    out = np.zeros((corner_uvs.shape[0], tex.shape[2]), np.float64)
    for start in range(0, corner_uvs.shape[0], 65536):  # bounded temporaries
        c = corner_uvs[start:start + 65536].astype(np.float64)
        uv = np.einsum("sk,tkc->tsc", weights, c)  # (T, S, 2)
        out[start:start + 65536] = sample_texture(tex, uv, wrap).mean(axis=1)
    return out.astype(np.float32)


def auto_view(scene: Scene) -> View:
    """A view that frames the whole scene from the front (+Z, glTF's front) and a little above
    (20 degrees), as the glTF sample viewer frames an asset, for files without a camera: the
    bounding sphere fits the height of the image."""
    lo, hi = scene.bounds()
    c = (lo + hi) * 0.5
    r = max(float(np.linalg.norm(hi - lo)) * 0.5, 1e-3)
    fov = 45.0
    dist = r / np.sin(np.radians(fov) * 0.5)
    up = np.radians(20.0)
    eye = c + np.array([0.0, np.sin(up), np.cos(up)], np.float32) * dist
    return View("auto", tuple(map(float, eye)), tuple(map(float, c)), (0.0, 1.0, 0.0), fov)
