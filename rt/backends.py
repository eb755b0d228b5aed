"""Which ray-tracing backends exist here, picking one (`tracer=auto|embree|vulkan|cuda`), and
making one."""
from __future__ import annotations

from core.errors import UserError
from rt.backend import Backend
from rt.effects import EFFECTS

NAMES = ("embree", "vulkan", "cuda")
CHOICES = ("auto",) + NAMES


def init_process() -> None:
    """Process set-up the backends need before their kernels load (rt/embree/process.py).
    The CLI, the viewer and the tests call it first; create() calls it too."""
    from rt.embree import process

    process.init()


def return_freed_memory() -> None:
    """Give the memory the backends keep for reuse (rt/embree/memory.py) back to the OS: after a
    scene switch, say, when the old scene's arrays were freed."""
    from rt.embree.memory import return_freed_memory as trim

    trim()


# what the first frame of each key compiles on the Embree backend: the ray-traced passes, and the
# ray-traced G-buffer (any pass with gbuffer=rt)
COMPILED_KEYS = (*EFFECTS, "hybrid", "gbuffer=rt")


SHADERS = "shaders:"  # a key of a Slang device's shaders: "shaders:vulkan"


def compile_keys(tracer: str, pass_name: str, gbuffer: str = "raster") -> list[str]:
    """What a first frame of pass_name would compile on this tracer (resolved), by key: the Embree
    kernels it needs, or on a Slang device its shaders where that device's cache is still empty
    (a GPU compiles them in seconds, lavapipe in up to a minute a pipeline)."""
    if tracer != "embree":
        from rt.slang.device import shaders_cached

        traced = pass_name in COMPILED_KEYS or gbuffer == "rt"
        return [SHADERS + tracer] if traced and pass_name != "forward" and not shaders_cached(tracer) else []
    keys = [pass_name] if pass_name in COMPILED_KEYS else []
    return keys + (["gbuffer=rt"] if gbuffer == "rt" and pass_name != "forward" else [])


def compile_notices(keys: list[str]) -> list[str]:
    """For keys whose kernels this version has not compiled yet: what the wait is, and how long it
    took here last time (rt/embree/compile_log.py); for a Slang device's, that it compiles them once."""
    from rt.embree import compile_log

    lines = [f"compiling the {k[len(SHADERS):]} device's shaders (the first time here; slangpy keeps them in "
             f"~/.cache/rtlab/slang/; software Vulkan takes up to a minute a pass)" for k in keys if k.startswith(SHADERS)]
    return lines + compile_log.notices([k for k in keys if not k.startswith(SHADERS)])


def kernels_ready() -> bool:
    """Whether every key's kernels are compiled for this version (the viewer compiles the rest in
    the background when not)."""
    from rt.embree import compile_log

    return set(COMPILED_KEYS) <= compile_log.compiled_keys()


def watch_first_frame(tracer: str, keys: list[str]):
    """A context manager around a first frame: records keys compiled (and the time, if it
    compiled); yields an object whose `compiles` counts the kernels compiled meanwhile."""
    from rt.embree import compile_log

    return compile_log.watch(keys if tracer == "embree" else [])


def record_compile(key: str, seconds: float | None) -> None:
    from rt.embree import compile_log

    compile_log.record(key, seconds)


def compiled_keys() -> set[str]:
    """The keys (COMPILED_KEYS) whose Embree kernels this version has compiled here."""
    from rt.embree import compile_log

    return compile_log.compiled_keys()


def describe_device(kind: str):
    """A Slang device kind's description here (rt/slang/device.py describe: adapter, software),
    or None where this machine has no such device with ray tracing; UserError without slangpy."""
    from rt.slang.device import describe

    return describe(kind)


def oidn_gpu_missing() -> str | None:
    """Why OIDN has no GPU device for the GPU backends here (rt/slang/oidn.py), or None where
    it has one (OIDN's CUDA device: an NVIDIA GPU)."""
    from rt.slang.oidn import missing

    return missing()


def ray_log(capacity: int):
    """A log of the rays a frame traces on Embree (rt/embree/tracer.py RayLog), to set as its
    tracer's `recording` (bench --perf replays it)."""
    from rt.embree.tracer import RayLog

    return RayLog(capacity)


def standalone_tracer(positions, indices):
    """An Embree tracer over bare triangles (no scene around them): bench --perf times its
    acceleration structure's build. close() it when done."""
    init_process()
    from rt.embree.tracer import EmbreeTracer

    return EmbreeTracer(positions, indices)


def pack_rgba_flipped(image, height: int, width: int, channels: int, out) -> None:
    """out (H, W, 4) float32 = image ((H*W, C) float32, top row first) with its rows flipped
    (bottom first, as GL textures): its first `channels` channels (one: grey in r, g, b), the
    others 0 and alpha 1; one compiled pass, for the viewer's uploads of CPU images."""
    from rt.embree.kernels import pack_rgba_flipped as pack

    pack(image, height, width, channels, out)


def available() -> list[dict]:
    """Every backend with what it runs on here: name, device, whether it is available, and
    whether it is hardware (a GPU) or software (the CPU: Embree, lavapipe)."""
    from rt.embree.tracer import default_threads
    from rt.slang.device import describe

    rows = [{"name": "embree", "device": f"CPU, {default_threads()} threads", "available": True, "hardware": False}]
    for kind in ("vulkan", "cuda"):
        try:
            info = describe(kind)
        except UserError as e:  # no slangpy
            rows.append({"name": kind, "device": str(e), "available": False, "hardware": False})
            continue
        rows.append({"name": kind, "device": info.adapter if info else "no device with ray tracing",
                     "available": info is not None, "hardware": bool(info and not info.software)})
    return rows


def resolve(name: str) -> str:
    """The backend a tracer option names: `auto` is a GPU with ray tracing (CUDA/OptiX, else
    Vulkan) if this machine has one, else Embree."""
    if name not in CHOICES:
        raise UserError(f"tracer: {name!r} is not one of {', '.join(CHOICES)}")
    if name != "auto":
        return name
    from rt.slang.device import describe

    for kind in ("cuda", "vulkan"):
        try:
            info = describe(kind)
        except UserError:
            return "embree"
        if info is not None and not info.software:
            return kind
    return "embree"


def create(name: str = "embree", **kwargs) -> Backend:
    """A backend by name (resolved: not `auto`), without a scene yet (Backend.set_scene)."""
    if name == "embree":
        init_process()
        from rt.embree.backend import EmbreeBackend

        return EmbreeBackend(**kwargs)
    if name in ("vulkan", "cuda"):
        from rt.slang.backend import SlangBackend

        return SlangBackend(name)
    raise UserError(f"unknown ray-tracing backend {name!r}; available: {', '.join(NAMES)}")
