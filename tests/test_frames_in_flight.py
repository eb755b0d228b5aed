"""Frames in flight on a GPU backend (option frames_in_flight, app/renderer.py and
rt/slang/flights.py): the device works on a frame while GL shows the one before, on lavapipe
with memory shared with llvmpipe. What a user sees must be what waiting for every frame gives:
each frame's own image, one frame late; the last one's when the image is read; the same ray
counts once the frames are done."""
import os

import numpy as np
import pytest

from app.camera import Camera
from scenes.builtin import build_builtin
from tests.test_rt import make

SIZE = (40, 24)
TRACER = os.environ.get("RTLAB_TEST_GPU_TRACER", "vulkan")  # cuda on a machine with an NVIDIA GPU


@pytest.fixture(scope="module")
def arcade():
    return build_builtin("arcade")


def _shown(r) -> np.ndarray:
    """The display texture as GL holds it now (without settling the frames in flight)."""
    tex = r.frame.channels["display"]
    w, h = tex.size
    return np.frombuffer(tex.read(), np.uint8).reshape(h, w, 4).copy()


def _run(gl, scene, in_flight: int, sets=(), count=4, moving=False):
    r = make(gl, scene, [f"tracer={TRACER}", f"frames_in_flight={in_flight}", *sets])
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    shown = []
    for k in range(count):
        if moving:
            cam.eye = np.asarray(cam.eye, float) + [0.05 * k, 0.0, 0.0]
        r.render(cam, *SIZE, "ao")
        shown.append(_shown(r))
    assert r.interop is not None, r.notices
    out = shown, r.read_display(), r.read_linear(), r.rt.rays_traced, r.profiler.names()
    r.release()
    return out


@pytest.mark.parametrize("sets", [(), ("accumulate=false",)])
def test_in_flight_frames_show_each_frame_one_late_and_the_last_when_read(gl, arcade, sets):
    waited, display, linear, rays, _ = _run(gl, arcade, 1, sets)
    late, display2, linear2, rays2, _ = _run(gl, arcade, 2, sets)
    assert np.array_equal(display, display2) and np.array_equal(linear, linear2)
    assert rays == rays2 > 0
    assert np.array_equal(late[0], waited[0])  # the first frame waits: nothing before it to show
    for k in range(1, len(late)):  # then each frame shows the one before it
        assert np.array_equal(late[k], waited[k - 1]), k
    if sets:  # without accumulation each frame is new noise: the lag is seen
        assert not np.array_equal(waited[1], waited[2])


def test_a_moving_camera_ends_on_its_last_view(gl, arcade):
    waited, display, *_ = _run(gl, arcade, 1, ("accumulate=false",), moving=True)
    late, display2, *_ = _run(gl, arcade, 2, ("accumulate=false",), moving=True)
    assert np.array_equal(display, display2)
    assert np.array_equal(late[-1], waited[-2])


def test_switching_to_a_waited_pass_and_resizing_show_their_own_frames(gl, arcade):
    """A hybrid frame (its traced images go to GL passes) and a resize come between in-flight
    frames: each shows its own image, as with frames_in_flight=1."""
    def run(in_flight):
        r = make(gl, arcade, [f"tracer={TRACER}", f"frames_in_flight={in_flight}", "accumulate=false"])
        cam = Camera.from_view(arcade.default_view(), arcade.diagonal)
        out = []
        for size, mode in ((SIZE, "ao"), (SIZE, "ao"), (SIZE, "hybrid"), ((32, 20), "ao"), ((32, 20), "ao"),
                           (SIZE, "forward")):
            r.render(cam, *size, mode)
            out.append(r.read_display().copy())
        r.release()
        return out

    for a, b in zip(run(1), run(2), strict=True):
        assert np.array_equal(a, b)


def test_the_ray_counter_is_its_words_sum_wrapping_as_one_word():
    """The device counts rays in COUNTER_WORDS words (one word made every thread queue on the
    same atomic); the host's total is their sum modulo 2^32, as one word's running value was, so
    that a frame's count (a difference of two readings) survives the words wrapping."""
    from rt.slang.flights import COUNTER_WORDS, counter_total

    shader = open("shaders/rt/common.slang").read()
    assert f"static const uint COUNTER_WORDS = {COUNTER_WORDS};" in shader
    assert COUNTER_WORDS & (COUNTER_WORDS - 1) == 0  # count_rays takes p mod it with a mask
    before = np.full(COUNTER_WORDS, 2**32 - 5, np.uint32)
    after = (before.astype(np.uint64) + 7) % 2**32  # every word wrapped past 2^32
    assert (counter_total(after) - counter_total(before)) % 2**32 == 7 * COUNTER_WORDS
    assert counter_total(np.arange(COUNTER_WORDS, dtype=np.uint32)) == COUNTER_WORDS * (COUNTER_WORDS - 1) // 2
