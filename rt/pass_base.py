"""Ray-traced passes: each effect asks the frame's backend to trace it into the channels the
frame wants from it (the renderer works those out from the pass graph)."""
from __future__ import annotations

from core.passes import Pass

# the first hit's specular radiance (with glTF's BRDF: the GGX lobe's part of the radiance, emission
# left out), which the passes that shade with both lobes write besides radiance when a denoiser
# asks: SVGF filters it apart from the diffuse part, each over its own albedo (rt/svgf.py)
SPECULAR = "rt_specular"


class RtPass(Pass):
    """A ray-traced effect, and its record (rt/effects.py collects them): name, options, writes
    ("radiance" and its own image, the aux channel, where it has one), and what the backends
    take from here rather than from tables of their own: its random stream (rt/keys.key_base;
    each effect draws its own numbers, the same on every backend), its own image's channels
    and its parameters (how its options reach the kernels and shaders)."""

    device = "rt"
    reads = ("gbuffer",)
    stream = 0  # its random stream: every effect's differs
    aux_channels = 1  # channels of its own image (or of the unused one, where it has none)
    lights = True  # it samples the scene's lights (its shader declares g_lights, g_far, g_ggx)
    svgf_iterations = 3  # SVGF's a-trous iterations for it unless option svgf.iterations says (rt/svgf.py)

    @classmethod
    def parameters(cls, opts) -> dict:
        """Its options as the parameters its kernels and shaders take, by name: the Embree
        kernels' arguments, the Slang shader's uniforms `g_<name>` (a flag as 0 or 1)."""
        return {}

    @classmethod
    def radiance_terms(cls, opts) -> tuple[bool, bool]:
        """What its radiance holds of the first hit's material: (its albedo as a factor, its
        emission added): what a denoiser takes out before it filters the lighting and puts back
        after (rt/svgf.py). Most effects' radiance is shaded light: both."""
        return True, True

    @classmethod
    def aux(cls) -> str | None:
        """Its own image's channel: what it writes besides radiance (and its specular part)."""
        return next((c for c in cls.writes if c not in ("radiance", SPECULAR)), None)

    @classmethod
    def splits_specular(cls, opts, scene) -> bool:
        """Whether its radiance has a specular part that it writes apart (SPECULAR) this frame:
        where it does, the scene shades with glTF's BRDF (option brdf), the radiance holds the
        material (not the light alone) and SVGF is to filter the part apart (svgf.split)."""
        return (SPECULAR in cls.writes and bool(opts.get("svgf.split")) and scene.uses_ggx(opts.get("brdf"))
                and cls.radiance_terms(opts)[0])

    def execute(self, frame) -> None:
        # its specular part only where it is the frame's image and comes apart (SVGF reads it if there)
        split = frame.mode == self.name and self.splits_specular(frame.options, frame.scene)
        wanted = tuple(c for c in self.writes if c in frame.wanted and (c != SPECULAR or split))
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
