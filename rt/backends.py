"""Which ray-tracing backends exist, and making one."""
from __future__ import annotations

from core.errors import UserError
from rt.backend import Backend

NAMES = ("embree",)


def init_process() -> None:
    """Process set-up the backends need before their kernels load (rt/embree/process.py).
    The CLI, the viewer and the tests call it first; create() calls it too."""
    from rt.embree import process

    process.init()


def create(name: str = "embree", **kwargs) -> Backend:
    """A backend by name, without a scene yet (Backend.set_scene)."""
    if name == "embree":
        init_process()
        from rt.embree.backend import EmbreeBackend

        return EmbreeBackend(**kwargs)
    raise UserError(f"unknown ray-tracing backend {name!r}; available: {', '.join(NAMES)}")
