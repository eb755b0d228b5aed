"""Environment maps (env=FILE.hdr|.exr): the readers, the equirectangular convention every backend
shares, backgrounds alike in the raster pass and on each ray-tracing backend, and the furnace:
a white diffuse sphere under a uniform white map reflects exactly its albedo; a map sampled by
importance (the reference's light sample, rt/environment.py) against quadrature and against
bounces alone."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from app.camera import Camera
from core.errors import UserError
from rt.embree import kernels
from rt.environment import env_args, env_distribution
from scenes.loaders import load_scene
from scenes.loaders.envmap import parse_env, read_envmap
from scenes.model import Environment, equirect_lookup
from tests.scenes_for_tests import sun_patch_map
from tests.test_rt import make, run
from tests.test_studio import _sphere_file


def write_exr(path, pixels):
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(header, {"RGB": np.asarray(pixels, np.float32)}).write(str(path))
    return str(path)


def smooth_map(h=32, w=64):
    """A map that varies with both angles and is continuous across its u seam."""
    v, u = np.meshgrid((np.arange(h) + 0.5) / h, (np.arange(w) + 0.5) / w, indexing="ij")
    return np.stack([1.0 + 0.5 * np.cos(2 * np.pi * u), 0.5 + v, 1.0 + 0.4 * np.sin(2 * np.pi * u) * v],
                    -1).astype(np.float32)


def _dirs(n, seed=3):
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32)


def test_exr_and_hdr_files_read_as_linear_radiance(tmp_path):
    import imagecodecs

    img = np.random.default_rng(0).random((8, 16, 3)).astype(np.float32) * 20
    assert np.array_equal(read_envmap(Path(write_exr(tmp_path / "a.exr", img))), img)
    (tmp_path / "a.hdr").write_bytes(imagecodecs.rgbe_encode(img))
    got = parse_env(str(tmp_path / "a.hdr"))
    assert got.kind == "map" and got.pixels.shape == (8, 16, 3)
    step = img.max(-1, keepdims=True) / 128  # RGBE: 8-bit mantissas under the pixel's largest channel's exponent
    assert (np.abs(got.pixels - img) <= step).all()


@pytest.mark.parametrize("name, data, words", [("bad.exr", b"garbage" * 20, "not a readable OpenEXR"),
                                               ("bad.hdr", b"garbage" * 20, "not a readable Radiance"),
                                               ("missing.hdr", None, "cannot read")])
def test_bad_map_files_give_one_line(tmp_path, name, data, words):
    path = tmp_path / name
    if data is not None:
        path.write_bytes(data)
    with pytest.raises(UserError, match=words):
        parse_env(str(path))
    r = subprocess.run([sys.executable, "-m", "app.cli", "shot", "arcade", "--size", "32x18", "--out",
                        str(tmp_path / "x.png"), "--set", f"env={path}"], capture_output=True, text=True, timeout=300)
    assert r.returncode != 0 and words in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "x.png").exists()


def test_equirect_convention():
    """Mitsuba 3's: -Z at u = 0 (the left edge), +X a quarter in, +Y the top row; texel centres
    read back exactly; env.rotation turns the map about +Y."""
    h, w = 4, 8
    img = np.arange(h * w * 3, dtype=np.float32).reshape(h, w, 3)
    # +X at u = 0.25 (between columns 1 and 2), row centres v = (i + 0.5) / h
    theta = (np.arange(h) + 0.5) / h * np.pi
    for i, t in enumerate(theta):
        d = np.array([[np.sin(t), np.cos(t), 0.0]], np.float32)
        np.testing.assert_allclose(equirect_lookup(img, d)[0], (img[i, 1] + img[i, 2]) / 2, rtol=1e-5)
    # -Z: u = 0, between the last and the first column (the map wraps)
    np.testing.assert_allclose(equirect_lookup(img, np.array([[0.0, 0.0, -1.0]], np.float32))[0],
                               (img[1, 0] + img[2, 0] + img[1, -1] + img[2, -1]) / 4, rtol=1e-5)
    top = equirect_lookup(img, np.array([[1e-4, 1.0, 0.0]], np.float32))[0]
    assert top[0] < img[0, :, 0].max() + 1e-3  # the top row, clamped, not the bottom one
    turned = Environment("map", pixels=img, rotation=90.0)
    np.testing.assert_allclose(turned.radiance(np.array([[0.0, 0.0, -1.0]], np.float32))[0],
                               equirect_lookup(img, np.array([[1.0, 0.0, 0.0]], np.float32))[0], rtol=1e-5)


@pytest.mark.parametrize("rotation", [0.0, 37.0])
def test_the_kernels_read_a_map_as_the_model_does(rotation):
    env = Environment("map", pixels=smooth_map(), strength=1.5, rotation=rotation)
    d = _dirs(3000)
    covered = np.random.default_rng(1).random(len(d)) < 0.3
    out = np.full((len(d), 3), 9.0, np.float32)
    kernels.background_fill(out, d, covered, *env_args(env))
    want = env.radiance(d)
    want[covered] = 0
    np.testing.assert_allclose(out, want, rtol=1e-4, atol=1e-4)


@pytest.mark.parametrize("tracer", ["embree", "vulkan"])
def test_a_map_background_is_the_same_in_every_pass(gl, tmp_path, tracer):
    """Looking past the sphere at a map, turned: the forward pass (GL's texture filter), AO
    (every backend's background) and the model's lookup agree."""
    scene = load_scene(_sphere_file(tmp_path))
    cam = Camera(np.array([0.0, 0.5, 4.0]), np.array([0.0, 0.5, 0.0]), np.array([0.0, 1.0, 0.0]), 70)
    cam.fit_clip(scene.diagonal)
    path = write_exr(tmp_path / "sky.exr", smooth_map())
    sets = ("jitter=false", f"tracer={tracer}", f"env={path}", "env.rotation=30", "env.intensity=2")
    forward = run(gl, scene, "forward", size=(32, 24), camera=cam, sets=sets + ("forward.fxaa=false",))[..., :3]
    traced = run(gl, scene, "ao", size=(32, 24), camera=cam, sets=sets)[..., :3]
    pos = run(gl, scene, "position", size=(32, 24), camera=cam, sets=sets)[..., :3]
    sky = np.abs(pos).sum(-1) == 0
    assert 200 < sky.sum() < 32 * 24 - 50
    np.testing.assert_allclose(traced[sky], forward[sky], rtol=1e-2, atol=1e-2)
    assert np.ptp(traced[sky][:, 0]) > 0.5  # a map, not a constant


@pytest.mark.parametrize("tracer", ["embree", "vulkan"])
def test_furnace_white_map_gives_the_albedo(gl, tmp_path, tracer):
    """A convex diffuse sphere of albedo 0.8 under a uniform map of radiance 1: every bounce ray
    escapes, so GI and the reference give 0.8 exactly, and the forward pass's ambient (the
    map's irradiance cube) 0.8 up to its quadrature."""
    scene = load_scene(_sphere_file(tmp_path))
    cam = Camera(np.array([0.0, 0.0, 3.5]), np.array([0.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), 45)
    cam.fit_clip(scene.diagonal)
    path = write_exr(tmp_path / "white.exr", np.ones((16, 32, 3), np.float32))
    sets = ("jitter=false", f"tracer={tracer}", f"env={path}", "brdf=lambert", "forward.ssao=false",
            "forward.env_reflections=false")
    pos = run(gl, scene, "position", size=(32, 24), camera=cam, sets=sets)[..., :3]
    ball = np.abs(pos).sum(-1) > 0
    assert ball.sum() > 150
    for pass_name, tol in (("gi", 2e-3), ("reference", 2e-3), ("forward", 1.5e-2)):
        # the reference with bounces alone: sampling the map too (MIS) would add noise to this exact case
        extra = ("reference.mis=false",) if pass_name == "reference" else ()
        img = run(gl, scene, pass_name, size=(32, 24), camera=cam, frames=2, sets=sets + extra)[..., :3]
        # at the faceted sphere's silhouette a bounce ray under the smooth normal can hit a neighbouring facet
        near = np.abs(img[ball] - 0.8).max(-1) < tol
        assert near.mean() > 0.95, (pass_name, near.mean())
        np.testing.assert_allclose(np.median(img[ball], 0), 0.8, atol=tol, err_msg=pass_name)
        np.testing.assert_allclose(img[~ball], 1.0, atol=1e-3, err_msg=pass_name)


def test_another_map_of_the_same_size_replaces_the_first(gl, tmp_path):
    """One renderer, env switched between maps of one shape and strength: the raster background
    follows each (the GL textures are made again for a new map)."""
    scene = load_scene(_sphere_file(tmp_path))
    cam = Camera(np.array([0.0, 0.5, 4.0]), np.array([0.0, 0.5, 0.0]), np.array([0.0, 1.0, 0.0]), 70)
    cam.fit_clip(scene.diagonal)
    r = make(gl, scene, ("jitter=false", "forward.fxaa=false"))
    try:
        for value in (0.25, 2.0, 0.25):
            r.options.set("env", write_exr(tmp_path / f"m{value}.exr", np.full((8, 16, 3), value, np.float32)))
            r.render(cam, 16, 12, "forward")
            assert r.read_linear()[0, 0, :3] == pytest.approx([value] * 3, rel=1e-3)
    finally:
        r.release()


def _sphere_quadrature(normals, env, albedo=0.8, h=256, w=512):
    """Radiance of a convex Lambert surface of normals (N,3) under env (nothing shadows it), by
    quadrature of the model's bilinear lookup on a fine grid."""
    theta, phi = (np.arange(h) + 0.5) / h * np.pi, (np.arange(w) + 0.5) / w * 2 * np.pi
    st = np.sin(theta)[:, None]
    dirs = np.stack([st * np.sin(phi)[None], np.broadcast_to(np.cos(theta)[:, None], (h, w)),
                     -st * np.cos(phi)[None]], -1).reshape(-1, 3)
    radiance = env.radiance(dirs.astype(np.float32))[:, 0].astype(np.float64)
    weight = radiance * (np.pi / h) * (2 * np.pi / w) * np.broadcast_to(st, (h, w)).reshape(-1)
    n = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    return albedo / np.pi * (np.maximum(n @ dirs.T, 0) @ weight)


def test_map_samples_have_the_density_they_claim():
    """Draws from a map's distribution (a sun and a dim sky, turned): the density that pdf()
    gives each direction is the one sample() returned, and radiance / density averages to the
    map's integral over the sphere."""
    pixels = sun_patch_map(32, 64)
    env = Environment("map", pixels=pixels, rotation=40)
    dist = env_distribution(env)
    assert env_distribution(env) is dist  # made once per map
    rng = np.random.default_rng(5)
    u1, u2 = rng.random(400_000, dtype=np.float32), rng.random(400_000, dtype=np.float32)
    dirs, pdf = dist.sample(u1, u2, env.rotation_u)
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=1), 1, atol=1e-5)
    assert np.median(np.abs(dist.pdf(dirs, env.rotation_u) / pdf - 1)) < 1e-5
    h, w = 512, 1024
    theta = (np.arange(h) + 0.5) / h * np.pi
    fine = Environment("map", pixels=pixels)
    grid = np.stack(np.meshgrid(theta, (np.arange(w) + 0.5) / w * 2 * np.pi, indexing="ij"), -1).reshape(-1, 2)
    st = np.sin(grid[:, 0])
    d = np.stack([st * np.sin(grid[:, 1]), np.cos(grid[:, 0]), -st * np.cos(grid[:, 1])], 1).astype(np.float32)
    exact = (fine.radiance(d)[:, 0] * st).sum() * (np.pi / h) * (2 * np.pi / w)
    estimate = (env.radiance(dirs)[:, 0] / pdf).mean()
    assert estimate == pytest.approx(exact, rel=5e-3)
    uniform = 4 * np.pi * env.radiance(_dirs(400_000))[:, 0]  # the same integral, uniform directions
    assert np.std(env.radiance(dirs)[:, 0] / pdf) < np.std(uniform) / 5, (np.std(uniform), exact)
    assert env_distribution(Environment("sky")) is None  # smooth: the bounces sample it


@pytest.mark.parametrize("tracer", ["embree", "vulkan"])
def test_a_sun_in_a_map_is_sampled_by_importance(gl, tmp_path, tracer):
    """A white diffuse sphere under a dim sky with a small bright sun (97 % of the light on the
    side facing it): the reference matches quadrature of the map within 1 % on average, and
    sampling the map by importance (MIS with the bounce) cuts the error of the bounces alone
    far more than its extra shadow rays cost (measured here at ~14x at 64 frames)."""
    scene = load_scene(_sphere_file(tmp_path))
    cam = Camera(np.array([0.0, 0.0, 3.5]), np.array([0.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), 45)
    cam.fit_clip(scene.diagonal)
    pixels = sun_patch_map(32, 64, sun=2000.0)
    path = write_exr(tmp_path / "sun.exr", pixels)
    sets = ("jitter=false", f"tracer={tracer}", f"env={path}", "brdf=lambert")
    normals = run(gl, scene, "normal", size=(32, 24), camera=cam, sets=sets)[..., :3]
    ball = np.abs(run(gl, scene, "position", size=(32, 24), camera=cam, sets=sets)[..., :3]).sum(-1) > 0
    exact = _sphere_quadrature(normals[ball].astype(np.float64), Environment("map", pixels=pixels))
    errors, rays = {}, {}
    for mis in (True, False):
        r = make(gl, scene, sets + (f"reference.mis={str(mis).lower()}",))
        try:
            rays[mis] = 0
            for _ in range(64):
                r.render(cam, 32, 24, "reference")
                rays[mis] += r.profiler.finished_counters.get("rays", 0)
            got = r.read_linear()[..., 0][ball]
        finally:
            r.release()
        errors[mis] = np.sqrt(np.mean((got - exact) ** 2))
        if mis:
            assert got.mean() == pytest.approx(exact.mean(), rel=0.01)
    assert rays[True] <= 2.1 * rays[False]
    # at equal rays (error ~ 1 / sqrt(rays)): importance sampling still at least 4x better
    assert errors[True] * np.sqrt(rays[True] / rays[False]) < errors[False] / 4, (errors, rays)


@pytest.mark.parametrize("tracer", ["embree", "vulkan"])
def test_the_shadows_pass_lights_with_the_environment(gl, tmp_path, tracer):
    """Besides its lights, the shadows pass samples the environment with one shadow ray a pixel:
    from the BRDF for an analytic one (a white Lambert sphere of albedo 0.8 under a uniform
    environment of 1 gives 0.8 with no noise), half by importance for a map (a sun in a dim sky:
    within 3 % of quadrature on average at 128 frames; -0.3 % at 256 when measured); hybrid's
    rt_direct keeps the lights alone (its forward shading adds the environment's ambient itself:
    under the uniform one, not twice)."""
    scene = load_scene(_sphere_file(tmp_path))
    cam = Camera(np.array([0.0, 0.0, 3.5]), np.array([0.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), 45)
    cam.fit_clip(scene.diagonal)
    sets = ("jitter=false", f"tracer={tracer}", "brdf=lambert")
    ball = np.abs(run(gl, scene, "position", size=(32, 24), camera=cam, sets=sets)[..., :3]).sum(-1) > 0
    white = run(gl, scene, "shadows", size=(32, 24), camera=cam, sets=sets + ("env=1,1,1",))[..., :3]
    np.testing.assert_allclose(np.median(white[ball], 0), 0.8, atol=5e-4)  # the G-buffer holds 0.8 in half floats
    assert (np.abs(white[ball] - 0.8).max(-1) < 2e-3).mean() > 0.95  # the faceted silhouette aside
    hybrid = run(gl, scene, "hybrid", size=(32, 24), camera=cam,
                 sets=sets + ("env=1,1,1", "forward.ssao=false", "hybrid.ao=false"))[..., :3]
    assert np.median(hybrid[ball]) == pytest.approx(0.8, abs=0.02)
    pixels = sun_patch_map(32, 64, sun=2000.0)
    path = write_exr(tmp_path / "sun.exr", pixels)
    normals = run(gl, scene, "normal", size=(32, 24), camera=cam, sets=sets)[..., :3]
    exact = _sphere_quadrature(normals[ball].astype(np.float64), Environment("map", pixels=pixels))
    got = run(gl, scene, "shadows", size=(32, 24), camera=cam, frames=128,
              sets=sets + (f"env={path}",))[..., 0]
    assert got[ball].mean() == pytest.approx(exact.mean(), rel=0.03)


def test_forward_ambient_keeps_a_small_sun_of_a_large_map(gl, tmp_path):
    """The raster baseline's diffuse light from a map (its irradiance cube): a 3 x 3-texel sun in a
    512 x 1024 map (0.35 degree texels, far finer than the cube's quadrature grid) still lights
    a white Lambert sphere as quadrature of the map does, within 3 % on average (the cube's 16 x 16
    faces, bilinear)."""
    scene = load_scene(_sphere_file(tmp_path))
    cam = Camera(np.array([0.0, 0.0, 3.5]), np.array([0.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), 45)
    cam.fit_clip(scene.diagonal)
    pixels = sun_patch_map(512, 1024, sun=20000.0)
    path = write_exr(tmp_path / "sun.exr", pixels)
    sets = ("jitter=false", "brdf=lambert", f"env={path}", "forward.ssao=false", "forward.fxaa=false")
    ball = np.abs(run(gl, scene, "position", size=(32, 24), camera=cam, sets=sets)[..., :3]).sum(-1) > 0
    normals = run(gl, scene, "normal", size=(32, 24), camera=cam, sets=sets)[..., :3]
    exact = _sphere_quadrature(normals[ball].astype(np.float64), Environment("map", pixels=pixels), h=1024, w=2048)
    got = run(gl, scene, "forward", size=(32, 24), camera=cam, sets=sets)[..., 0][ball]
    assert got.mean() == pytest.approx(exact.mean(), rel=0.03)
    assert np.median(np.abs(got / exact - 1)) < 0.05
