"""Pass names of the CLI contract and what each one is."""
from app.raster.channel_view import CHANNEL_VIEWS

RASTER = ("forward",)
RAY_TRACED = ("shadows", "reflections", "gi", "ao", "hybrid", "reference")
ALL = RASTER + RAY_TRACED + CHANNEL_VIEWS
AVAILABLE = RASTER + CHANNEL_VIEWS  # ray-traced passes arrive with the tracer


def check_pass(name: str) -> str:
    from app.errors import UserError

    if name not in ALL:
        raise UserError(f"unknown pass {name!r}; choose one of {', '.join(ALL)}")
    if name not in AVAILABLE:
        raise UserError(f"pass {name!r} needs the Embree ray tracer, which this build does not have yet; "
                        f"available: {', '.join(AVAILABLE)}")
    return name
