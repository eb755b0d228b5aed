"""Pass names of the CLI contract and the ray-traced pass objects."""
from app.errors import UserError
from app.raster.channel_view import CHANNEL_VIEWS

RASTER = ("forward",)
RAY_TRACED = ("shadows", "reflections", "gi", "ao", "hybrid", "reference")
ALL = RASTER + RAY_TRACED + CHANNEL_VIEWS


def RT_PASSES() -> dict:
    """One object per CPU ray-traced pass (hybrid is composed by the renderer)."""
    from rt.ao import AOPass
    from rt.gi import GIPass
    from rt.reference import ReferencePass
    from rt.reflections import ReflectionsPass
    from rt.shadows import ShadowsPass

    return {p.name: p for p in (ShadowsPass(), ReflectionsPass(), GIPass(), AOPass(), ReferencePass())}


def register_all_options() -> None:
    """Import the passes so their option groups exist (they register on import)."""
    RT_PASSES()
    import rt.hybrid  # noqa: F401


def check_pass(name: str) -> str:
    if name not in ALL:
        raise UserError(f"unknown pass {name!r}; choose one of {', '.join(ALL)}")
    return name
