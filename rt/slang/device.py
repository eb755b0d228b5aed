"""Which Slang devices this machine has, and opening one (once per process and kind)."""
from __future__ import annotations

import os
import sys
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from core.cache import cache_root
from core.errors import UserError

SHADER_DIR = Path(__file__).resolve().parent.parent.parent / "shaders" / "rt"
KINDS = ("vulkan", "cuda")
SOFTWARE = ("llvmpipe", "lavapipe", "swiftshader")  # adapter names of CPU implementations

_devices: dict = {}  # kind -> slangpy.Device or the error that opening it gave


@dataclass
class DeviceInfo:
    kind: str  # vulkan or cuda
    adapter: str
    ray_tracing: bool
    software: bool  # a CPU implementation (lavapipe): fine for tests, not for speed


def _slangpy():
    if "slangpy" not in sys.modules:
        # slangpy imports PyTorch when it is installed (4.2 s of a 4.3 s import on the H200
        # machine) for tensor interop that rtlab never uses: import it as if PyTorch were absent
        sys.modules.setdefault("torch", None)  # None: an import of torch raises ImportError meanwhile
    try:
        import slangpy
    except ImportError as e:
        raise UserError(f"the Slang backends need the slangpy package ({e}); pip install slangpy==0.43.1") from None
    finally:
        if sys.modules.get("torch", 0) is None:
            del sys.modules["torch"]
    # a device that cannot be opened is reported as one line of ours, not slangpy's log lines
    slangpy.Logger.get().level = slangpy.LogLevel.fatal
    return slangpy


@contextmanager
def _quiet():
    """The C library's own lines (a missing CUDA driver prints one) kept off the terminal: the
    caller reports the outcome in one line."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        os.dup2(null, 2)
        yield
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, null):
            os.close(fd)


def _cache_dir(kind: str) -> Path:
    """slangpy's module and shader caches for a device kind, beside the Embree kernels' cache."""
    return cache_root() / "slang" / kind


def shaders_cached(kind: str) -> bool:
    """Whether slangpy's shader cache for this device kind holds anything yet (a first frame
    compiles the shaders it lacks)."""
    folder = _cache_dir(kind) / "shaders"
    try:
        return any(folder.iterdir())
    except OSError:
        return False


def open_device(kind: str):
    """The process's slangpy device of this kind, opened on first use; UserError if there is none."""
    if kind not in KINDS:
        raise UserError(f"unknown Slang device kind {kind!r}; choose one of {', '.join(KINDS)}")
    found = _devices.get(kind)
    if found is None:
        spy = _slangpy()
        try:
            # fast floating point: NVRTC's approximate division, square root and transcendentals,
            # as NVIDIA's Vulkan compiler already uses (report/HISTORY.md: what it saves on CUDA)
            options = spy.SlangCompilerOptions({"include_paths": [str(SHADER_DIR)],
                                                "floating_point_mode": spy.SlangFloatingPointMode.fast})
            device_type = spy.DeviceType.vulkan if kind == "vulkan" else spy.DeviceType.cuda
            cache = _cache_dir(kind)
            # an index into this kind's adapters: bench --cluster gives each GPU task of a node with
            # several GPUs its own (CUDA needs none: Ray narrows CUDA_VISIBLE_DEVICES to the task's)
            chosen = os.environ.get("RTLAB_ADAPTER")
            luid = None
            if chosen and kind == "vulkan":
                adapters = spy.Device.enumerate_adapters(device_type)
                luid = adapters[int(chosen) % len(adapters)].luid if adapters else None
            with _quiet():
                # compiled modules and pipelines are cached on disk: a process after the first
                # does not compile the shaders again (rtlab warmup fills the cache)
                found = spy.Device(type=device_type, enable_rhi_validation=False, compiler_options=options,
                                   enable_hot_reload=False, adapter_luid=luid, module_cache_path=str(cache / "modules"),
                                   shader_cache_path=str(cache / "shaders"))
            if not found.has_feature(spy.Feature.ray_tracing):
                found = UserError(f"the {kind} device ({found.info.adapter_name}) has no ray tracing")
        except UserError:
            raise
        except Exception as e:  # no driver, no GPU: slangpy raises its own RuntimeError
            hint = (" (install Mesa's Vulkan drivers with ray tracing: mesa-vulkan-drivers from "
                    "bookworm-backports, see scripts/setup.sh)" if kind == "vulkan" else " (needs an NVIDIA GPU)")
            found = UserError(f"no {kind} device with ray tracing here{hint}: {str(e).splitlines()[0][:160]}")
        _devices[kind] = found
    if isinstance(found, UserError):
        raise found
    return found


def describe(kind: str) -> DeviceInfo | None:
    """The device of this kind, or None where there is none."""
    try:
        device = open_device(kind)
    except UserError:
        return None
    name = device.info.adapter_name
    return DeviceInfo(kind, name, True, any(s in name.lower() for s in SOFTWARE))
