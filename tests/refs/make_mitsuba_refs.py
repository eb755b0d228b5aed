"""Renders the Mitsuba 3 references that tests/test_brdf.py compares rtlab with (run by hand:
`python tests/refs/make_mitsuba_refs.py`; needs `pip install mitsuba`, scalar_rgb: no GPU).

The scene is tests/gltf_writer.ggx_spheres_document(): white metal spheres (glTF's Schlick F0 =
1, so F = 1 at every angle, as Mitsuba's roughconductor with material "none"), GGX with alpha =
roughness^2 and Smith's separable G in both, under one point light. rtlab's own loader reads
the geometry, the light and the camera; Mitsuba does all the shading. Each image is written
as float16 (H, W, 3) linear radiance, with a box pixel filter (rtlab's pixels are point-sampled at
their centres: the tests compare pixels away from silhouettes).
"""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

WIDTH, HEIGHT = 128, 64
CASES = {
    # name: (environment radiance, Mitsuba max_depth, samples per pixel)
    "ggx_spheres_direct": (0.0, 2, 1024),  # the point light alone, no interreflection: direct light
    "ggx_spheres_env": (0.5, 4, 4096),  # and a constant environment, 3 bounces: rtlab reference.max_bounces=3
}


def mitsuba_scene(scene, env: float, max_depth: int, spp: int) -> dict:
    import mitsuba as mi

    view = scene.default_view()
    shapes = {}
    for k, mat in enumerate(scene.materials):
        tris = scene.indices[scene.material_ids == k]
        used = np.unique(tris)
        remap = np.full(scene.positions.shape[0], -1, np.int64)
        remap[used] = np.arange(used.shape[0])
        mesh = mi.Mesh(f"m{k}", used.shape[0], tris.shape[0], has_vertex_normals=True)
        params = mi.traverse(mesh)
        params["vertex_positions"] = scene.positions[used].ravel()
        params["vertex_normals"] = scene.normals[used].ravel()
        params["faces"] = remap[tris].astype(np.uint32).ravel()
        params.update()
        mesh.set_bsdf(mi.load_dict({"type": "roughconductor", "material": "none", "distribution": "ggx",
                                    "alpha": float(mat.roughness) ** 2}))
        shapes[f"m{k}"] = mesh
    light = scene.lights[0]
    d = {"type": "scene", "integrator": {"type": "path", "max_depth": max_depth},
         "sensor": {"type": "perspective", "fov": float(view.fov), "fov_axis": "y",
                    "to_world": mi.ScalarTransform4f().look_at(origin=list(view.eye), target=list(view.target),
                                                               up=list(view.up)),
                    "film": {"type": "hdrfilm", "width": WIDTH, "height": HEIGHT, "rfilter": {"type": "box"},
                             "pixel_format": "rgb"},
                    "sampler": {"type": "independent", "sample_count": spp}},
         "light": {"type": "point", "position": list(light.position),
                   "intensity": {"type": "rgb", "value": [float(c) for c in light.radiance_scale]}}}
    if env > 0:
        d["env"] = {"type": "constant", "radiance": {"type": "rgb", "value": [env] * 3}}
    d.update(shapes)
    return d


def main() -> int:
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    from scenes.loaders import load_scene
    from tests.gltf_writer import ggx_spheres_document, write_gltf

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "spheres.gltf"
        write_gltf(path, ggx_spheres_document())
        scene = load_scene(str(path))
    for name, (env, depth, spp) in CASES.items():
        image = np.asarray(mi.render(mi.load_dict(mitsuba_scene(scene, env, depth, spp))), np.float32)[..., :3]
        out = ROOT / "tests" / "refs" / f"{name}.npy"
        np.save(out, image.astype(np.float16))
        print(f"{out.relative_to(ROOT)}: {image.shape}, mean {image.mean():.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
