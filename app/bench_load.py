"""`rtlab bench --load [TRIANGLES,TEXTURES]`: how rtlab copes with big scenes (the study's go up to
~10 M triangles and hundreds of textures). Generates a glTF scene of that many triangles (one
wavy sheet per texture, each its own material and 256x256 PNG, one sun) under the output folder
once, then measures, each step in a fresh process so that nothing is warm that should not be:
the first open (an empty scene cache), the cached reopen, and per ray-tracing backend here the
acceleration structure's build, the device memory the scene holds (GPU backends) and the first
ray-traced frame (AO, 1280x720) after the scene is loaded; peak resident memory of each."""
from __future__ import annotations

import json
import math
import os
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from core.errors import UserError

TEXTURE_SIDE = 256
FIRST_FRAME_SIZE = (1280, 720)


def parse_load(text: str, quick: bool) -> tuple[int, int]:
    if text in (None, "", "default"):
        return (200_000, 20) if quick else (10_000_000, 500)
    try:
        tris, texs = (int(float(x)) for x in text.split(","))
    except ValueError:
        raise UserError(f"--load: expected TRIANGLES,TEXTURES (e.g. 10000000,500), got {text!r}") from None
    if not (2 <= tris <= 200_000_000 and 1 <= texs <= 10_000 and tris >= 2 * texs):
        raise UserError("--load: 2..200M triangles, 1..10000 textures, at least two triangles a texture")
    return tris, texs


def generate(folder: Path, triangles: int, textures: int) -> Path:
    """The scene (folder/scene.gltf, scene.bin, tex_K.png), made once for these counts."""
    from PIL import Image

    path = folder / "scene.gltf"
    if path.exists():
        return path
    folder.mkdir(parents=True, exist_ok=True)
    n = max(1, round(math.sqrt(triangles / (2 * textures))))  # cells a side of each sheet
    g = np.linspace(0.0, 1.0, n + 1, dtype=np.float32)
    x, z = np.meshgrid(g, g)
    y = 0.03 * np.sin(6 * x) * np.cos(5 * z)
    pos = np.stack([x, y, z], -1).reshape(-1, 3).astype(np.float32)
    dydx, dydz = 0.18 * np.cos(6 * x) * np.cos(5 * z), -0.15 * np.sin(6 * x) * np.sin(5 * z)
    nrm = np.stack([-dydx, np.ones_like(x), -dydz], -1).reshape(-1, 3)
    nrm = (nrm / np.linalg.norm(nrm, axis=1, keepdims=True)).astype(np.float32)
    uv = np.stack([x, z], -1).reshape(-1, 2).astype(np.float32)
    i = np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]
    quads = np.stack([i, i + n + 1, i + 1, i + 1, i + n + 1, i + n + 2], -1).reshape(-1, 3).astype(np.uint32)
    cols = math.ceil(math.sqrt(textures))
    offsets = np.array([[(k % cols) * 1.2, 0.0, (k // cols) * 1.2] for k in range(textures)], np.float32)
    blocks = [(pos[None] + offsets[:, None]).reshape(-1), np.tile(nrm.reshape(-1), textures),
              np.tile(uv.reshape(-1), textures), np.tile(quads.reshape(-1), textures)]
    with open(folder / "scene.bin", "wb") as f:
        for b in blocks:
            f.write(b.tobytes())
    sizes = [b.nbytes for b in blocks]
    starts = np.cumsum([0] + sizes[:-1]).tolist()
    views = [{"buffer": 0, "byteOffset": int(s), "byteLength": int(z)} for s, z in zip(starts, sizes, strict=True)]
    per = [pos.nbytes, nrm.nbytes, uv.nbytes, quads.nbytes]
    accessors, meshes, nodes, materials, images = [], [], [], [], []
    rng = np.random.default_rng(7)
    for k in range(textures):
        base = len(accessors)
        for v, (kind, count, comp) in enumerate((("VEC3", len(pos), 5126), ("VEC3", len(pos), 5126),
                                                 ("VEC2", len(pos), 5126), ("SCALAR", quads.size, 5125))):
            acc = {"bufferView": v, "byteOffset": k * per[v], "componentType": comp, "count": int(count), "type": kind}
            if v == 0:
                acc["min"] = (pos.min(0) + offsets[k]).tolist()
                acc["max"] = (pos.max(0) + offsets[k]).tolist()
            accessors.append(acc)
        meshes.append({"primitives": [{"attributes": {"POSITION": base, "NORMAL": base + 1, "TEXCOORD_0": base + 2},
                                       "indices": base + 3, "material": k}]})
        nodes.append({"mesh": k})
        materials.append({"pbrMetallicRoughness": {"baseColorTexture": {"index": k}, "metallicFactor": 0.0,
                                                   "roughnessFactor": 0.6}})
        colour = rng.integers(40, 255, 3)
        t = np.arange(TEXTURE_SIDE)
        stripes = ((t[:, None] // (4 + k % 12) + t[None, :] // 16) % 2)[..., None]
        Image.fromarray(np.where(stripes, colour, colour // 3).astype(np.uint8)).save(folder / f"tex_{k}.png")
        images.append({"uri": f"tex_{k}.png"})
    sun = {"type": "directional", "intensity": 3.0, "color": [1, 1, 1]}
    nodes.append({"rotation": [-0.3535534, 0.3535534, 0.1464466, 0.8535534],
                  "extensions": {"KHR_lights_punctual": {"light": 0}}})
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": list(range(len(nodes)))}], "nodes": nodes,
           "meshes": meshes, "materials": materials, "accessors": accessors, "bufferViews": views,
           "buffers": [{"byteLength": int(sum(sizes)), "uri": "scene.bin"}],
           "textures": [{"source": k} for k in range(textures)], "images": images,
           "extensionsUsed": ["KHR_lights_punctual"], "extensions": {"KHR_lights_punctual": {"lights": [sun]}}}
    path.write_text(json.dumps(doc))
    return path


def _child(mode: str, scene_path: str, tracer: str) -> dict:
    """One measurement in this (fresh) process."""
    import warnings

    from scenes.loaders import load_scene

    warnings.simplefilter("ignore")
    t0 = time.perf_counter()
    scene = load_scene(scene_path)
    out = {"load_s": time.perf_counter() - t0, "triangles": scene.triangle_count}
    if mode == "trace":
        from rt.backends import create

        backend = create(tracer)
        t0 = time.perf_counter()
        backend.set_scene(scene)
        out["build_s"] = time.perf_counter() - t0
        inner = getattr(backend, "scene", None)
        if hasattr(inner, "device_bytes"):
            out["device_mb"] = inner.device_bytes / 2**20
        backend.close()
        from app.camera import Camera
        from app.gl_context import create_headless_context
        from app.options import Options
        from app.renderer import Renderer

        opts = Options()
        opts.apply([f"tracer={tracer}", "accumulate=false"])
        t0 = time.perf_counter()
        r = Renderer(create_headless_context(), scene, opts, prefetch=True)
        cam = Camera.from_view(scene.default_view(), scene.diagonal)
        r.render(cam, *FIRST_FRAME_SIZE, "ao")
        r.read_linear()
        out["first_frame_s"] = time.perf_counter() - t0
        r.release()
    out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return out


def _measure(mode: str, scene: Path, tracer: str, cache: Path) -> dict:
    env = {**os.environ, "RTLAB_SCENE_CACHE_DIR": str(cache)}
    r = subprocess.run([sys.executable, "-m", "app.bench_load", mode, str(scene), tracer], capture_output=True,
                       text=True, env=env, timeout=3600)
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith("{")]
    if r.returncode != 0 or not lines:
        tail = (r.stderr.strip().splitlines() or ["no output"])[-1]
        return {"error": tail[:200]}
    return json.loads(lines[-1])


def run_load_bench(args) -> int:
    from app.machine import machine_info
    from rt.backends import available

    tris, texs = parse_load(args.load, args.quick)
    out = Path(args.out)
    folder = out / f"load_scene_{tris}_{texs}"
    t0 = time.perf_counter()
    scene = generate(folder, tris, texs)
    print(f"load bench: {scene} ({tris:,} triangles asked, {texs} textures; made in {time.perf_counter() - t0:.1f} s)")
    cache = out / "load_scene_cache"
    shutil.rmtree(cache, ignore_errors=True)
    rows = {"cold": _measure("load", scene, "embree", cache), "cached": _measure("load", scene, "embree", cache)}
    cold, cached = rows["cold"], rows["cached"]
    print(f"  first open: {cold.get('load_s', float('nan')):.2f} s, peak {cold.get('peak_rss_mb', 0):.0f} MB; "
          f"cached reopen: {cached.get('load_s', float('nan')):.2f} s")
    for b in available():
        if not b["available"] or (b["name"] != "embree" and not b["hardware"] and not args.quick):
            continue  # a software GPU (lavapipe) only in --quick runs
        row = rows[b["name"]] = {**_measure("trace", scene, b["name"], cache), "device": b["device"]}
        if "error" in row:
            print(f"  {b['name']}: {row['error']}")
            continue
        memory = f", device memory {row['device_mb']:.0f} MB" if "device_mb" in row else ""
        print(f"  {b['name']} ({b['device']}): BVH {row['build_s']:.2f} s{memory}, first AO frame "
              f"{row['first_frame_s']:.2f} s after the load, peak {row['peak_rss_mb']:.0f} MB")
    doc = {"machine": machine_info(), "triangles": rows["cold"].get("triangles", tris), "textures": texs,
           "results": rows}
    out.mkdir(parents=True, exist_ok=True)
    (out / "load.json").write_text(json.dumps(doc, indent=1))
    print(f"  -> {out / 'load.json'}")
    return 0


if __name__ == "__main__":
    print(json.dumps(_child(*sys.argv[1:4])))
