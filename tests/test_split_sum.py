"""The raster baseline's split-sum specular light under glTF's BRDF (app/raster/split_sum.py):
its BRDF table against quadrature, its prefiltered layers, and a furnace: a single white metal
sphere under a uniform map reflects exactly its directional albedo, which the reference path
tracer gives too."""
import numpy as np
import pytest

from app.raster.split_sum import SPECULAR_LEVELS, brdf_lut, specular_maps
from scenes.model import Environment
from tests.gltf_writer import mesh_scene, uv_sphere
from tests.scenes_for_tests import sun_patch_map
from tests.test_brdf import _load
from tests.test_envmap import write_exr
from tests.test_rt import run


def _albedo_quadrature(rough, nv, n=1500):
    """The specular lobe's directional albedo with F = 1 (GGX, Smith's separable G), by
    quadrature over the hemisphere."""
    a = rough * rough
    th, ph = np.meshgrid((np.arange(n) + 0.5) / n * np.pi / 2, (np.arange(2 * n) + 0.5) / (2 * n) * 2 * np.pi,
                         indexing="ij")
    lt = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1)
    v = np.array([np.sqrt(1 - nv * nv), 0.0, nv])
    h = lt + v
    h /= np.linalg.norm(h, axis=-1, keepdims=True)

    def g1(c):
        return 2 * c / (c + np.sqrt(a * a + (1 - a * a) * c * c))

    d = a * a / (np.pi * (h[..., 2] ** 2 * (a * a - 1) + 1) ** 2)
    f = d * g1(nv) * g1(lt[..., 2]) / (4 * lt[..., 2] * nv)
    return (f * lt[..., 2] * np.sin(th)).sum() * (np.pi / 2 / n) * (np.pi / n)


@pytest.mark.parametrize("rough_i, nv_i", [(31, 31), (15, 15), (9, 28), (24, 4)])
def test_brdf_table_matches_quadrature(rough_i, nv_i):
    lut = brdf_lut()
    rough, nv = (rough_i + 0.5) / lut.shape[0], (nv_i + 0.5) / lut.shape[1]
    assert lut[rough_i, nv_i].sum() == pytest.approx(_albedo_quadrature(rough, nv), rel=0.02)
    assert 0 <= lut[rough_i, nv_i, 1] < lut[rough_i, nv_i, 0]


def test_prefiltered_layers_keep_the_light_and_blur_more_with_roughness():
    """A sun in a dim sky: every layer keeps the map's mean radiance (the lobe's weights are
    normalised), a uniform map stays uniform, and each rougher layer's peak is lower."""
    env = Environment("map", pixels=sun_patch_map(), rotation=25)
    layers = specular_maps(env)
    assert layers.shape == (SPECULAR_LEVELS, 32, 64, 3) and np.isfinite(layers).all()
    peaks = layers[..., 0].max(axis=(1, 2))
    assert (np.diff(peaks[1:]) < 0).all()
    sin_t = np.sin((np.arange(32) + 0.5) / 32 * np.pi)[None, :, None]
    means = (layers[..., 0] * sin_t).sum(axis=(1, 2)) / (sin_t.sum() * 64)
    np.testing.assert_allclose(means[2:], means[2], rtol=0.03)  # the lobes resolved by the layer's texels
    flat = specular_maps(Environment("constant", (0.5, 0.5, 0.5)))
    np.testing.assert_allclose(flat, 0.5, rtol=1e-4)


def test_split_sum_furnace_matches_the_reference(gl, tmp_path):
    """One white metal sphere (F = 1), roughness 0.5, under a uniform white map: the forward
    pass's specular light (prefiltered radiance 1 x the table's A + B) gives the lobe's
    directional albedo, as the reference path tracer does (one bounce: nothing else to hit)."""
    material = {"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 1.0,
                                         "roughnessFactor": 0.5}}
    doc = mesh_scene([(*uv_sphere((0.0, 0.0, 0.0), 0.5, 96, 48), 0)], [material], [],
                     ((0.0, 0.0, 2.2), (0.0, 0.0, 0.0, 1.0), 0.7))
    scene = _load(tmp_path, doc)
    env = write_exr(tmp_path / "white.exr", np.ones((16, 32, 3), np.float32))
    sets = (f"env={env}", "jitter=false", "forward.ssao=false", "reference.max_bounces=1", "reference.mis=false")
    pos = run(gl, scene, "position", size=(48, 48), sets=sets)[..., :3]
    ball = np.abs(pos).sum(-1) > 0
    inner = ball & (np.linalg.norm(pos, axis=-1) > 0) & (pos[..., 2] > 0.2)  # away from grazing angles
    forward = run(gl, scene, "forward", size=(48, 48), sets=sets)[..., 0]
    reference = run(gl, scene, "reference", frames=64, size=(48, 48), sets=sets)[..., 0]
    assert inner.sum() > 500
    assert forward[inner].mean() == pytest.approx(reference[inner].mean(), rel=0.02)
    assert np.median(np.abs(forward[inner] / reference[inner] - 1)) < 0.03
    assert forward[inner].max() < 1.0  # energy is lost (single scattering), not made
