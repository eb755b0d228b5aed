"""The frame-wide options (group ""), and the old spelling of the options registry.

`Options()` from here holds every pass's group: importing this module loads the passes
(app/passes.py), which register their option dataclasses in core.options."""
from __future__ import annotations

from dataclasses import dataclass

from core.options import FALSE, GROUPS, TRUE, opt, register_group  # noqa: F401  (the old spelling)
from rt.backends import CHOICES
from scenes.loaders.envmap import parse_env


def _check_env(text: str) -> None:
    if text != "scene":
        parse_env(text)


@dataclass
class GlobalOptions:
    accumulate: bool = opt(True, "average frames while nothing changes")
    max_frames: int = opt(0, "stop accumulating after this many frames (0 = never)", 0, 1_000_000)
    reproject: bool = opt(False, "accumulation survives camera motion: each pixel's mean follows its point through "
                          "the motion vectors, restarting where the surface changes (false: the study's restart "
                          "on any motion)")
    jitter: bool = opt(True, "while accumulating, sample a different point of each pixel every frame (Halton 2,3), "
                       "so the average is the pixel's box-filtered image (antialiased edges)")
    denoise: str = opt("off", "denoiser of the ray-traced modes' image: svgf (spatio-temporal variance-guided "
                       "filtering, GL shaders, before accumulation) or oidn (Intel Open Image Denoise on the CPU, "
                       "of the image shown)", choices=("off", "svgf", "oidn"))
    gbuffer: str = opt("auto", "G-buffer source of the ray-traced passes: raster (OpenGL), rt (primary rays on the "
                       "tracer) or auto (rt where Embree traces and OpenGL is a CPU rasteriser, which draws it slower "
                       "than rays find it, unless a denoiser or reproject rasterises one anyway; else raster)",
                       choices=("auto", "raster", "rt"))
    finish: str = opt("auto", "where a ray-traced frame's accumulation and tone mapping run: tracer (on the ray "
                      "tracer's device, so that only the 8-bit image goes to GL), gl (OpenGL's shaders) or auto (the "
                      "GPU backends' device; Embree's threads where OpenGL is a CPU rasteriser, whose two full-screen "
                      "passes and float upload cost more; else gl)", choices=("auto", "tracer", "gl"))
    exposure: float = opt(1.0, "exposure multiplier before tone mapping", 1e-6, 1e6)
    env: str = opt("scene", "radiance of rays that miss: scene (the file's; the studio for files with no "
                     "lights), black, sky, studio, R,G,B or an equirectangular map of linear radiance "
                     "(.hdr or .exr file)", check=_check_env)
    brdf: str = opt("auto", "surface model: lambert (the study's: Lambert diffuse, mirror reflections), ggx "
                    "(glTF's metal-rough: Lambert + GGX specular) or auto (glTF files ggx, others lambert)",
                    choices=("auto", "lambert", "ggx"))
    tracer: str = opt("embree", "ray-tracing backend: embree (CPU), vulkan or cuda (Slang on a GPU, or Vulkan "
                      "on lavapipe without one), auto (a GPU with ray tracing if there is one, else embree)",
                      choices=CHOICES)
    interop: str = opt("auto", "how GL and a GPU ray-tracing device exchange the G-buffer and images: auto (memory "
                       "both share, where the drivers can; else copies through host memory) or copy (always copies)",
                       choices=("auto", "copy"))
    frames_in_flight: int = opt(2, "frames a GPU backend works on at once: 2 shows each frame's image while the "
                                "device makes the next (one frame late, no wait for the device between frames), "
                                "1 waits for every frame before showing it", 1, 2)


register_group("", GlobalOptions)


@dataclass
class EnvOptions:
    intensity: float = opt(1.0, "scale of the environment's radiance (option env), in every pass", 0.0, 1000.0)
    rotation: float = opt(0.0, "turn of an environment map about the vertical axis (degrees)", -360.0, 360.0)


register_group("env", EnvOptions)


@dataclass
class TextureOptions:
    max_size: int = opt(0, "longest side of a texture in the renderer, when GPU or host memory is short: larger "
                        "ones are box-filtered down to it in every pass and backend (0: as loaded, at most 1024)",
                        0, 1024)


register_group("textures", TextureOptions)

import app.passes  # noqa: E402, F401  (registers every pass's options after the global ones)
from core.options import Options  # noqa: E402, F401
