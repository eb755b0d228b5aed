"""Window tests: run under Xvfb (the `display` fixture starts one when there is none)."""
import shutil
import subprocess
import sys
import threading
import time
from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image

from app.fly_camera import FlyCamera, FlyInput
from scenes.builtin import BUILTINS

pytestmark = pytest.mark.window


def view_args(scene="arcade", pass_name="forward", size="320x200", **kw):
    return SimpleNamespace(scene=scene, pass_name=pass_name, set=kw.pop("set", None), size=size,
                           exit_after=kw.pop("exit_after", 0), screenshot=kw.pop("screenshot", None))


@pytest.mark.parametrize("scene", list(BUILTINS))
def test_view_screenshot_has_scene_and_panel(display, tmp_path, scene):
    out = tmp_path / "v.png"
    r = subprocess.run([sys.executable, "-m", "app.cli", "view", scene, "--size", "480x300", "--exit-after", "3",
                        "--screenshot", str(out)], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    img = np.asarray(Image.open(out)).astype(float)
    assert img.shape[:2] == (300, 480)
    # the panel sits top-left over the scene; its title bar is ImGui's blue-grey
    panel = img[12:24, 20:200]
    assert (np.abs(panel - panel.mean((0, 1))) < 40).mean() > 0.5
    scene_part = img[150:, 300:]
    assert scene_part.std() > 5, "no scene rendered right of the panel"


def test_every_mode_renders_in_a_window(display):
    from app.passes import AVAILABLE
    from app.viewer import Viewer

    v = Viewer(view_args(size="200x120"))
    try:
        for name in AVAILABLE:
            v.pass_name = name
            for _ in range(2):
                v.frame(0.016)
            assert v.renderer.frame is not None
            assert np.isfinite(v.renderer.read_linear()).all(), name
    finally:
        v.close()


def test_failed_scene_load_keeps_the_old_scene(display, tmp_path):
    from app.viewer import Viewer

    v = Viewer(view_args())
    try:
        old = v.scene
        v.request_scene(str(tmp_path / "missing.glb"))
        v.frame(0.016)
        assert v.scene is old and "no such file" in v.panel.error
        v.request_scene("cafe")
        v.frame(0.016)
        assert v.scene.name == "cafe" and not v.panel.error
    finally:
        v.close()


def test_minimise_to_zero_size_does_not_crash(display):
    from app.viewer import Viewer

    v = Viewer(view_args())
    try:
        v.glfw.set_window_size(v.window, 1, 1)
        v.glfw.iconify_window(v.window)
        for _ in range(3):
            v.glfw.poll_events()
            v.frame(0.016)
        v.glfw.restore_window(v.window)
        v.glfw.set_window_size(v.window, 320, 200)
        for _ in range(3):
            v.glfw.poll_events()
            v.frame(0.016)
        assert v.renderer.frame is not None
    finally:
        v.close()


@pytest.mark.skipif(shutil.which("xdotool") is None, reason="xdotool not installed")
def test_keys_move_the_camera_and_reset_accumulation(display):
    from app.viewer import Viewer

    v = Viewer(view_args(size="320x200"))
    try:
        for _ in range(3):
            v.glfw.poll_events()
            v.frame(0.05)
        assert v.renderer.frame_count >= 1
        start = v.fly.camera.eye.copy()
        wid = str(v.glfw.get_x11_window(v.window))
        subprocess.run(["xdotool", "windowactivate", "--sync", wid], capture_output=True, timeout=10)
        subprocess.run(["xdotool", "mousemove", "--window", wid, "250", "150"], capture_output=True, timeout=10)

        def press():
            time.sleep(0.2)
            subprocess.run(["xdotool", "keydown", "w"], timeout=10)
            time.sleep(0.6)
            subprocess.run(["xdotool", "keyup", "w"], timeout=10)

        t = threading.Thread(target=press)
        t.start()
        moved_count = None
        deadline = time.time() + 5
        while time.time() < deadline:
            v.glfw.poll_events()
            v.frame(0.05)
            if np.linalg.norm(v.fly.camera.eye - start) > 1e-3 and moved_count is None:
                moved_count = v.renderer.frame_count
        t.join()
        assert np.linalg.norm(v.fly.camera.eye - start) > 0.01, "W did not move the camera"
        assert moved_count == 1, "accumulation did not reset when the camera moved"
    finally:
        v.close()


def test_fly_camera_logic():
    from app.camera import Camera

    cam = Camera(np.array([0.0, 1.0, 5.0]), np.array([0.0, 1.0, 0.0]), np.array([0.0, 1.0, 0.0]), 60)
    fly = FlyCamera(cam, 10.0)
    speed = fly.speed
    assert fly.update(1.0, FlyInput(move=(0, 0, 1)))
    np.testing.assert_allclose(fly.camera.eye, [0, 1, 5 - speed], atol=1e-9)  # forward is -z
    fly.update(1.0, FlyInput(move=(1, 0, 0), fast=True))
    np.testing.assert_allclose(fly.camera.eye[0], 4 * speed)
    fly.update(0.0, FlyInput(look=(100, 0)))
    _, _, f = fly.camera.basis()
    assert f[0] > 0.3  # dragging right turns right
    fly.update(0.0, FlyInput(scroll=2))
    assert fly.speed == pytest.approx(speed * 1.44)
    assert not fly.update(0.1, FlyInput())
