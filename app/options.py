"""Options as data: one dataclass per pass, addressed by `group.key=value` strings.

The same keys come from `--set`, the viewer's panel and benchmark result files. Values out
of range are refused (never silently clamped) so a typo cannot produce a misleading result.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from app.errors import UserError

TRUE = {"1", "true", "yes", "on"}
FALSE = {"0", "false", "no", "off"}


def opt(default, help: str, lo=None, hi=None, choices=None):
    return field(default=default, metadata={"help": help, "lo": lo, "hi": hi, "choices": choices})


@dataclass
class GlobalOptions:
    accumulate: bool = opt(True, "average frames while nothing changes")
    max_frames: int = opt(0, "stop accumulating after this many frames (0 = never)", 0, 1_000_000)
    gbuffer: str = opt("raster", "G-buffer source: raster (GPU) or rt (primary rays)", choices=("raster", "rt"))
    exposure: float = opt(1.0, "exposure multiplier before tone mapping", 1e-6, 1e6)
    env: str = opt("scene", "radiance of rays that miss: scene, black, sky or R,G,B")


@dataclass
class ForwardOptions:
    shadow_maps: bool = opt(True, "shadow maps for the sun and the strongest point/spot lights")
    shadow_map_size: int = opt(2048, "sun shadow map resolution (texels)", 256, 8192)
    pcf_radius: int = opt(2, "PCF kernel half-width in texels (0 = hard shadows)", 0, 8)
    point_shadow_budget: int = opt(4, "how many point/spot lights get cube shadow maps", 0, 32)
    point_shadow_size: int = opt(512, "cube shadow map face resolution (texels)", 64, 4096)
    ssao: bool = opt(True, "screen-space ambient occlusion on the ambient term")
    ssao_radius: float = opt(0.5, "SSAO hemisphere radius (m)", 0.01, 100.0)
    ssao_samples: int = opt(16, "SSAO kernel samples per pixel", 1, 64)
    ssao_blur: bool = opt(True, "4x4 blur of the SSAO result")
    env_reflections: bool = opt(True, "environment cube map reflections on smooth surfaces")
    roughness_threshold: float = opt(0.25, "env reflections on surfaces smoother than this", 0.0, 1.0)
    ambient: float = opt(1.0, "scale of the ambient term (environment + the scene's ambient hint)", 0.0, 100.0)
    emissive_lights: bool = opt(True, "light from emissive surfaces through proxy point lights")
    fxaa: bool = opt(True, "FXAA after tone mapping")


GROUPS: dict[str, type] = {"": GlobalOptions, "forward": ForwardOptions}


def register_group(name: str, cls: type) -> None:
    """Passes register their option dataclass under their name (e.g. 'ao')."""
    GROUPS[name] = cls


def _parse_value(key: str, f: dataclasses.Field, text: str):
    meta = f.metadata
    kind = type(f.default)
    t = text.strip()
    if kind is bool:
        if t.lower() in TRUE:
            return True
        if t.lower() in FALSE:
            return False
        raise UserError(f"{key}: expected true or false, got {text!r}")
    if kind in (int, float):
        try:
            v = kind(float(t)) if kind is float else int(t)
        except ValueError:
            raise UserError(f"{key}: expected {'an integer' if kind is int else 'a number'}, got {text!r}") from None
        if v != v or v in (float("inf"), float("-inf")):
            raise UserError(f"{key}: expected a finite number, got {text!r}")
        lo, hi = meta.get("lo"), meta.get("hi")
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            raise UserError(f"{key}={t} is out of range; allowed {lo}..{hi}")
        return v
    choices = meta.get("choices")
    if choices and t not in choices:
        raise UserError(f"{key}: {text!r} is not one of {', '.join(choices)}")
    if key == "env" and t != "scene":
        from scenes.model import Environment

        Environment.parse(t)  # validates
    return t


class Options:
    """All option groups of a session, addressed by flat keys."""

    def __init__(self):
        from app.passes import register_all_options

        register_all_options()
        self.groups = {name: cls() for name, cls in GROUPS.items()}

    def _field(self, key: str):
        group, _, name = key.rpartition(".")
        obj = self.groups.get(group)
        fields = {f.name: f for f in dataclasses.fields(obj)} if obj is not None else {}
        if name not in fields:
            raise UserError(f"unknown option {key!r}; valid keys: {', '.join(self.keys())}")
        return obj, fields[name]

    def keys(self) -> list[str]:
        out = []
        for group, obj in self.groups.items():
            out += [f"{group}.{f.name}" if group else f.name for f in dataclasses.fields(obj)]
        return out

    def get(self, key: str):
        obj, f = self._field(key)
        return getattr(obj, f.name)

    def set(self, key: str, value) -> bool:
        """Set from a string or a typed value; returns True if the value changed."""
        obj, f = self._field(key)
        new = _parse_value(key, f, value) if isinstance(value, str) else _parse_value(key, f, _fmt(value))
        changed = getattr(obj, f.name) != new
        setattr(obj, f.name, new)
        return changed

    def apply(self, assignments: list[str]) -> None:
        for a in assignments:
            key, eq, value = a.partition("=")
            if not eq:
                raise UserError(f"--set expects KEY=VALUE, got {a!r}")
            self.set(key.strip(), value)

    def spec(self, key: str) -> dict:
        _, f = self._field(key)
        return {"key": key, "default": f.default, **f.metadata}

    def as_dict(self) -> dict:
        return {k: self.get(k) for k in self.keys()}

    def state(self) -> tuple:
        """Hashable snapshot; a change means the frame is dirty."""
        return tuple(sorted(self.as_dict().items()))

    def group(self, name: str):
        return self.groups[name]


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    return str(v)
