"""The pass contract (Falcor's RenderPass, in Python), shared by raster and ray-traced passes.

A pass declares its options dataclass (registered under its name in core.options), the
channels it reads and writes (the renderer wires the frame from them and decides what to
read back from one device or upload to another), and where it runs: "gl" (on the GL thread)
or "rt" (on a ray-tracing backend, off the GL thread). `execute(frame)` reads its inputs from
frame.channels and writes its outputs there; `reset()` drops temporal state; `set_scene(scene)`
reacts to a new scene."""
from __future__ import annotations


class Pass:
    name = ""
    options: type | None = None  # its options dataclass, registered under `name`
    option_groups: tuple[str, ...] = ()  # other groups the panel shows with this pass
    reads: tuple[str, ...] = ()  # channels it reads (optional ones too: a pass checks frame.channels)
    writes: tuple[str, ...] = ()  # channels it writes
    device = "gl"  # "gl": runs on the GL thread; "rt": runs on the ray-tracing backend

    def set_scene(self, scene) -> None:
        pass

    def execute(self, frame) -> None:
        raise NotImplementedError

    def reset(self) -> None:
        pass

    def release(self) -> None:
        pass
