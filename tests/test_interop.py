"""Memory shared between OpenGL and the Vulkan backend (app/raster/interop.py): here Mesa's
llvmpipe imports lavapipe's exported memory. The shared path must give the images of the copy
path through host memory bit for bit, fall back to it with one notice where sharing cannot be
had, and recreate its memory on resizes and switches without leaking."""
import os

import numpy as np
import pytest

from app.camera import Camera
from scenes.builtin import build_builtin
from tests.test_rt import make

SIZE = (40, 24)


def frames(gl, scene, pass_name, sets, count=2, size=SIZE):
    r = make(gl, scene, ["tracer=vulkan", *sets])
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    for _ in range(count):
        r.render(cam, *size, pass_name)
    out = r.read_linear(), r.read_display(), r.interop is not None, list(r.notices), set(r.profiler.names())
    r.release()
    return out


@pytest.fixture(scope="module")
def arcade():
    return build_builtin("arcade")


@pytest.mark.parametrize("pass_name,sets", [
    ("hybrid", ()),  # raster G-buffer to the device, RT shadows and AO back to GL
    ("hybrid", ("hybrid.gi=true", "hybrid.reflections=true")),
    ("gi", ()),  # the device's own frame: only the display image goes to GL
    ("normal", ("gbuffer=rt",)),  # a G-buffer view: a host image, copied even when sharing
])
def test_shared_memory_gives_the_copy_paths_images(gl, arcade, pass_name, sets):
    linear, display, shared, notices, names = frames(gl, arcade, pass_name, sets)
    linear_copy, display_copy, copied, _, copy_names = frames(gl, arcade, pass_name, (*sets, "interop=copy"))
    assert shared and not copied and notices == []
    assert "share" in names and "share" not in copy_names
    if pass_name == "hybrid":
        assert "gbuffer_share" in names and "gbuffer_readback" in copy_names
    assert np.array_equal(linear, linear_copy)
    assert np.array_equal(display, display_copy)
    assert linear.mean() > 0.01


def test_without_sharing_the_copies_run_and_say_so_once(gl, arcade, monkeypatch):
    import app.raster.interop as interop

    monkeypatch.setattr(interop, "same_gpu", lambda ctx, backend: False)
    linear, display, shared, notices, names = frames(gl, arcade, "hybrid", ())
    linear_copy, display_copy, *_ = frames(gl, arcade, "hybrid", ("interop=copy",))
    assert not shared and "gbuffer_readback" in names
    assert len(notices) == 1 and "host memory" in notices[0] and "not the same GPU" in notices[0]
    assert np.array_equal(display, display_copy)


def test_a_check_that_reads_other_bytes_turns_sharing_off(gl, arcade, monkeypatch):
    """Memory that GL does not see as the device wrote it (another GPU, a driver bug) is caught
    by the pattern written through it when sharing starts."""
    import app.raster.interop as interop

    monkeypatch.setattr(interop._VulkanShare, "to_device", lambda self, links: None)
    monkeypatch.setattr(interop._VulkanShare, "link", _broken_link(interop._VulkanShare.link))
    _, _, shared, notices, _ = frames(gl, arcade, "gi", ())
    assert not shared and "other bytes" in notices[0]


@pytest.mark.parametrize("pass_name", ["hybrid", "ao"])
def test_a_hand_over_that_fails_mid_run_falls_back_within_the_frame(gl, arcade, pass_name):
    """A driver that refuses the hand-over after sharing started (CUDA's map failing): the frame
    is read back through host memory instead, and the rest run without sharing."""
    from app.raster.interop import Unavailable

    r = make(gl, arcade, ["tracer=vulkan"])
    cam = Camera.from_view(arcade.default_view(), arcade.diagonal)
    r.render(cam, *SIZE, pass_name)

    def refuse(links):
        raise Unavailable("the driver refused")

    r.interop._share.to_gl = refuse
    r.render(cam, *SIZE, pass_name)
    r.render(cam, *SIZE, pass_name)
    linear, display, shared = r.read_linear(), r.read_display(), r.interop is not None
    notices = list(r.notices)
    r.release()
    linear_copy, display_copy, *_ = frames(gl, arcade, pass_name, ("interop=copy",), count=3)
    assert not shared and notices == ["vulkan: images go through host memory (the driver refused)"]
    assert np.array_equal(linear, linear_copy) and np.array_equal(display, display_copy)


def _broken_link(link):
    """A link whose GL side is a separate buffer: what the device writes never reaches GL."""

    def make_link(self, nbytes):
        found = link(self, nbytes)
        found.gl = self.ctx.buffer(reserve=nbytes)
        return found

    return make_link


def test_resizes_and_switches_leak_no_shared_memory(gl, arcade):
    """Each link's memory is a file descriptor exported by the device and one imported by GL:
    sizes that change every frame, a scene switch and a backend switch leave the process with
    the descriptors it had."""
    r = make(gl, arcade, ["tracer=vulkan"])
    cam = Camera.from_view(arcade.default_view(), arcade.diagonal)

    def fds():
        return len(os.listdir("/proc/self/fd"))

    for size in ((32, 20), (30, 18), (32, 20)):  # the device lets go of freed memory a frame or two late
        r.render(cam, *size, "hybrid")
    links, before = len(r.interop.links), fds()
    for k in range(12):
        r.render(cam, 24 + 2 * k, 16 + k, "hybrid")
        assert len(r.interop.links) == links
    r.render(cam, 32, 20, "hybrid")
    assert fds() <= before
    r.set_scene(build_builtin("cafe"))
    r.render(cam, 32, 20, "hybrid")
    r.options.set("tracer", "embree")
    r.render(cam, 32, 20, "hybrid")
    assert r.interop is None
    r.options.set("tracer", "vulkan")
    r.render(cam, 32, 20, "hybrid")
    assert r.interop is not None and fds() <= before
    r.release()


def _fresh_rtlab_caches(folder) -> dict:
    """A child process's environment with rtlab's caches in folder; Mesa's own pipeline cache
    stays where it was (cold, lavapipe compiles a ray-tracing pipeline for minutes)."""
    home_cache = os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache")
    return {**os.environ, "XDG_CACHE_HOME": str(folder),
            "MESA_SHADER_CACHE_DIR": os.environ.get("MESA_SHADER_CACHE_DIR", home_cache)}


def test_warmup_fills_the_slang_caches(tmp_path):
    """rtlab warmup's GPU step (here forced onto lavapipe, which it leaves out by default, and one
    pass) leaves slangpy's module and shader caches under the cache folder."""
    import subprocess
    import sys

    env = _fresh_rtlab_caches(tmp_path)
    code = "import app.warmup as w; w.GPU_MODES = ('ao',); raise SystemExit(w.warm_gpu_shaders(('vulkan',)))"
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "the vulkan device's shaders compiled and cached" in done.stdout
    caches = tmp_path / "rtlab" / "slang" / "vulkan"
    assert any((caches / "modules").iterdir()) and any(p.is_file() for p in (caches / "shaders").rglob("*"))


def test_devices_say_whether_gl_interop_is_there():
    """rtlab devices: "interop: yes/no" for each GPU backend (DESIGN's contract); llvmpipe and
    lavapipe share memory here."""
    import json
    import subprocess
    import sys

    text = subprocess.run([sys.executable, "-m", "app.cli", "devices"], capture_output=True, text=True, timeout=300)
    assert text.returncode == 0, text.stderr[-2000:]
    assert "interop: yes (OpenGL <-> vulkan: shared memory" in text.stdout
    doc = subprocess.run([sys.executable, "-m", "app.cli", "devices", "--json"], capture_output=True, text=True,
                         timeout=300)
    rows = {r["name"]: r for r in json.loads(doc.stdout)["backends"]}
    assert rows["vulkan"]["interop"] is True and "interop" not in rows["embree"]
    # where each denoiser runs on a GPU backend: OIDN has no GPU device for lavapipe
    assert rows["vulkan"]["denoisers"].startswith("svgf on the device; oidn on ") and "denoisers" not in rows["embree"]
    if "llvmpipe" in rows["vulkan"]["device"]:
        assert "oidn on the CPU" in text.stdout


def test_a_first_gpu_frame_says_it_compiles_shaders(tmp_path):
    """rtlab shot on a Slang device whose shader cache is empty says what the wait is; once the
    cache holds them, nothing is said."""
    import subprocess
    import sys

    env = _fresh_rtlab_caches(tmp_path)
    said = []
    for _ in range(2):
        done = subprocess.run([sys.executable, "-m", "app.cli", "shot", "arcade", "--pass", "ao", "--size", "16x9",
                               "--set", "tracer=vulkan", "--out", str(tmp_path / "ao.png")], env=env,
                              capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr[-2000:]
        said.append("compiling the vulkan device's shaders" in done.stderr)
    assert said == [True, False]
