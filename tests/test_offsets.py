"""Ray origins off surfaces at any scale (rt/embree/raygen.py: offset_origin, Ray Tracing Gems
ch. 6; hits lifted by their error, kernels.hit_lift; the same in common.slang): ambient
occlusion between two parallel planes h apart is (h / radius)^2 for cosine rays, whether the
scene is a metre or a kilometre across, on every G-buffer path and backend."""
import numpy as np
import pytest

from app.camera import Camera
from rt.embree import raygen
from scenes.builder import SceneBuilder, grid, trs
from tests.scenes_for_tests import expected_point_radiance
from tests.test_rt import run


def planes(h, cells=8):
    """A floor and a ceiling h apart, each 400 h wide (vertices 200 h from the axis) in cells x
    cells squares of two triangles, on black."""
    b = SceneBuilder("planes")
    b.environment.kind = "black"
    b.material("grey", (0.5, 0.5, 0.5), roughness=1.0)
    b.add(grid(cells, cells), "grey", trs((0, 0, 0), 0, (400 * h, 1, 400 * h)))
    b.add(grid(cells, cells), "grey", trs((0, h, 0), 0, (400 * h, 1, 400 * h), rotate_x=np.pi))
    return b.build()


def floor_ao(gl, scene, cam, h, sets, frames):
    """Mean AO (radius 2 h, 8 rays a pixel) over the floor pixels the camera sees (more than 1000);
    the far plane past the scene's farthest corner, the camera inside it or not."""
    lo, hi = scene.bounds()
    cam.fit_clip(scene.diagonal + float(np.linalg.norm(cam.eye - 0.5 * (lo + hi))))
    pos = run(gl, scene, "position", camera=cam, sets=sets)
    floor = (np.abs(pos[..., 1]) < 1e-3 * h) & (np.abs(pos).sum(-1) > 0)
    assert floor.sum() > 1000
    ao = run(gl, scene, "ao", frames=frames, camera=cam, sets=sets + (f"ao.radius={2.0 * h}", "ao.rays_per_pixel=8"))
    return ao[floor][:, 0].mean()


@pytest.mark.parametrize("h", [1.0, 1000.0])
@pytest.mark.parametrize("sets", [(), ("gbuffer=rt",), ("tracer=vulkan",)])
def test_ao_between_planes_is_exact_at_any_scale(gl, h, sets):
    cam = Camera(np.array([0.0, 0.5 * h, 0.0]), np.array([0.0, 0.0, -0.3 * h]), np.array([0.0, 1.0, 0.0]), 60)
    assert floor_ao(gl, planes(h), cam, h, sets, frames=32) == pytest.approx(0.25, abs=0.003)  # (h / 2 h)^2


@pytest.mark.parametrize("sets", [(), ("gbuffer=rt",)])
def test_raster_gbuffer_points_lie_on_huge_triangles(gl, sets):
    """Each plane two triangles 400 km wide, seen from 500 m up, 30 degrees down: the raster
    G-buffer's depth is the pixel's ray meeting its triangle's plane (shaders/gbuffer.frag), so
    the rebuilt points lie on it; interpolating the position over such triangles had left them
    centimetres under it (AO 0.197 for 0.25)."""
    h = 1000.0
    cam = Camera(np.array([0.0, 0.5 * h, 0.0]), np.array([0.0, 0.5 * h - 0.5, -0.866]), np.array([0.0, 1.0, 0.0]),
                 60)
    assert floor_ao(gl, planes(h, cells=1), cam, h, sets, frames=8) == pytest.approx(0.25, abs=0.003)


def test_origins_leave_the_surface_by_ulps():
    p = np.array([[0.0, 0.01, -3.0], [1000.0, -1e5, 0.5]], np.float32)
    n = np.array([[0.0, 1.0, 0.0], [0.6, -0.8, 0.0]], np.float32)
    o = raygen.offset_origins(p, n, np.empty_like(p))
    assert o[0, 1] == np.float32(0.01) + np.float32(1 / 65536)  # near 0: a fixed step
    assert o[0, 0] == 0.0 and o[0, 2] == -3.0
    ulps = o.view(np.int32).astype(np.int64) - p.view(np.int32)
    assert ulps[1].tolist() == [153, 204, 0]  # elsewhere 256 x n ulps, away from the surface on each axis
    assert o[1, 0] > p[1, 0] and o[1, 1] < p[1, 1]


def strip_planes(h, k):
    """planes(h) as a strip of two triangles each under far_camera(h, k)'s view: from 200 h short
    of 0.8 k h to 200 h beyond 1.25 k h away, 400 h wide (the camera outside it once k > 250;
    at 100 km and k = 10,000 the strip spans 5e8 m, half rtlab's largest scene)."""
    b = SceneBuilder("planes")
    b.environment.kind = "black"
    b.material("grey", (0.5, 0.5, 0.5), roughness=1.0)
    near, far = 0.8 * k * h - 200 * h, 1.25 * k * h + 200 * h
    centre, length = (0.0, 0.0, -0.5 * (near + far)), far - near
    b.add(grid(1, 1), "grey", trs(centre, 0, (400 * h, 1, length)))
    b.add(grid(1, 1), "grey", trs((0.0, h, centre[2]), 0, (400 * h, 1, length), rotate_x=np.pi))
    return b.build()


def far_camera(h, k):
    """Between the planes (at h / 2), looking at the floor k x h away, the view a little wider
    than the floor from 0.8 k h to 1.25 k h."""
    target = np.array([0.0, 0.0, -k * h])
    eye = np.array([0.0, 0.5 * h, 0.0])
    fov = 2.0 * np.degrees(np.arctan(0.5 / (0.8 * k)) - np.arctan(0.5 / k)) * 1.5
    return Camera(eye, target, np.array([0.0, 1.0, 0.0]), max(fov, 1e-4))


@pytest.mark.parametrize("h", [1.0, 1e3, 1e5])
@pytest.mark.parametrize("k", [1, 100, 10000])
@pytest.mark.parametrize("sets", [(), ("gbuffer=rt",), ("tracer=vulkan",), ("tracer=vulkan", "gbuffer=rt")])
def test_ao_between_planes_is_exact_at_any_scale_and_distance(gl, h, k, sets):
    """Issue 39's matrix: gaps of 1 m, 1 km and 100 km, the floor seen from 1, 100 and 10,000 x
    the gap away, on the raster and the ray-traced G-buffer, Embree and the device: (h / 2 h)^2
    within 0.003. Hits lifted by the largest coordinate (2^-20 x (max |o_i| + t), 2 cm at 10 km)
    gave 0.243 from 10,000 x a 1 m gap; per coordinate they are lifted by ulps of the height."""
    assert floor_ao(gl, strip_planes(h, k), far_camera(h, k), h, sets, frames=8) == pytest.approx(0.25, abs=0.003)


def lit_strip(h, k):
    """strip_planes' floor alone under a point light h above the middle of far_camera's view."""
    b = SceneBuilder("lit_strip")
    b.environment.kind = "black"
    b.material("grey", (0.5, 0.5, 0.5), roughness=1.0)
    near, far = 0.8 * k * h - 200 * h, 1.25 * k * h + 200 * h
    b.add(grid(1, 1), "grey", trs((0.0, 0.0, -0.5 * (near + far)), 0, (400 * h, 1, far - near)))
    b.light(kind="point", position=(0.0, h, -k * h), intensity=h * h, color=(1, 1, 1))
    return b.build()


@pytest.mark.parametrize("h", [1.0, 1e3, 1e5])
@pytest.mark.parametrize("k", [1, 100, 10000])
@pytest.mark.parametrize("sets", [(), ("gbuffer=rt",), ("tracer=vulkan",), ("tracer=vulkan", "gbuffer=rt")])
def test_lit_plane_is_exact_at_any_scale_and_distance(gl, h, k, sets):
    """The matrix again for a floor under a point light h above it: the shadows pass is rho / pi
    I cos / d^2 within 1 % on every floor pixel (a point lifted too little shadows itself: 0)."""
    scene, cam = lit_strip(h, k), far_camera(h, k)
    lo, hi = scene.bounds()
    cam.fit_clip(scene.diagonal + float(np.linalg.norm(cam.eye - 0.5 * (lo + hi))))
    pos = run(gl, scene, "position", camera=cam, sets=sets).astype(np.float64)
    got = run(gl, scene, "shadows", camera=cam, sets=sets)
    floor = np.abs(pos).sum(-1) > 0
    assert floor.sum() > 1000
    want = expected_point_radiance(pos[floor], (0.5, 0.5, 0.5), (0.0, h, -k * h), h * h)
    assert np.abs(got[floor] / want - 1).max() < 0.01
