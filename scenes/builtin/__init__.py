"""The five archetype scenes, generated deterministically in code.

A scene name may carry a detail level: `park:4`. Detail scales the triangle count.
"""
from __future__ import annotations

from core.errors import UserError
from scenes.builtin import arcade, cafe, park, street, temple

BUILTINS = {
    "arcade": (arcade.build, "sparse indoor arcade, a few point lights"),
    "street": (street.build, "outdoor urban street, sun, mirror-like shop windows"),
    "cafe": (cafe.build, "cluttered indoor café lit only by emissive surfaces"),
    "park": (park.build, "open outdoor square, sun, trees with dense foliage"),
    "temple": (temple.build, "marble temple hall, many small point lights"),
}
MAX_DETAIL = 5
DEFAULT_SCENE = "arcade"


def split_name(spec: str) -> tuple[str, int]:
    name, _, level = spec.partition(":")
    if not level:
        return name, 1
    try:
        detail = int(level)
    except ValueError:
        raise UserError(f"scene detail must be an integer 1..{MAX_DETAIL}: {spec!r}") from None
    if not 1 <= detail <= MAX_DETAIL:
        raise UserError(f"scene detail must be 1..{MAX_DETAIL}: {spec!r}")
    return name, detail


def is_builtin(spec: str) -> bool:
    return spec.partition(":")[0] in BUILTINS


def build_builtin(spec: str):
    name, detail = split_name(spec)
    if name not in BUILTINS:
        raise UserError(f"unknown built-in scene {name!r}; choose one of {', '.join(BUILTINS)}")
    scene = BUILTINS[name][0](detail)
    if detail > 1:
        scene.name = f"{name}:{detail}"
    return scene
