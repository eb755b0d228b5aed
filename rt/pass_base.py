"""Ray-traced passes: each effect asks the frame's backend to trace it into the channels the
frame wants from it (the renderer works those out from the pass graph)."""
from __future__ import annotations

from core.passes import Pass


class RtPass(Pass):
    device = "rt"
    reads = ("gbuffer",)

    def execute(self, frame) -> None:
        wanted = tuple(c for c in self.writes if c in frame.wanted)
        with frame.profiler.cpu(self.name):
            frame.channels.update(frame.backend.trace(self.name, wanted))


class PrimaryPass(Pass):
    """Primary visibility on the backend: from the raster G-buffer read back (when the graph
    runs one) or from primary rays. Every ray-traced effect reads its "gbuffer"."""

    name = "primary"
    device = "rt"
    reads = ("gbuffer_packed",)
    writes = ("gbuffer",)

    def execute(self, frame) -> None:
        packed = frame.channels.get("gbuffer_packed")
        with frame.profiler.cpu("gbuffer_unpack" if packed is not None else "gbuffer_rt"):
            frame.backend.begin_frame(frame.backend_inputs(packed))
        frame.channels["gbuffer"] = frame.backend


class GBufferViewPass(Pass):
    """A G-buffer channel view (the mode's name: albedo, normal, ...) from the backend's primary
    hits (`gbuffer=rt`)."""

    name = "gbuffer_view"
    device = "rt"
    reads = ("gbuffer",)
    writes = ("radiance",)

    def execute(self, frame) -> None:
        frame.channels["radiance"] = frame.backend.gbuffer_view(frame.mode)
