"""The bench's configurations: each a pass and its options, and what of it is measured (the
timed frames, the quality of its effect in the forward frame, denoised variants, the camera
path's configuration)."""
from __future__ import annotations

from core.errors import UserError
from rt.effects import EFFECTS
from rt.hybrid import EFFECTS as HYBRID_EFFECTS

# name: (pass, options); ray-traced ones also run as NAME+acc with accumulation on, and the
# one-sample ones as NAME+svgf and NAME+oidn: each frame denoised, without accumulation
CONFIGS = {
    "forward": ("forward", []),
    "reflections": ("reflections", []),
    "shadows_all": ("shadows", ["shadows.lights=all"]),
    "shadows_one": ("shadows", ["shadows.lights=one"]),
    "gi_1": ("gi", ["gi.rays_per_pixel=1", "gi.shadows=false"]),
    "gi_4": ("gi", ["gi.rays_per_pixel=4", "gi.shadows=false"]),
    "gi_shadows": ("gi", ["gi.rays_per_pixel=1", "gi.shadows=true"]),
    "ao_1": ("ao", ["ao.rays_per_pixel=1"]),
    "ao_4": ("ao", ["ao.rays_per_pixel=4"]),
    "hybrid": ("hybrid", []),
    "hybrid_gi": ("hybrid", ["hybrid.gi=true"]),  # RT shadows and RT GI (one ray a pixel) in the forward frame
}
HYBRID_EFFECT = {"reflections": "reflections", "shadows_all": "shadows", "shadows_one": "shadows", "gi_1": "gi",
                 "gi_4": "gi", "gi_shadows": "gi", "ao_1": "ao", "ao_4": "ao"}
DENOISERS = ("svgf", "oidn")
# profiler entries that move images between GL, the host and a ray-tracing device
TRANSFERS = ("gbuffer_readback", "gbuffer_share", "device_readback", "upload", "share")
DENOISED = ("gi_1", "gi_shadows", "ao_1", "shadows_one")
FLICKER_FRAMES = 8  # a denoised configuration's flicker: over its last 8 frames shown (still camera)
DENOISE_FRAMES = 16  # a denoised configuration's image: its 16th frame (SVGF's history fills), against 16 accumulated
# the raw frames accumulated that each denoiser's image is held against: SVGF's 16th frame (its
# history holds 16 frames' samples) against 16, OIDN's single frame against 4 (issue 38's targets)
DENOISE_MATCH = {"svgf": DENOISE_FRAMES, "oidn": 4}
RAW_FRAMES = tuple(sorted({1, *DENOISE_MATCH.values()}))  # the raw images a denoised configuration measures
ALL_CONFIGS = (list(CONFIGS) + [f"{c}+acc" for c in CONFIGS if c != "forward"]
               + [f"{c}+{d}" for c in DENOISED for d in DENOISERS])
DEFAULT_SCENES = ("arcade", "street", "cafe", "park", "temple")


def parse_configs(text: str | None) -> list[str]:
    if not text:
        return ALL_CONFIGS
    out = []
    for name in (c.strip() for c in text.split(",")):
        if name not in ALL_CONFIGS:
            raise UserError(f"--configs: unknown configuration {name!r}; choose from {', '.join(ALL_CONFIGS)}")
        out.append(name)
    if "forward" not in out:
        out.insert(0, "forward")  # every cost is relative to the forward baseline
    return out


def config_options(config: str) -> tuple[str, list[str]]:
    base, _, suffix = config.partition("+")
    pass_name, sets = CONFIGS[base]
    if suffix in DENOISERS:
        return pass_name, sets + ["accumulate=false", f"denoise={suffix}"]
    return pass_name, sets + [f"accumulate={'true' if suffix else 'false'}"]


def quality_options(config: str) -> list[str]:
    """The forward renderer with only this configuration's effect ray traced."""
    base = config.partition("+")[0]
    _, sets = CONFIGS[base]
    if base.startswith("hybrid"):
        return list(sets)
    effect = HYBRID_EFFECT[base]
    return sets + [f"hybrid.{e}={'true' if e == effect else 'false'}" for e in HYBRID_EFFECTS]


PATH_CONFIG = "gi_1"  # the configuration flown along the camera path (PATH_VARIANTS: accumulated, denoised)
PATH_CHECKS = 4  # frames of the path compared with their converged image (the last one among them)
PATH_VARIANTS = {"restart": ["accumulate=true", "reproject=false"], "reproject": ["accumulate=true", "reproject=true"],
                 "svgf": ["accumulate=false", "denoise=svgf"]}


# a frame's split by what its passes do (profiler entries by name; a ray-traced effect's pass is
# its rays and their shading together: `bench --perf` tells the trace from the rest)
SPLIT = {"G-buffer": ("gbuffer", "gbuffer_pack", "gbuffer_readback", "gbuffer_unpack", "gbuffer_share",
                      "gbuffer_rt"),
         "raster lighting": ("shadow_maps", "ssao", "forward_lighting"),
         "denoise": ("svgf", "oidn"),
         "finish": ("accumulation", "reproject", "tonemap", "fxaa", "display", "present", "upload", "device_readback",
                    "share", "counters")}


def frame_split(passes_ms: dict, frame_ms: float, kinds: dict | None = None) -> dict:
    """A frame's time by part: the G-buffer, the ray-traced effects, the raster lighting, the
    denoiser, the finish (accumulation, tone mapping, display and the copies that show it),
    other passes, and the host's time beyond them all (Python, waits; negative where GL's
    timed work overlapped the host's). On the CPU (Embree) every pass's time counts; with a
    device backend (its passes timed on the device as NAME_gpu) the parts are GPU time, GL's
    and the device's, and the host's recording, copies and waits are what lies beyond them."""
    part_of = {name: part for part, names in SPLIT.items() for name in names}
    part_of["primary"] = "G-buffer"  # a device backend's primary hits
    device = any(name.endswith("_gpu") for name in passes_ms)
    out = {"G-buffer": 0.0, "ray traced": 0.0, "raster lighting": 0.0, "denoise": 0.0, "finish": 0.0, "other": 0.0}
    for name, ms in passes_ms.items():
        if device and (kinds or {}).get(name) != "gpu":
            continue
        name = name.removesuffix("_gpu")
        out["ray traced" if name in EFFECTS else part_of.get(name, "other")] += ms
    out["host beyond"] = frame_ms - sum(out.values())
    return out
