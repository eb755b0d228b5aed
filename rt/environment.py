"""The environment (radiance of rays that miss) as every backend's kernels take it."""
from __future__ import annotations

import numpy as np

from scenes.model import SKY_GROUND, SKY_HORIZON, SKY_ZENITH


def env_args(environment) -> tuple:
    """An environment as kernel arguments (the Embree kernels; common.slang's Environment): kind
    (0 black, 1 constant colour, 2 the analytic sky of scenes/model.py), colour (the sky's
    strength in [0]), and the sky's horizon, zenith and ground colours."""
    kind = {"black": 0, "constant": 1, "sky": 2}[environment.kind]
    color = np.asarray(environment.color if kind == 1 else (environment.strength, 0, 0), np.float32)
    return kind, color, SKY_HORIZON, SKY_ZENITH, SKY_GROUND
