"""Renders the Mitsuba 3 references that tests/test_brdf.py and tests/test_convergence.py compare
rtlab with (run by hand: `python tests/refs/make_mitsuba_refs.py [CASE ...]`; needs `pip install
mitsuba` (3.7 or later) and libLLVM for its llvm_ad_rgb variant: no GPU).

The scenes: tests/gltf_writer.ggx_spheres_document(): white metal spheres (glTF's Schlick F0 =
1, so F = 1 at every angle, as Mitsuba's roughconductor with material "none"), GGX with alpha =
roughness^2 and Smith's separable G in both, under one point light; ggx_grid_document() (glTF's
BRDF as a plugin, below); tests/scenes_for_tests.closed_box(), a closed Lambert room with a box in
it under one point light (Mitsuba's diffuse BSDF), for the convergence tests of
tests/test_convergence.py, and closed_box_ggx(), the same room in glTF's materials (a metal
and a glossy box: GI under brdf=ggx). rtlab's own loader or builder makes the geometry, the light and the
camera; Mitsuba does all the shading (ggx_spheres_map: under an environment map, Mitsuba's
envmap, which reads equirectangular maps as rtlab does). Each image is written as float16 (H, W, 3) linear
radiance, with a box pixel filter (what rtlab's jittered frames accumulate to).
"""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
VARIANT = "llvm_ad_rgb"  # vectorised on the CPU (Mitsuba's LLVM backend: needs libLLVM); scalar_rgb works too, slowly
sys.path.insert(0, str(ROOT))

# width, height
SIZES = {"spheres": (128, 64), "grid": (96, 96), "box": (64, 48), "box_ggx": (64, 48), "box_mirror": (64, 48)}
CASES = {
    # name: (scene, environment radiance, Mitsuba max_depth, samples per pixel, BSDF: conductor, gltf or diffuse)
    "ggx_spheres_direct": ("spheres", 0.0, 2, 1024, "conductor"),  # the point light alone: direct light
    "ggx_spheres_env": ("spheres", 0.5, 4, 4096, "conductor"),  # and a constant sky, 3 bounces (max_bounces=3)
    # and an environment map with a small bright sun (scenes_for_tests.sun_patch_map), 3 bounces
    "ggx_spheres_map": ("spheres", "sun_patch_map", 4, 2048, "conductor"),
    "ggx_grid_direct": ("grid", 0.0, 2, 256, "gltf"),
    "ggx_grid_env": ("grid", 0.5, 3, 1024, "gltf"),  # 2 bounces (reference.max_bounces=2)
    "box_direct": ("box", 0.0, 2, 4096, "diffuse"),  # direct light
    "box_gi": ("box", 0.0, 3, 16384, "diffuse"),  # direct light and one bounce (gi.bounces=1)
    "box_ggx_gi": ("box_ggx", 0.0, 3, 65536, "gltf"),  # glTF's BRDF: a metal and glossy boxes, one bounce
    # and near-mirror boxes under the point light and an emissive panel: the reference's MIS, two bounces
    "box_mirror_ref": ("box_mirror", 0.0, 4, 65536, "gltf"),
}


def gltf_bsdf_class():
    """glTF's metal-rough BRDF as a Mitsuba BSDF plugin written here (the spec's formulas, with
    Mitsuba's own GGX distribution and separable Smith G): Lambert c_diff (1 - F) / pi + F D G /
    (4 n.v n.l), F Schlick's with F0 = mix(0.04, base, metallic), alpha = roughness^2. Sampled
    as a mixture of the cosine lobe and Mitsuba's visible-normal sampling of D. Written with
    masks (dr.select), so that it runs in the vectorised variants (llvm_ad_rgb) as in scalar_rgb."""
    import drjit as dr
    import mitsuba as mi

    class GltfBSDF(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.base = mi.Color3f(props["base"])
            self.metallic = float(props["metallic"])
            self.distr = mi.MicrofacetDistribution(mi.MicrofacetType.GGX, max(float(props["roughness"]) ** 2, 1e-3),
                                                   True)
            self.m_flags = mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide
            self.m_components = [self.m_flags]

        def _fresnel(self, c):
            f0 = 0.04 * (1.0 - self.metallic) + self.base * self.metallic
            return f0 + (1.0 - f0) * dr.power(1.0 - dr.clip(c, 0.0, 1.0), 5)

        def _p_spec(self, cos_v):
            f = self._fresnel(cos_v)
            spec = mi.luminance(f)
            diff = mi.luminance(self.base * (1.0 - self.metallic) * (1.0 - f))
            return dr.select(spec + diff > 0, spec / dr.maximum(spec + diff, 1e-12), 1.0)

        def _eval(self, wi, wo):
            valid = (wi.z > 0) & (wo.z > 0)
            h = dr.normalize(wi + wo)
            f = self._fresnel(dr.dot(wi, h))
            spec = f * (self.distr.eval(h) * self.distr.G(wi, wo, h) / dr.maximum(4.0 * wi.z * wo.z, 1e-12))
            diff = self.base * (1.0 - self.metallic) * (1.0 - f) / dr.pi
            return dr.select(valid, (diff + spec) * wo.z, 0.0)

        def _pdf(self, wi, wo):
            valid = (wi.z > 0) & (wo.z > 0)
            h = dr.normalize(wi + wo)
            p = self._p_spec(wi.z)
            spec = self.distr.pdf(wi, h) / dr.maximum(4.0 * dr.abs(dr.dot(wo, h)), 1e-12)
            return dr.select(valid, p * spec + (1.0 - p) * wo.z / dr.pi, 0.0)

        def sample(self, ctx, si, sample1, sample2, active=True):
            wi = si.wi
            spec_lobe = sample1 < self._p_spec(wi.z)
            m, _ = self.distr.sample(wi, sample2)
            wo = dr.select(spec_lobe, mi.reflect(wi, m), mi.warp.square_to_cosine_hemisphere(sample2))
            bs = mi.BSDFSample3f()
            bs.wo, bs.eta, bs.sampled_component = wo, 1.0, 0
            bs.sampled_type = dr.select(spec_lobe, mi.UInt32(int(mi.BSDFFlags.GlossyReflection)),
                                        mi.UInt32(int(mi.BSDFFlags.DiffuseReflection)))
            bs.pdf = self._pdf(wi, wo)
            ok = active & (wi.z > 0) & (bs.pdf > 0)
            return bs, dr.select(ok, self._eval(wi, wo) / dr.maximum(bs.pdf, 1e-20), 0.0)

        def eval(self, ctx, si, wo, active=True):
            return self._eval(si.wi, wo)

        def pdf(self, ctx, si, wo, active=True):
            return self._pdf(si.wi, wo)

        def eval_pdf(self, ctx, si, wo, active=True):
            return self._eval(si.wi, wo), self._pdf(si.wi, wo)

        def traverse(self, callback):
            pass

        def to_string(self):
            return "GltfBSDF"

    return GltfBSDF


def mitsuba_scene(scene, env: float, max_depth: int, spp: int, kind: str, size: tuple) -> dict:
    import mitsuba as mi

    view = scene.default_view()
    shapes = {}
    for k, mat in enumerate(scene.materials):
        tris = scene.indices[scene.material_ids == k]
        if not len(tris):  # a material no triangle uses (the vectorised variants refuse empty meshes)
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
        if kind == "gltf":
            bsdf = {"type": "gltf", "base": mi.ScalarColor3f(*mat.base_color[:3]), "metallic": float(mat.metallic),
                    "roughness": float(mat.roughness)}
        elif kind == "diffuse":
            bsdf = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [float(c) for c in mat.base_color[:3]]}}
        else:
            bsdf = {"type": "roughconductor", "material": "none", "distribution": "ggx",
                    "alpha": float(mat.roughness) ** 2}
        mesh.set_bsdf(mi.load_dict(bsdf))
        shapes[f"m{k}"] = mesh
        if max(mat.emissive) > 0:  # a one-sided emitter (as Mitsuba's area lights): the mesh
            # written as PLY, loaded back with its emitter
            path = str(Path(tempfile.mkdtemp()) / f"m{k}.ply")
            mesh.write_ply(path)
            radiance = {"type": "area", "radiance": {"type": "rgb", "value": [float(c) for c in mat.emissive]}}
            shapes[f"m{k}"] = {"type": "ply", "filename": path, "bsdf": bsdf, "emitter": radiance}
    light = scene.lights[0]
    d = {"type": "scene", "integrator": {"type": "path", "max_depth": max_depth},
         "sensor": {"type": "perspective", "fov": float(view.fov), "fov_axis": "y",
                    "to_world": mi.ScalarTransform4f().look_at(origin=list(view.eye), target=list(view.target),
                                                               up=list(view.up)),
                    "film": {"type": "hdrfilm", "width": size[0], "height": size[1], "rfilter": {"type": "box"},
                             "pixel_format": "rgb"},
                    "sampler": {"type": "independent", "sample_count": spp}},
         "light": {"type": "point", "position": list(light.position),
                   "intensity": {"type": "rgb", "value": [float(c) for c in light.radiance_scale]}}}
    if isinstance(env, str):  # an EXR file: Mitsuba's envmap reads it as rtlab's env=FILE does
        d["env"] = {"type": "envmap", "filename": env}
    elif env > 0:
        d["env"] = {"type": "constant", "radiance": {"type": "rgb", "value": [env] * 3}}
    d.update(shapes)
    return d


PASS_SPP = 1024  # samples per pixel a call of mi.render: the vectorised variants hold a call's paths at once


def render_in_passes(mi, scene, spp: int) -> np.ndarray:
    """The mean of spp samples per pixel, rendered PASS_SPP at a time with distinct seeds."""
    calls = max(1, spp // PASS_SPP)
    total = np.zeros((0,), np.float64)
    for seed in range(calls):
        image = np.asarray(mi.render(scene, spp=min(spp, PASS_SPP), seed=seed), np.float64)[..., :3]
        total = image if seed == 0 else total + image
    return (total / calls).astype(np.float32)


def main() -> int:
    import mitsuba as mi

    mi.set_variant(VARIANT)
    from scenes.loaders import load_scene
    from tests.gltf_writer import ggx_grid_document, ggx_spheres_document, write_gltf
    from tests.scenes_for_tests import closed_box, closed_box_ggx, closed_box_mirror

    GltfBSDF = gltf_bsdf_class()
    mi.register_bsdf("gltf", lambda props: GltfBSDF(props))
    scenes = {}
    with tempfile.TemporaryDirectory() as folder:
        for key, doc in (("spheres", ggx_spheres_document()), ("grid", ggx_grid_document())):
            path = Path(folder) / f"{key}.gltf"
            write_gltf(path, doc)
            scenes[key] = load_scene(str(path))
    scenes["box"] = closed_box()
    scenes["box_ggx"] = closed_box_ggx()
    scenes["box_mirror"] = closed_box_mirror()
    only = sys.argv[1:]
    for name, (key, env, depth, spp, kind) in CASES.items():
        if only and name not in only:
            continue
        with tempfile.TemporaryDirectory() as maps_folder:
            if isinstance(env, str):  # a map of tests/scenes_for_tests.py, written as EXR
                import tests.scenes_for_tests as maps
                from tests.test_envmap import write_exr

                env = write_exr(Path(maps_folder) / f"{env}.exr", getattr(maps, env)())
            d = mitsuba_scene(scenes[key], env, depth, spp, kind, SIZES[key])
            image = render_in_passes(mi, mi.load_dict(d), spp)
        out = ROOT / "tests" / "refs" / f"{name}.npy"
        np.save(out, image.astype(np.float16))
        print(f"{out.relative_to(ROOT)}: {image.shape}, mean {image.mean():.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
