"""Whole-frame times of Mitsuba 3 on rtlab's five built-in scenes, the yardstick of issue 36
(run by hand on a GPU machine: `python report/mitsuba_frames.py [--variant cuda_ad_rgb]
[--size 1920x1080] [--frames 30] [--out mitsuba.json]`; needs `pip install mitsuba`, which is
not a dependency of rtlab).

Each scene is rtlab's own (scenes.builtin: the same triangles, camera, lights and emitters),
shaded by Mitsuba with its diffuse BSDF of each material's base colour (the study's Lambert),
its point, spot and directional emitters for rtlab's lights, area emitters for emissive
materials and an environment map of the sky where the scene has one. Two integrators, each at 1 sample per pixel and a box filter, as rtlab's frames:
- direct: `direct` with one emitter sample and one BSDF sample (rtlab: shadows_one);
- one_bounce: `path` with max_depth 3, direct light plus one bounce (rtlab: gi_shadows).
A frame is mi.render(...) with a new seed, evaluated and waited for (dr.sync_thread), after
warm-up frames that compile and cache Mitsuba's kernels; the figures are ms per frame.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SCENES = ("arcade", "street", "cafe", "park", "temple")
INTEGRATORS = {"direct": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 1},
               "one_bounce": {"type": "path", "max_depth": 3, "rr_depth": 100}}


def _rgb(values) -> dict:
    return {"type": "rgb", "value": [float(c) for c in values[:3]]}


def _light(mi, light, diagonal: float) -> dict:
    if light.kind == "point":
        return {"type": "point", "position": list(map(float, light.position)), "intensity": _rgb(light.radiance_scale)}
    if light.kind == "spot":
        target = np.asarray(light.position) + np.asarray(light.direction)
        return {"type": "spot", "intensity": _rgb(light.radiance_scale),
                "cutoff_angle": float(np.degrees(light.outer_cone)), "beam_width": float(np.degrees(light.inner_cone)),
                "to_world": mi.ScalarTransform4f().look_at(origin=list(map(float, light.position)),
                                                           target=list(map(float, target)), up=_up(light.direction))}
    return {"type": "directional", "direction": list(map(float, light.direction)),
            "irradiance": _rgb(light.radiance_scale)}


def _up(direction) -> list:
    d = np.asarray(direction, float)
    return [0.0, 0.0, 1.0] if abs(d[1]) > 0.9 * np.linalg.norm(d) else [0.0, 1.0, 0.0]


def mitsuba_scene(mi, scene, integrator: dict, size: tuple, folder: str) -> dict:
    """rtlab's scene as a Mitsuba scene dictionary: a mesh per material (PLY files in folder)."""
    view = scene.default_view()
    d = {"type": "scene", "integrator": dict(integrator),
         "sensor": {"type": "perspective", "fov": float(view.fov), "fov_axis": "y",
                    "to_world": mi.ScalarTransform4f().look_at(origin=list(view.eye), target=list(view.target),
                                                               up=list(view.up)),
                    "film": {"type": "hdrfilm", "width": size[0], "height": size[1], "rfilter": {"type": "box"},
                             "pixel_format": "rgb"},
                    "sampler": {"type": "independent", "sample_count": 1}}}
    for k, mat in enumerate(scene.materials):
        tris = scene.indices[scene.material_ids == k]
        if tris.shape[0] == 0:
            continue
        used = np.unique(tris)
        remap = np.full(scene.positions.shape[0], -1, np.int64)
        remap[used] = np.arange(used.shape[0])
        mesh = mi.Mesh(f"m{k}", used.shape[0], tris.shape[0], has_vertex_normals=True)
        params = mi.traverse(mesh)
        params["vertex_positions"] = scene.positions[used].ravel()
        params["vertex_normals"] = scene.normals[used].ravel()
        params["faces"] = remap[tris].astype(np.uint32).ravel()
        params.update()
        # through a PLY file: a Mesh made in Python takes a BSDF but not an emitter
        path = str(Path(folder) / f"m{k}.ply")
        mesh.write_ply(path)
        d[f"m{k}"] = {"type": "ply", "filename": path, "face_normals": False,
                      "bsdf": {"type": "diffuse", "reflectance": _rgb(mat.base_color)}}
        if max(mat.emissive) > 0:
            d[f"m{k}"]["emitter"] = {"type": "area", "radiance": _rgb(mat.emissive)}
    for i, light in enumerate(scene.lights):
        d[f"light{i}"] = _light(mi, light, scene.diagonal)
    env = scene.environment
    if env.kind == "constant" and max(env.color) > 0:
        d["env"] = {"type": "constant", "radiance": _rgb(env.color)}
    elif env.kind in ("sky", "studio"):
        # the analytic gradient as a latitude-longitude map (Mitsuba's envmap: +Y up, row 0 the
        # zenith); it depends on height alone, so the azimuth's convention does not matter
        rows, cols = 128, 256
        y = np.cos(np.pi * (np.arange(rows) + 0.5) / rows).astype(np.float32)
        dirs = np.stack([np.sqrt(1 - y * y), y, np.zeros_like(y)], 1)
        image = np.repeat(env.radiance(dirs)[:, None, :], cols, axis=1)
        d["env"] = {"type": "envmap", "bitmap": mi.Bitmap(np.ascontiguousarray(image, np.float32))}
    return d


def time_frames(mi, dr, loaded, frames: int, warmup: int = 3) -> list[float]:
    for seed in range(warmup):
        dr.eval(mi.render(loaded, spp=1, seed=seed))
        dr.sync_thread()
    times = []
    for seed in range(warmup, warmup + frames):
        t0 = time.perf_counter()
        image = mi.render(loaded, spp=1, seed=seed)
        dr.eval(image)
        dr.sync_thread()
        times.append((time.perf_counter() - t0) * 1e3)
    return times


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variant", default="cuda_ad_rgb")
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--out", default="")
    ap.add_argument("--images", default="", help="a folder for each scene's last frame (PNG, to look at)")
    args = ap.parse_args()
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(args.variant)
    from scenes.builtin import build_builtin

    size = tuple(int(v) for v in args.size.lower().split("x"))
    rows = []
    for name in args.scenes.split(","):
        scene = build_builtin(name)
        for integ, desc in INTEGRATORS.items():
            with tempfile.TemporaryDirectory() as folder:
                loaded = mi.load_dict(mitsuba_scene(mi, scene, desc, size, folder))
            ms = time_frames(mi, dr, loaded, args.frames)
            if args.images:
                Path(args.images).mkdir(parents=True, exist_ok=True)
                mi.util.write_bitmap(str(Path(args.images) / f"{name}_{integ}.png"), mi.render(loaded, spp=16))
            row = {"scene": name, "integrator": integ, "variant": args.variant, "size": list(size),
                   "frame_ms_mean": float(np.mean(ms)), "frame_ms_median": float(np.median(ms)),
                   "frame_ms_min": float(np.min(ms)), "frames": len(ms)}
            rows.append(row)
            print(f"{name:7} {integ:10} {row['frame_ms_median']:7.2f} ms median, {row['frame_ms_mean']:7.2f} mean "
                  f"({args.variant}, {size[0]}x{size[1]}, 1 spp)", flush=True)
    if args.out:
        Path(args.out).write_text(json.dumps({"mitsuba": mi.__version__, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
