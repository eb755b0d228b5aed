"""The environment's radiance as the CPU kernels compute it (background pixels, missed rays)
against the analytic sky of scenes/model.py, which the raster shaders share."""
import numpy as np
import pytest

from rt.embree import gather, kernels
from scenes.model import SKY_GROUND, SKY_HORIZON, SKY_ZENITH, sky_radiance


def _env(kind, color):
    return kind, np.asarray(color, np.float32), SKY_HORIZON, SKY_ZENITH, SKY_GROUND, np.zeros((1, 1, 3), np.float32)


def _dirs(n, seed=2):
    d = np.random.default_rng(seed).normal(size=(n, 3)).astype(np.float32)
    d[:4] = [[0, 1, 0], [0, -1, 0], [1, 0, 0], [0, 1e-9, 1]]  # zenith, nadir, the horizon from both sides
    return d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.parametrize("kind, color", [(0, (2.0, 0, 0)), (1, (0.2, 0.3, 0.4)), (2, (1.7, 0, 0))])
def test_background_pixels_get_the_environment_and_covered_ones_zero(kind, color):
    d = _dirs(999)
    covered = np.random.default_rng(1).random(len(d)) < 0.4
    out = np.full((len(d), 3), 7.0, np.float32)
    kernels.background_fill(out, d, covered, *_env(kind, color))
    want = {0: np.zeros((len(d), 3)), 1: np.tile(color, (len(d), 1)), 2: sky_radiance(d[:, 1:2]) * color[0]}[kind]
    want[covered] = 0
    np.testing.assert_allclose(out, want, rtol=1e-5, atol=1e-7)


def test_missed_rays_add_the_sky_to_their_points_and_hits_are_listed():
    d = _dirs(500, seed=4)
    prim = np.where(np.random.default_rng(5).random(len(d)) < 0.5, 3, -1).astype(np.int32)
    owner = np.random.default_rng(6).integers(0, 40, len(d)).astype(np.int32)
    out = np.zeros((40, 3), np.float32)
    sel = np.zeros(len(d), np.int64)
    k = gather.split_hits(prim, len(d), d, owner, out, *_env(2, (1.5, 0, 0)), sel)
    assert list(sel[:k]) == list(np.flatnonzero(prim >= 0))
    want = np.zeros((40, 3))
    np.add.at(want, owner[prim < 0], sky_radiance(d[prim < 0, 1:2]) * 1.5)
    np.testing.assert_allclose(out, want, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("first, last", [(True, True), (False, True), (True, False), (False, False)])
def test_blocks_fill_every_uncovered_pixel_once_between_them(first, last):
    """gather.fill_uncovered: the whole-frame kernels' blocks of covered points, each filling
    the uncovered pixels up to its last one, fill every uncovered pixel with the environment
    (and aux's channels with aux_fill), whether or not the image starts or ends covered."""
    rng = np.random.default_rng(7)
    d = _dirs(2000, seed=9)
    covered = rng.random(len(d)) < 0.6
    covered[0], covered[-1] = first, last
    pix = np.flatnonzero(covered)
    out, aux = np.full((len(d), 3), -5.0, np.float32), np.full((len(d), 4), -5.0, np.float32)
    cuts = [0, *sorted(rng.choice(np.arange(1, len(pix)), 6, replace=False)), len(pix)]
    blocks = list(zip(cuts[:-1], cuts[1:], strict=True))
    for b0, b1 in blocks[::-1]:  # blocks in any order
        gather.fill_uncovered(out, aux, np.float32(0.25), pix, b0, b1, d, _env(2, (1.3, 0, 0)))
    np.testing.assert_allclose(out[~covered], sky_radiance(d[~covered, 1:2]) * 1.3, rtol=1e-5, atol=1e-7)
    assert (aux[~covered] == 0.25).all()
    assert (out[covered] == -5).all() and (aux[covered] == -5).all()  # the blocks' own pixels: the passes'
