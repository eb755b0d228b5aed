"""Open Image Denoise's options (`denoise=oidn`) and what one frame's filter runs with, on the
CPU (app/raster/oidn.py, through pyoidn) or on a ray-tracing backend's GPU (Backend.present: OIDN's
CUDA device, rt/slang/oidn.py), where the denoised image is shown without leaving the device."""
from __future__ import annotations

from dataclasses import dataclass

from core.options import opt, register_group
from rt.effects import radiance_terms


@dataclass
class OidnOptions:
    quality: str = opt("high", "OIDN's filter quality (fast is several times quicker, a little softer)",
                       choices=("high", "balanced", "fast"))
    device: bool = opt(True, "denoise on the ray-tracing backend's GPU where OIDN has a device for it (its CUDA "
                       "device: NVIDIA GPUs; the image stays there); false, on embree or without one: on the CPU")


register_group("oidn", OidnOptions)


@dataclass(frozen=True)
class OidnFrame:
    """What one frame's filter runs with (the GL pass, or Backend.present on a GPU)."""

    quality: str  # high, balanced or fast
    has_albedo: bool  # the radiance holds the first hit's albedo as a factor (RtPass.radiance_terms): OIDN's guide
    has_emission: bool  # and its emission, which bypasses the filter


def oidn_frame(mode: str, options) -> OidnFrame:
    return OidnFrame(str(options.group("oidn").quality), *radiance_terms(mode, options))
