import os
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from rt.backends import init_process  # noqa: E402

init_process()  # before any test module imports a backend's kernels
GOLDEN = ROOT / "screenshots" / "golden"
FAILURES = ROOT / "tests" / "_failures"


def pytest_addoption(parser):
    parser.addoption("--regen-golden", action="store_true", help="rewrite the golden images instead of comparing")
    parser.addoption("--runslow", action="store_true", help="run tests marked slow")


def pytest_collection_modifyitems(config, items):
    if config.getoption("--runslow"):
        return
    skip = pytest.mark.skip(reason="slow: use --runslow")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)


@pytest.fixture(scope="session")
def gl():
    from app.gl_context import create_headless_context

    return create_headless_context()


@pytest.fixture(scope="session")
def gpu_device():
    """The Slang device kind the GPU-backend tests run on (RTLAB_TEST_GPU_TRACER: vulkan, which
    is lavapipe here, or cuda on a machine with an NVIDIA GPU), asserted present."""
    from rt.backends import describe_device

    tracer = os.environ.get("RTLAB_TEST_GPU_TRACER", "vulkan")
    assert describe_device(tracer) is not None, f"no {tracer} device with ray tracing (scripts/setup.sh installs " \
                                                "Mesa's lavapipe)"
    return tracer


@pytest.fixture(scope="session")
def vulkan():
    """The Vulkan device (lavapipe here), asserted present."""
    from rt.slang.device import describe

    info = describe("vulkan")
    assert info is not None, "no Vulkan device with ray tracing (scripts/setup.sh installs Mesa's lavapipe)"
    return info


@pytest.fixture
def compare_golden(request):
    """compare_golden(name, image): tolerant comparison with a stored PNG; --regen-golden rewrites it."""
    from PIL import Image

    def check(name: str, image: np.ndarray, mean_tol: float = 3.0, p99_tol: float = 40.0):
        path = GOLDEN / f"{name}.png"
        if request.config.getoption("--regen-golden"):
            path.parent.mkdir(parents=True, exist_ok=True)
            Image.fromarray(image).save(path)
            return
        if not path.exists():  # a test that writes its own reference cannot fail: say how to make it
            pytest.fail(f"golden image {path} is missing: write it with "
                        f"`python3 -m pytest {request.node.nodeid} --regen-golden`, look at it, commit it")
        ref = np.asarray(Image.open(path).convert("RGB")).astype(np.float32)
        assert ref.shape == image.shape, f"{name}: size {image.shape} differs from golden {ref.shape}"
        diff = np.abs(ref - image.astype(np.float32))
        mean, p99 = float(diff.mean()), float(np.percentile(diff.max(axis=2), 99))
        if mean > mean_tol or p99 > p99_tol:
            FAILURES.mkdir(exist_ok=True)
            Image.fromarray(image).save(FAILURES / f"{name}_actual.png")
            Image.fromarray(np.clip(diff * 4, 0, 255).astype(np.uint8)).save(FAILURES / f"{name}_diff.png")
            pytest.fail(f"{name}: mean diff {mean:.2f} (tol {mean_tol}), p99 {p99:.1f} (tol {p99_tol}); "
                        f"see {FAILURES}")

    return check


@pytest.fixture(scope="session")
def display():
    """An X display for window tests: the current one, or a private Xvfb."""
    import shutil
    import subprocess

    if os.environ.get("DISPLAY"):
        yield os.environ["DISPLAY"]
        return
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        if os.environ.get("CI"):
            pytest.fail("Xvfb is missing (apt-get install xvfb)")
        pytest.skip("Xvfb not installed")
    read, write = os.pipe()  # Xvfb picks a free display and writes its number here (test workers run side by side)
    proc = subprocess.Popen([xvfb, "-displayfd", str(write), "-screen", "0", "1600x1000x24", "-nolisten", "tcp"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, pass_fds=(write,))
    os.close(write)
    with os.fdopen(read) as f:
        num = f.readline().strip()
    if not num:
        pytest.fail("Xvfb did not start")
    os.environ["DISPLAY"] = f":{num}"
    try:
        yield os.environ["DISPLAY"]
    finally:
        del os.environ["DISPLAY"]
        proc.terminate()
        proc.wait(timeout=10)
