"""OIDN on the ray-tracing GPU (rt/oidn.py, rt/slang/oidn.py, shaders/rt/oidn.slang): where OIDN
has a device for the backend's GPU (its CUDA device: NVIDIA), the frame is denoised and shown
there, with no GL OIDN pass, and gives the CPU filter's image (app/raster/oidn.py) to OIDN's own
GPU/CPU difference; elsewhere (here: lavapipe) OIDN runs on the CPU, said once."""
import os

import numpy as np
import pytest

from app.camera import Camera
from app.options import Options
from app.renderer import Renderer
from scenes.builtin import build_builtin

W, H = 96, 64
TRACER = os.environ.get("RTLAB_TEST_GPU_TRACER", "vulkan")  # cuda on a machine with an NVIDIA GPU


def frames(gl, scene, pass_name: str, sets: tuple, count: int = 1):
    """count frames of pass_name; (the image shown, the last frame's pass names, notices)."""
    opts = Options()
    opts.apply(["denoise=oidn", f"tracer={TRACER}", *sets])
    r = Renderer(gl, scene, opts)
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    for _ in range(count):
        job = r.prepare(cam, W, H, pass_name)
        names = job.gl_before + job.traced + job.gl_after
        r.compute(job)
        r.finish(job)
    image = r.read_linear()
    notices, on_device = list(r.notices), r.rt.on_device("oidn")
    r.release()
    return image, names, notices, on_device


@pytest.mark.parametrize("pass_name,sets", [("ao", ("accumulate=false",)), ("gi", ("max_frames=4",))])
def test_oidn_on_the_gpu_gives_the_cpu_filters_image(gl, gpu_device, pass_name, sets):
    scene = build_builtin("cafe" if pass_name == "gi" else "arcade")
    count = 1 if pass_name == "ao" else 4
    image, names, notices, on_device = frames(gl, scene, pass_name, sets, count)
    cpu, cpu_names, _, _ = frames(gl, scene, pass_name, sets + ("oidn.device=false",), count)
    assert "oidn" in cpu_names
    if not on_device:  # no OIDN device for this GPU: the CPU filter, said once
        assert "oidn" in names and image.tobytes() == cpu.tobytes()
        assert sum(n.startswith("oidn: on the CPU") for n in notices) == 1, notices
        return
    assert "oidn" not in names and "gbuffer" not in names, names
    raw, _, _, _ = frames(gl, scene, pass_name, sets + ("denoise=off",), count)
    # OIDN's GPU device computes in half precision: near the CPU's image, far nearer than the input
    scale = float(np.mean(cpu[..., :3])) + 1e-6
    gap = float(np.mean(np.abs(image[..., :3] - cpu[..., :3]))) / scale
    noise = float(np.mean(np.abs(raw[..., :3] - cpu[..., :3]))) / scale
    assert gap < 0.02 and gap < 0.1 * noise, (gap, noise)


def test_emitters_and_sky_bypass_the_gpu_filter(gl, gpu_device):
    """The first hit's emission and the sky come back as they were (the café's emissive panels;
    the park's sky), wherever OIDN runs."""
    for name in ("cafe", "park"):
        scene = build_builtin(name)
        image, _, _, _ = frames(gl, scene, "gi", ("accumulate=false",))
        raw, _, _, _ = frames(gl, scene, "gi", ("accumulate=false", "denoise=off"))
        opts = Options()
        opts.apply([f"tracer={TRACER}"])
        r = Renderer(gl, scene, opts)
        cam = Camera.from_view(scene.default_view(), scene.diagonal)
        r.render(cam, W, H, "emissive")
        emissive = r.read_linear()[..., :3]
        r.render(cam, W, H, "position")
        covered = np.abs(r.read_linear()[..., :3]).sum(-1) > 0
        r.release()
        sky = ~covered
        lit = covered & (emissive.max(-1) > 1.0)  # emitters far brighter than what they reflect
        assert sky.any() or lit.any(), name
        np.testing.assert_array_equal(image[sky], raw[sky])
        assert np.all(image[lit][..., :3] >= emissive[lit] * 0.999), name


def test_a_failing_gpu_filter_falls_back_to_the_cpu(gl, gpu_device):
    """OIDN's GPU device failing mid-run (a driver error): that frame is shown undenoised, the
    next ones are denoised on the CPU, said once; nothing crashes."""
    from rt.slang.oidn_library import OidnError

    class Failing:
        def run(self, *args):
            raise OidnError("out of memory")

    scene = build_builtin("arcade")
    opts = Options()
    opts.apply([f"tracer={TRACER}", "accumulate=false", "denoise=oidn"])
    r = Renderer(gl, scene, opts)
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    r.options.set("denoise", "off")
    r.render(cam, W, H, "ao")
    raw = r.read_linear()
    r.rt._oidn, r.rt.oidn_note = Failing(), None  # as if OIDN's GPU device had opened
    r.options.set("denoise", "oidn")
    names = []
    for _ in range(2):
        job = r.prepare(cam, W, H, "ao")
        names.append(job.gl_before + job.traced + job.gl_after)
        r.compute(job)
        r.finish(job)
        if not names[1:]:
            failed = r.read_linear()
    notices = list(r.notices)
    r.release()
    assert "oidn" not in names[0] and "oidn" in names[1], names
    np.testing.assert_array_equal(failed, raw)
    assert [n for n in notices if n.startswith("oidn: on the CPU")] == \
        ["oidn: on the CPU (OIDN's GPU device failed: out of memory)"], notices
