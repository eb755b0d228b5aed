"""glTF's metal-rough BRDF (option brdf; docs/ARCHITECTURE.md "Materials") in every renderer:
closed-form direct light on coloured dielectric and metal floors; Mitsuba 3's renders
(tests/refs/make_mitsuba_refs.py) of white GGX metal spheres (its roughconductor) and of a
metallic x roughness grid of spheres (glTF's BRDF as a Mitsuba plugin); on the raster path,
Embree and Vulkan (lavapipe); built-in scenes keep the study's Lambert model."""
import json
import warnings

import numpy as np
import pytest

from app.camera import Camera
from scenes.builtin import build_builtin
from scenes.loaders import load_scene
from tests.gltf_writer import ggx_grid_document, ggx_quads_document, ggx_spheres_document, textured_scene
from tests.test_rt import run

REFS = __import__("pathlib").Path(__file__).parent / "refs"


def _erode(mask, steps=1):
    """mask without its pixels within `steps` of a pixel outside it (8-neighbourhood)."""
    for _ in range(steps):
        m = np.pad(mask, 1)
        out = np.ones_like(mask)
        for dy in (0, 1, 2):
            for dx in (0, 1, 2):
                out &= m[dy:dy + mask.shape[0], dx:dx + mask.shape[1]]
        mask = out
    return mask


def _load(tmp_path, doc):
    path = tmp_path / "scene.gltf"
    path.write_text(json.dumps(doc))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_scene(str(path))


def gltf_brdf(base, metallic, roughness, n, v, l):
    """The glTF spec's metal-rough BRDF (its appendix B) with Smith's separable G, written out
    here apart from rtlab's own code: (..., 3) arrays of unit vectors, base (3,)."""
    base = np.asarray(base, np.float64)
    a2 = roughness**4
    h = v + l
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    nv, nl, nh, vh = ((n * v).sum(-1), (n * l).sum(-1), (n * h).sum(-1), (v * h).sum(-1))
    d = a2 / (np.pi * (nh**2 * (a2 - 1) + 1) ** 2)

    def g1(c):
        return 2 * c / (c + np.sqrt(a2 + (1 - a2) * c**2))

    f0 = 0.04 * (1 - metallic) + base * metallic
    f = f0 + (1 - f0) * ((1 - vh) ** 5)[..., None]
    spec = f * (d * g1(nv) * g1(nl) / (4 * nv * nl))[..., None]
    return (1 - f) * base * (1 - metallic) / np.pi + spec


QUADS = [(-2.1, (0.8, 0.1, 0.1), 0.0, 0.3), (0.0, (1.0, 0.78, 0.34), 1.0, 0.4), (2.1, (0.6, 0.6, 0.6), 0.5, 0.7)]


@pytest.mark.parametrize("pass_name,sets", [("forward", ()), ("shadows", ()), ("shadows", ("tracer=vulkan",)),
                                            ("hybrid", ()), ("reference", ()), ("reference", ("tracer=vulkan",))])
def test_direct_light_on_floors_matches_the_formula(gl, tmp_path, pass_name, sets):
    scene = _load(tmp_path, ggx_quads_document())
    assert scene.uses_ggx("auto")
    light = scene.lights[0]
    pos = run(gl, scene, "position", size=(96, 54)).astype(np.float64)
    got = run(gl, scene, pass_name, size=(96, 54), sets=("env=black",) + sets)
    view = scene.default_view()
    to_light = np.asarray(light.position) - pos
    dist2 = (to_light**2).sum(-1, keepdims=True)
    l = to_light / np.sqrt(dist2)
    v = np.asarray(view.eye) - pos
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    n = np.broadcast_to([0.0, 1.0, 0.0], pos.shape)
    checked = 0
    for x, base, metal, rough in QUADS:
        inside = (np.abs(pos[..., 0] - x) < 0.9) & (np.abs(pos[..., 2]) < 0.9) & (np.abs(pos[..., 1]) < 1e-4)
        inside = _erode(inside & (np.abs(pos).sum(-1) > 0))  # not the background
        want = gltf_brdf(base, metal, rough, n, v, l) * light.intensity * l[..., 1:2] / dist2
        rel = np.abs(got[inside] - want[inside]) / np.maximum(want[inside], 1e-3)
        assert np.median(rel) < 0.01 and np.percentile(rel, 95) < 0.03, (x, np.median(rel), np.percentile(rel, 95))
        checked += inside.sum()
    assert checked > 600


def _mitsuba(name):
    ref = np.load(REFS / f"{name}.npy").astype(np.float32)
    # pixels well inside the spheres (rtlab samples pixel centres, Mitsuba filters over each pixel)
    covered = _erode(np.abs(ref.mean(-1) - ref[0, 0].mean()) > 1e-3, 2)
    return ref, covered & (ref.mean(-1) > 0.01)


# the Mitsuba scenes: their document, image size, the reference's bounces and its median bound
# (tests/refs/make_mitsuba_refs.py): white GGX metal spheres of roughness 0.25, 0.5, 0.8 against
# Mitsuba's roughconductor; orange spheres, metallic 0 / 0.5 / 1 x roughness 0.3 / 0.55 / 0.8,
# against Mitsuba rendering glTF's BRDF as a plugin (its own GGX and Smith G)
MITSUBA_SCENES = {"ggx_spheres": (ggx_spheres_document, (128, 64), 3, 0.03),
                  "ggx_grid": (ggx_grid_document, (96, 96), 2, 0.04)}


@pytest.mark.parametrize("name", list(MITSUBA_SCENES))
@pytest.mark.parametrize("pass_name,sets", [("forward", ()), ("shadows", ()), ("shadows", ("tracer=vulkan",))])
def test_direct_light_matches_mitsuba(gl, tmp_path, name, pass_name, sets):
    """Direct light from a point light: D, G, Fresnel and the alpha mapping."""
    document, size, _, _ = MITSUBA_SCENES[name]
    scene = _load(tmp_path, document())
    ref, keep = _mitsuba(f"{name}_direct")
    got = run(gl, scene, pass_name, size=size, sets=("env=black",) + sets)
    assert keep.sum() > 400
    rel = np.abs(got[keep] - ref[keep]) / ref[keep]
    assert np.median(rel) < 0.02 and np.percentile(rel, 90) < 0.06, (np.median(rel), np.percentile(rel, 90))


@pytest.mark.parametrize("name", list(MITSUBA_SCENES))
@pytest.mark.parametrize("sets,frames", [((), 256), (("tracer=vulkan",), 64)])
def test_reference_matches_mitsuba_path_tracer(gl, tmp_path, name, sets, frames):
    """The reference path tracer's lobe choice and weights (GGX's visible normals, the cosine
    lobe) under a point light and a constant sky, against Mitsuba's path tracer."""
    document, size, bounces, bound = MITSUBA_SCENES[name]
    scene = _load(tmp_path, document())
    ref, keep = _mitsuba(f"{name}_env")
    got = run(gl, scene, "reference", frames=frames, size=size,
              sets=("env=0.5,0.5,0.5", f"reference.max_bounces={bounces}", "reference.rr_start=8") + sets)
    rel = np.abs(got[keep] - ref[keep]) / ref[keep]
    assert got[keep].mean() == pytest.approx(ref[keep].mean(), rel=0.02)
    assert np.median(rel) < bound, np.median(rel)


@pytest.mark.parametrize("sets", [(), ("tracer=vulkan",)])
def test_reference_under_a_map_matches_mitsuba(gl, tmp_path, sets):
    """The white GGX spheres under an environment map of a dim sky and a small bright sun
    (tests/scenes_for_tests.py sun_patch_map) and the point light, 3 bounces: the map sampled by
    importance against both lobes (MIS) gives Mitsuba's path tracer with its envmap."""
    from tests.scenes_for_tests import sun_patch_map
    from tests.test_envmap import write_exr

    document, size, bounces, _ = MITSUBA_SCENES["ggx_spheres"]
    scene = _load(tmp_path, document())
    ref, keep = _mitsuba("ggx_spheres_map")
    env = write_exr(tmp_path / "sun.exr", sun_patch_map())
    got = run(gl, scene, "reference", frames=256, size=size,
              sets=(f"env={env}", f"reference.max_bounces={bounces}", "reference.rr_start=8") + sets)
    rel = np.abs(got[keep] - ref[keep]) / ref[keep]
    assert got[keep].mean() == pytest.approx(ref[keep].mean(), rel=0.01)
    assert np.median(rel) < 0.035, np.median(rel)


def test_builtin_scenes_keep_the_study_model_unless_asked(gl):
    scene = build_builtin("arcade")
    assert not scene.uses_ggx("auto") and scene.uses_ggx("ggx")
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    lambert = run(gl, scene, "shadows", camera=cam)
    assert np.array_equal(run(gl, scene, "shadows", camera=cam, sets=("brdf=lambert",)), lambert)
    ggx = run(gl, scene, "shadows", camera=cam, sets=("brdf=ggx",))
    assert np.abs(ggx - lambert).mean() > 0.01 * lambert.mean()


def test_lambert_option_on_a_gltf_scene(gl, tmp_path):
    """brdf=lambert shades a glTF file as the study did: albedo / pi, no highlight."""
    scene = _load(tmp_path, ggx_quads_document())
    light = scene.lights[0]
    pos = run(gl, scene, "position", size=(96, 54)).astype(np.float64)
    got = run(gl, scene, "shadows", size=(96, 54), sets=("brdf=lambert", "env=black"))
    to_light = np.asarray(light.position) - pos
    dist2 = (to_light**2).sum(-1)
    inside = (np.abs(pos[..., 0] + 2.1) < 0.85) & (np.abs(pos[..., 2]) < 0.85) & (np.abs(pos).sum(-1) > 0)
    want = np.array([0.8, 0.1, 0.1]) / np.pi * (light.intensity * to_light[..., 1] / dist2**1.5)[..., None]
    np.testing.assert_allclose(got[inside], want[inside], rtol=0.01, atol=1e-4)


def rough_metal_floors():
    white = [{"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 1.0, "roughnessFactor": r}}
             for r in (0.4, 0.75)]
    return textured_scene(white, [], [((-1.05, 0, 0), 2.0, 0, "up"), ((1.05, 0, 0), 2.0, 1, "up")], [],
                          ((0, 2.0, 3.0), (float(np.sin(-0.3)), 0, 0, float(np.cos(-0.3))), 0.9))


@pytest.mark.parametrize("sets", [(), ("tracer=vulkan",)])
def test_glossy_reflections_converge_to_the_reference(gl, tmp_path, sets):
    """reflections.glossy: rough metal floors under a constant sky, no lights: one ray a frame
    from the GGX lobe, accumulated, gives what the reference path tracer gives (one bounce);
    without it the pass's sample of the environment (both lobes, as a light) gives the same; with
    lit=false (the study's mirror-only reflections of material colours) they stay black."""
    scene = _load(tmp_path, rough_metal_floors())
    sky = ("env=1,1,1",) + sets
    pos = run(gl, scene, "position", size=(64, 36))
    floor = _erode(np.abs(pos).sum(-1) > 0)
    glossy = run(gl, scene, "reflections", frames=48, size=(64, 36), sets=sky + ("reflections.glossy=true",))
    ref = run(gl, scene, "reference", frames=48, size=(64, 36), sets=sky + ("reference.max_bounces=1",))
    plain = run(gl, scene, "reflections", frames=48, size=(64, 36), sets=sky)
    study = run(gl, scene, "reflections", size=(64, 36), sets=sky + ("reflections.lit=false",))
    assert floor.sum() > 300 and np.abs(study[floor] - 1.0).max() < 1e-6  # the albedo (white), unlit
    assert 0.6 < glossy[floor].mean() < 1.0  # single scattering loses some light at these roughnesses
    for got in (glossy, plain):
        assert got[floor].mean() == pytest.approx(ref[floor].mean(), rel=0.01)
        for side in (pos[..., 0] < 0, pos[..., 0] > 0):  # each roughness on its own
            m = floor & side
            assert got[m].mean() == pytest.approx(ref[m].mean(), rel=0.02)
