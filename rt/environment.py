"""The environment (radiance of rays that miss) as every backend's kernels take it."""
from __future__ import annotations

import numpy as np

from scenes.model import GRADIENTS


def env_args(environment) -> tuple:
    """An environment as kernel arguments (the Embree kernels; common.slang's Environment): kind
    (0 black, 1 constant colour, 2 an analytic gradient of scenes/model.py: the sky or the
    studio), colour (the gradient's strength in [0]), and the gradient's horizon, zenith and
    ground colours (the sky's for the kinds without one)."""
    kind = {"black": 0, "constant": 1, "sky": 2, "studio": 2}[environment.kind]
    color = np.asarray(environment.color if kind == 1 else (environment.strength, 0, 0), np.float32)
    return (kind, color, *GRADIENTS.get(environment.kind, GRADIENTS["sky"]))
