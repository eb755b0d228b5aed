"""Subpixel jitter (option jitter): accumulated frames sample the Halton (2, 3) points of each
pixel in the raster G-buffer and forward pass (a jittered projection) and in every backend's
primary rays, so their average is the box-filtered image; motion vectors leave the jitter out."""
import numpy as np
import pytest

from app.camera import Camera, subpixel_jitter
from scenes.builder import SceneBuilder, grid, trs
from tests.test_rt import make, run

LE, HALF, TILT = 2.0, 0.6, np.radians(20.0)
EYE, FOV, SIZE = np.array([0.0, 0.0, 3.0]), 40.0, (48, 36)


def tilted_square():
    """An emissive 1.2 m square facing the camera, turned 20 degrees about the view axis, on black."""
    b = SceneBuilder("tilted_square")
    b.environment.kind = "black"
    b.material("glow", (0.0, 0.0, 0.0), roughness=1.0, emissive=(LE, LE, LE))
    b.add(grid(1, 1), "glow", trs((0, 0, 0), 0, (2 * HALF, 1, 2 * HALF), rotate_x=np.pi / 2, rotate_z=TILT))
    b.view("front", tuple(EYE), (0.0, 0.0, 0.0), FOV)
    return b.build()


def box_filtered_coverage(width, height, n=32):
    """The fraction of each pixel (n x n points) that sees the square: the exact image / LE."""
    th, aspect = np.tan(np.radians(FOV) / 2), width / height
    s = (np.arange(n) + 0.5) / n
    x = (np.arange(width)[:, None] + s[None]).ravel()
    y = (np.arange(height)[:, None] + s[None]).ravel()
    sx = (x / width * 2 - 1) * th * aspect * EYE[2]  # where the ray meets the plane z = 0
    sy = (1 - y / height * 2) * th * EYE[2]
    px, py = np.meshgrid(sx, sy)
    c, si = np.cos(TILT), np.sin(TILT)
    u, v = c * px + si * py, -si * px + c * py  # into the square's own axes
    inside = (np.abs(u) < HALF) & (np.abs(v) < HALF)
    return inside.reshape(height, n, width, n).mean(axis=(1, 3))


def test_the_sequence_starts_at_the_centre_and_stratifies_the_pixel():
    points = np.array([subpixel_jitter(i) for i in range(81)])
    assert tuple(points[0]) == (0.0, 0.0)
    assert (points >= -0.5).all() and (points < 0.5).all()
    phase = (points + 0.5) % 1.0  # back to the radical inverses: stratified in their base's intervals
    assert (np.bincount((phase[:64, 0] * 8).astype(int), minlength=8) == 8).all()  # base 2: 64 points in 8ths
    assert (np.bincount((phase[:81, 1] * 9).astype(int), minlength=9) == 9).all()  # base 3: 81 points in 9ths


@pytest.mark.parametrize("pass_name,sets", [("forward", ()), ("shadows", ()), ("shadows", ("gbuffer=rt",)),
                                            ("shadows", ("tracer=vulkan",)), ("hybrid", ("tracer=vulkan",))])
def test_accumulated_edges_converge_to_the_box_filtered_image(gl, pass_name, sets):
    scene = tilted_square()
    want = box_filtered_coverage(*SIZE)
    edge = (want > 0.05) & (want < 0.95)
    assert edge.sum() > 60

    def error(extra):
        got = run(gl, scene, pass_name, frames=32, size=SIZE, sets=sets + extra)[..., 0] / LE
        whole = (want == 0.0) | (want == 1.0)
        return np.abs(got - want)[edge].mean(), np.abs(got - want)[whole].max()

    jittered, inside = error(())
    centred, _ = error(("jitter=false",))
    print(f"{pass_name} {sets}: mean edge error {jittered:.4f} jittered, {centred:.4f} centred")
    assert inside < 0.02  # whole pixels in or out stay as they were
    assert jittered < 0.03, f"{pass_name} {sets}: mean edge error {jittered:.3f} with jitter"
    assert centred > 0.15  # pixel centres alone are a quarter of a pixel off on such an edge


def test_motion_vectors_leave_the_jitter_out(gl):
    scene = tilted_square()
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    r = make(gl, scene, ("tracer=vulkan",))
    for _ in range(3):  # frames 1 and 2 are jittered by half and a third of a pixel
        r.render(cam, *SIZE, "hybrid")
    assert r.frame.jitter != (0.0, 0.0)
    still = np.frombuffer(r.frame.channels["g_motion"].read(), np.float32).reshape(SIZE[1], SIZE[0], -1)
    r.release()
    covered = box_filtered_coverage(*SIZE, n=2) == 1.0
    assert np.abs(still[covered]).max() < 1e-3  # a still camera: nothing moved, however jittered
