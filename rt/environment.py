"""The environment (radiance of rays that miss) as every backend's kernels take it."""
from __future__ import annotations

import numpy as np

from scenes.model import GRADIENTS

_NO_MAP = np.zeros((1, 1, 3), np.float32)


def env_args(environment) -> tuple:
    """An environment as kernel arguments (the Embree kernels; common.slang's Environment): kind
    (0 black, 1 constant colour, 2 an analytic gradient of scenes/model.py: the sky or the
    studio, 3 an equirectangular map), colour (the gradient's strength in [0]; a map's strength
    and rotation as a shift of u, scenes/model.py equirect_uv, in [0] and [1]), the gradient's
    horizon, zenith and ground colours (the sky's for the kinds without one) and the map's
    texels (H, W, 3) float32 (one black texel for the other kinds)."""
    kind = {"black": 0, "constant": 1, "sky": 2, "studio": 2, "map": 3}[environment.kind]
    if kind == 3:
        color = np.asarray((environment.strength, environment.rotation_u, 0), np.float32)
    else:
        color = np.asarray(environment.color if kind == 1 else (environment.strength, 0, 0), np.float32)
    texels = environment.pixels if kind == 3 else _NO_MAP
    return (kind, color, *GRADIENTS.get(environment.kind, GRADIENTS["sky"]), texels)
