"""Open Image Denoise's options (`denoise=oidn`) and what one frame's filter runs with, on the
CPU (app/raster/oidn.py, through pyoidn) or on a ray-tracing backend's GPU (Backend.present: OIDN's
CUDA device, rt/slang/oidn.py), where the denoised image is shown without leaving the device."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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
    ggx: bool = False  # surfaces shade with glTF's BRDF: OIDN's albedo is their diffuse plus specular albedo


def oidn_frame(mode: str, options, scene=None) -> OidnFrame:
    ggx = scene is not None and scene.uses_ggx(options.get("brdf"))
    return OidnFrame(str(options.group("oidn").quality), *radiance_terms(mode, options), ggx)


def specular_albedo(base: np.ndarray, metallic: np.ndarray, roughness: np.ndarray, nv: np.ndarray) -> np.ndarray:
    """The GGX lobe's directional albedo F0 A + B (Karis's fit of the split sum's scale and bias;
    shaders/rt/common.slang and svgf_common.glsl have the same) of (..., 3) base colours, metallic,
    perceptual roughness and n.v (...)."""
    r = roughness[..., None]
    k = r * np.array([-1.0, -0.0275, -0.572, 0.022], np.float32) + np.array([1.0, 0.0425, 1.04, -0.04], np.float32)
    a004 = np.minimum(k[..., 0] ** 2, np.exp2(-9.28 * nv)) * k[..., 0] + k[..., 1]
    scale, bias = -1.04 * a004 + k[..., 2], 1.04 * a004 + k[..., 3]
    f0 = 0.04 * (1.0 - metallic[..., None]) + base * metallic[..., None]
    return (f0 * scale[..., None] + bias[..., None]).astype(np.float32)


def glossy_albedo(base: np.ndarray, metallic, roughness, nv) -> np.ndarray:
    """OIDN's albedo image under glTF's BRDF: the diffuse albedo plus the specular one (OIDN's
    advice for glossy surfaces), clamped to [0, 1] (shaders/rt/oidn.slang)."""
    base = base * (1.0 - metallic[..., None]) + specular_albedo(base, metallic, roughness, nv)
    return np.clip(base, 0.0, 1.0)
