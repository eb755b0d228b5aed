"""Options as data: one dataclass per pass, addressed by `group.key=value` strings.

The registry of option groups lives here, in the bottom layer: passes (rt/, app/raster/)
register their dataclass, and every layer reads options without importing the app.

The same keys come from `--set`, the viewer's panel and benchmark result files. Values out
of range are refused (never silently clamped) so a typo cannot produce a misleading result.
"""
from __future__ import annotations

import dataclasses
import functools
from dataclasses import field

from core.errors import UserError

TRUE = {"1", "true", "yes", "on"}
FALSE = {"0", "false", "no", "off"}


def opt(default, help: str, lo=None, hi=None, choices=None, check=None):
    """An option field: its default, a line of help (the panel's tooltip), a range or the allowed
    choices, and check(text), which raises UserError for a value of the right type that is still
    wrong (a malformed colour, say)."""
    return field(default=default, metadata={"help": help, "lo": lo, "hi": hi, "choices": choices, "check": check})


GROUPS: dict[str, type] = {}  # group name -> options dataclass, in registration order


def register_group(name: str, cls: type) -> None:
    """Passes register their option dataclass under their name (e.g. 'ao') when their module
    is imported; the layer that assembles the passes imports them all (app/passes.py)."""
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
    if meta.get("check"):
        meta["check"](t)
    return t


@functools.lru_cache(maxsize=None)
def _fields_of(cls) -> dict:
    """An options dataclass's fields by name (looked up for every option read: once per class)."""
    return {f.name: f for f in dataclasses.fields(cls)}


class Options:
    """All option groups of a session, addressed by flat keys."""

    def __init__(self, groups: dict[str, type] | None = None):
        """groups: name -> options dataclass; default: every group registered so far."""
        self.groups = {name: cls() for name, cls in (GROUPS if groups is None else groups).items()}

    def _field(self, key: str):
        group, _, name = key.rpartition(".")
        obj = self.groups.get(group)
        fields = _fields_of(type(obj)) if obj is not None else {}
        if name not in fields:
            raise UserError(f"unknown option {key!r}; valid keys: {', '.join(self.keys())}")
        return obj, fields[name]

    def keys(self) -> list[str]:
        return [f"{group}.{name}" if group else name for group, obj in self.groups.items()
                for name in _fields_of(type(obj))]

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
        return {f"{group}.{name}" if group else name: getattr(obj, name)
                for group, obj in self.groups.items() for name in _fields_of(type(obj))}

    def state(self) -> tuple:
        """Hashable snapshot; a change means the frame is dirty."""
        return tuple(sorted(self.as_dict().items()))

    def group(self, name: str):
        return self.groups[name]


def _fmt(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    return str(v)
