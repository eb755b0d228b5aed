"""FBX and the other formats Assimp reads (.fbx, .dae, .3ds, .blend...), for the study's own
scenes. The native importer runs in a child process (scenes/loaders/assimp_worker.py) under a
memory limit and a time limit, so that a hostile file's crash or hang costs one error line, not
the viewer; it hands back arrays. Here: the textures the file names, read only from inside the
scene's folder (safe_child; a Windows path's file name is looked up there), DDS through
imagecodecs (block-compressed) or Pillow, and rtlab's material model built from Assimp's (module docs: README's table).

Materials (FBX is Phong-shaded; rtlab shades glTF's metal-rough BRDF): base colour = the
diffuse colour x the diffuse (or base colour) texture; roughness = (2 / (shininess + 2))^(1/4)
from the Phong exponent, as the OBJ reader maps Ns, or a PBR file's roughness factor; metallic
= its metallic factor, else 0; emission = the emissive colour, or the emissive texture;
normal maps (normals; a height map is left out); opacity < 1, an opacity map or a base colour
texture with alpha: an alpha mask at 0.5."""
from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

from core.errors import UserError
from scenes.loaders.checks import read_regular
from scenes.loaders.common import available_memory, check_memory, decode_image, safe_child
from scenes.model import Environment, Light, Material, Scene, View
from scenes.progress import counted, stage

EXTENSIONS = (".fbx", ".dae", ".3ds", ".blend", ".x", ".lwo", ".ase", ".ms3d", ".md5mesh", ".off")
TIME_LIMIT_S = 300  # the importer's wall time at most (big FBX scenes take tens of seconds)
MAX_TEXTURE_BYTES = 256 << 20


def load_assimp(path: Path) -> Scene:
    check_memory(path.stat().st_size // 20, path.stat().st_size // 12, path.name)
    stage("importing with Assimp (a child process)")
    arrays, meta = _import(path)
    for feature in meta["features"]:
        warnings.warn(f"{path.name}: {feature}", stacklevel=3)
    pos, tri = arrays["positions"], arrays["indices"]
    if not len(tri):
        raise UserError(f"{path.name}: the file has no triangle meshes")
    if not (np.isfinite(pos).all() and np.isfinite(arrays["normals"]).all() and np.isfinite(arrays["uvs"]).all()):
        raise UserError(f"{path.name}: non-finite vertex data")
    if tri.min() < 0 or tri.max() >= len(pos):
        raise UserError(f"{path.name}: triangle indices out of range")
    embedded = _embedded(meta.get("embedded", []), arrays)
    mats = []
    for k, m in enumerate(meta["materials"]):
        counted("materials and textures", k, len(meta["materials"]))
        mats.append(_material(path, m, embedded))
    mats = mats or [Material()]
    mid = arrays["material_ids"]
    if mid.size and (mid.min() < 0 or mid.max() >= len(mats)):
        raise UserError(f"{path.name}: a mesh names a material the file does not have")
    nrm = arrays["normals"]
    length = np.linalg.norm(nrm, axis=1, keepdims=True)
    if (length < 1e-12).any():  # meshes without normals: the faces'
        from scenes.loaders.common import compute_normals

        nrm = np.where(length < 1e-12, compute_normals(pos, tri), nrm)
    scene = Scene(path.stem, pos, nrm, arrays["uvs"], tri.astype(np.int32), mid.astype(np.int32), mats,
                  [_light(li) for li in meta["lights"]], Environment("black"), _views(meta["cameras"]), str(path),
                  brdf="ggx")
    if any(m.normal_map is not None for m in mats):
        from scenes.loaders.gltf_materials import generate_tangents

        scene.tangents = generate_tangents(pos, nrm, arrays["uvs"], tri)
    scene.validate()
    return scene


def _limits(memory: int):
    def apply():  # in the child, before it runs: its address space and CPU time
        resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
        resource.setrlimit(resource.RLIMIT_CPU, (TIME_LIMIT_S, TIME_LIMIT_S + 5))
    return apply


def _import(path: Path) -> tuple[dict, dict]:
    memory = int(max(min(available_memory() * 0.8, 64 << 30), 2 << 30))
    root = str(Path(__file__).resolve().parents[2])
    env = {**os.environ, "PYTHONPATH": root + os.pathsep + os.environ.get("PYTHONPATH", "")}
    with tempfile.TemporaryDirectory(prefix="rtlab-assimp-") as folder:
        out = Path(folder) / "scene.npz"
        try:
            r = subprocess.run([sys.executable, "-m", "scenes.loaders.assimp_worker", str(path), str(out)],
                               capture_output=True, text=True, timeout=TIME_LIMIT_S, preexec_fn=_limits(memory),
                               env=env, cwd=folder)
        except subprocess.TimeoutExpired:
            raise UserError(f"{path.name}: Assimp did not finish within {TIME_LIMIT_S} s; stopped") from None
        if r.returncode != 0 or not out.exists():
            lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
            reason = lines[-1] if lines and r.returncode in (2, 3) else _crash(r.returncode, memory)
            raise UserError(f"{path.name}: {reason[:200]}")
        with np.load(out, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files if k != "meta"}
            meta = json.loads(z["meta"].tobytes())
    return arrays, meta


def _crash(code: int, memory: int) -> str:
    if code < 0:
        return (f"Assimp's importer crashed (signal {-code}; memory limit {memory / 2**30:.0f} GiB); "
                "the file is damaged or not supported")
    return f"Assimp's importer failed (exit {code})"


def _numbers(m: dict, key: str, n: int, default) -> list:
    v = m.get(key)
    if not v or len(v) < n or not all(np.isfinite(v[:n])):
        return list(default)
    return [float(x) for x in v[:n]]


def _either(m: dict, key: str, legacy: str) -> list:
    """A colour from Assimp's material key, or where that is black FBX's legacy property of the
    same meaning (Assimp's own FBX exporter writes Emissive, not EmissiveColor)."""
    value = _numbers(m, key, 3, (0, 0, 0))
    return value if max(value) > 0 else _numbers(m, legacy, 3, (0, 0, 0))


def _embedded(infos: list, arrays: dict) -> dict:
    """The textures the file carries, by how materials name them: "*index" (Assimp's reference)
    and their own file name (FBX's embedded media keep it), lower case; each (bytes or RGBA
    texels, format hint)."""
    out = {}
    for i, info in enumerate(infos):
        data = arrays.pop(f"embedded_{i}", None)
        if data is None:
            continue
        entry = (data.reshape(info["shape"]) if info.get("hint") == "rgba8" else data.tobytes(), info.get("hint", ""))
        out[f"*{i}"] = entry
        base = info.get("name", "").replace("\\", "/").rsplit("/", 1)[-1].lower()
        if base:
            out.setdefault(base, entry)
    return out


def _material(scene_file: Path, m: dict, embedded: dict | None = None) -> Material:
    name = m.get("name", "default")
    tex = m.get("textures", {})
    base = _numbers(m, "base", 3, _numbers(m, "diffuse", 3, (0.8, 0.8, 0.8)))
    shininess = _numbers(m, "shininess", 1, (None,))[0]
    rough_f = _numbers(m, "roughnessFactor", 1, (None,))[0]
    if rough_f is not None and 0.0 <= rough_f <= 1.0:
        roughness = rough_f
    elif shininess is not None:
        roughness = float((2.0 / (np.clip(shininess, 0.0, 1e6) + 2.0)) ** 0.25)
    else:
        roughness = 0.5
    metal = _numbers(m, "metallicFactor", 1, (0.0,))[0]
    mat = Material(name=name, base_color=(*np.clip(base, 0, 1), 1.0), roughness=float(np.clip(roughness, 0, 1)),
                   metallic=float(np.clip(metal, 0, 1)),
                   emissive=tuple(float(x) for x in np.clip(_either(m, "emissive", "Emissive"), 0, 1e6)),
                   double_sided=True)
    what = f"{scene_file.name}: material {name[:60]!r}"
    colour = _texture(scene_file, tex.get("base_color") or tex.get("diffuse"), what, srgb=True, alpha=True,
                      embedded=embedded)
    opacity = _texture(scene_file, tex.get("opacity"), what, srgb=False, embedded=embedded)
    if colour is not None and opacity is not None:
        h, w = colour.shape[:2]
        yi, xi = np.arange(h) * opacity.shape[0] // h, np.arange(w) * opacity.shape[1] // w
        colour[..., 3] = opacity[yi][:, xi].mean(-1)
    if colour is not None:
        cut = colour.shape[-1] == 4 and float(colour[..., 3].min()) < 1.0
        mat.texture = colour if cut else np.ascontiguousarray(colour[..., :3])
        if cut:
            mat.alpha_mode = "MASK"
    if _numbers(m, "opacity", 1, (1.0,))[0] < 1.0:
        mat.base_color = (*mat.base_color[:3], float(np.clip(_numbers(m, "opacity", 1, (1.0,))[0], 0, 1)))
        mat.alpha_mode = "MASK"
    normal = _texture(scene_file, tex.get("normals"), what, srgb=False, embedded=embedded)
    if normal is not None:
        n = normal[..., :3] * 2.0 - 1.0
        mat.normal_map = (n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-6)).astype(np.float32)
    emission = _texture(scene_file, tex.get("emission_color") or tex.get("emissive"), what, srgb=True,
                        embedded=embedded)
    if emission is not None:
        scale = np.asarray(mat.emissive, np.float32) if max(mat.emissive) > 0 else np.ones(3, np.float32)
        mat.emissive_map = np.ascontiguousarray(emission[..., :3] * scale, np.float32)
    return mat


def _texture(scene_file: Path, name: str | None, what: str, srgb: bool, alpha: bool = False,
             embedded: dict | None = None):
    """A texture the file names: one it carries (embedded: "*index", or its file name), else from
    inside the scene's folder: its relative path, or (a path from another machine, e.g.
    C:\\...\\wood.dds) its file name there or in a textures/ folder."""
    if not name:
        return None
    rel = name.replace("\\", "/")
    base = rel.rsplit("/", 1)[-1]
    found = (embedded or {}).get(name if name.startswith("*") else base.lower())
    if found is not None:
        return _decode_embedded(found, f"{what}: embedded texture {name[:60]!r}", srgb, alpha)
    if name.startswith("*"):
        warnings.warn(f"{what}: embedded texture {name[:20]!r} is not in the file; using the colour", stacklevel=4)
        return None
    candidates = [rel] if not (rel.startswith("/") or ":" in rel) else []
    candidates += [base, f"textures/{base}", f"Textures/{base}"]
    for c in candidates:
        try:
            target = safe_child(scene_file, c)
        except UserError:
            continue
        if target.is_file():
            data = read_regular(target, what, MAX_TEXTURE_BYTES)
            return _decode(data, f"{what}: texture {base[:60]!r}", target.suffix.lower(), srgb, alpha)
    warnings.warn(f"{what}: texture {name[:80]!r} not found in the scene's folder; using the colour", stacklevel=4)
    return None


def _decode_embedded(found: tuple, what: str, srgb: bool, alpha: bool):
    """An embedded texture: an image file's bytes (Assimp's format hint as its suffix; a file
    whose hint is missing or unknown is read by its content), or RGBA8 texels, made a PNG."""
    data, hint = found
    if not isinstance(data, bytes):
        import io

        from PIL import Image

        buf = io.BytesIO()
        Image.fromarray(np.ascontiguousarray(data, np.uint8)).save(buf, format="PNG")
        data, hint = buf.getvalue(), "png"
    if len(data) > MAX_TEXTURE_BYTES:
        raise UserError(f"{what}: {len(data) >> 20} MB, over the {MAX_TEXTURE_BYTES >> 20} MB limit")
    suffix = ".dds" if hint == "dds" or data[:4] == b"DDS " else f".{hint or 'bin'}"
    return _decode(data, what, suffix, srgb, alpha)


def _decode(data: bytes, what: str, suffix: str, srgb: bool, alpha: bool):
    if suffix != ".dds":
        return decode_image(data, what, srgb=srgb, alpha=alpha)
    import imagecodecs
    from PIL import Image

    try:  # the block-compressed formats (BC1-BC7); Pillow reads the uncompressed ones, and BC1-BC7 too
        pixels = np.asarray(imagecodecs.dds_decode(data))
    except Exception:  # noqa: BLE001 - the codec's errors: Pillow's reader decides
        return decode_image(data, what, srgb=srgb, alpha=alpha)
    if pixels.ndim == 2:
        pixels = np.repeat(pixels[..., None], 3, -1)
    rgba = pixels[..., :4] if pixels.shape[-1] >= 4 else np.concatenate(
        [pixels[..., :3], np.full(pixels.shape[:2] + (1,), 255, pixels.dtype)], -1)
    buf = __import__("io").BytesIO()
    Image.fromarray(np.ascontiguousarray(rgba.astype(np.uint8))).save(buf, "PNG")
    return decode_image(buf.getvalue(), what, srgb=srgb, alpha=alpha)


def _light(li: dict) -> Light:
    """Assimp's light (colour x intensity, its attenuation left out) as rtlab's: point and spot
    intensity in W/sr, a sun's irradiance in W/m^2, one unit per unit of the file's colour."""
    colour = np.clip(np.nan_to_num(np.asarray(li["color"], np.float64)), 0, 1e9)
    intensity = float(colour.max()) if colour.max() > 0 else 0.0
    d = np.asarray(li["direction"], np.float64)
    d = d / np.linalg.norm(d) if np.linalg.norm(d) > 1e-12 else np.array([0.0, -1.0, 0.0])
    outer = float(np.clip(np.nan_to_num(li["outer"], nan=np.pi / 4), 1e-3, np.pi / 2))
    inner = float(np.clip(np.nan_to_num(li["inner"], nan=0.0), 0.0, outer))
    return Light(li["kind"], tuple((colour / intensity).tolist()) if intensity else (1.0, 1.0, 1.0), intensity,
                 tuple(np.nan_to_num(li["position"]).tolist()), tuple(d.tolist()), 0.0, inner, outer, li["name"])


def _views(cameras: list) -> dict:
    views = {}
    for k, c in enumerate(cameras):
        eye, look, up = (np.nan_to_num(np.asarray(c[key], np.float64)) for key in ("eye", "look", "up"))
        if np.linalg.norm(look) < 1e-12:
            continue
        aspect = c["aspect"] if c["aspect"] > 0 else 16 / 9
        half = c["hfov"]  # Assimp: half the horizontal angle
        if 0.01 < half < 1.5:
            fov = float(np.degrees(2 * np.arctan(np.tan(half) / aspect)))
        else:  # none given, or not believable (Assimp 5.2's COLLADA reader converts it twice)
            fov = View("", (0, 0, 0), (0, 0, 1)).fov
        name = c["name"] or f"camera{k}"
        views[name] = View(name, tuple(eye.tolist()), tuple((eye + look).tolist()), tuple(up.tolist()),
                           float(np.clip(fov, 1.0, 170.0)))
    return views
