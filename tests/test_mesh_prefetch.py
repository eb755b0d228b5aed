"""The ray-tracing backend's arrays made on a thread while GL uploads the scene (rt/mesh.py
prefetch): the backend takes them, the same as made on the spot; a scene's bounds kept."""
import pickle

import numpy as np

from app.camera import Camera
from app.options import Options
from app.renderer import Renderer
from rt.mesh import MeshArrays, prefetch
from tests.scenes_for_tests import closed_box


def test_the_backend_takes_the_prefetched_arrays(gl):
    scene = closed_box()
    fresh = MeshArrays(scene)
    r = Renderer(gl, scene, Options(), prefetch=True)
    pending = scene.__dict__["_mesh_prefetch"]
    pickle.dumps(scene)  # the scene cache still pickles a scene with a prefetch pending
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    r.render(cam, 32, 24, "ao")
    assert "_mesh_prefetch" not in scene.__dict__ and pending.done()
    data = r.rt.data
    for name in ("corners", "face_normals", "tri_area", "tex_data", "tex_offset", "base_color"):
        np.testing.assert_array_equal(getattr(data, name), getattr(fresh, name), err_msg=name)
    assert data.corners is pending.result().corners  # taken, not made again
    r.release()


def test_a_failed_prefetch_is_made_again():
    scene = closed_box()
    prefetch(scene)
    scene.__dict__["_mesh_prefetch"].result()
    scene.__dict__["_mesh_prefetch"] = _Failed()
    np.testing.assert_array_equal(MeshArrays(scene).corners, MeshArrays(closed_box()).corners)


class _Failed:
    def result(self):
        raise MemoryError("no room")


def test_bounds_are_kept_while_the_positions_are_the_same():
    scene = closed_box()
    lo, hi = scene.bounds()
    lo -= 100.0  # the caller's copy
    np.testing.assert_array_equal(scene.bounds()[0], scene.positions.min(0))
    scene.positions = scene.positions * 2.0
    np.testing.assert_array_equal(scene.bounds()[1], scene.positions.max(0))
