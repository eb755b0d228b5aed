"""The raster light list: analytic lights plus emissive proxies, with shadow-map slots.

Shadow budget (like real engines): the sun always gets the view-fitted map; of the point,
spot and proxy lights, the `forward.point_shadow_budget` strongest as seen from the camera
(intensity / (distance^2 + 1)) get cube shadow maps; the rest are unshadowed.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.raster.gpu_scene import KIND, MAX_LIGHTS


@dataclass
class RasterLight:
    kind: str
    position: np.ndarray
    direction: np.ndarray
    radiance: np.ndarray  # W/sr or W/m^2 per channel
    lobe: float = 0.0
    cos_outer: float = -1.0
    cos_inner: float = 1.0
    slot: int = -1
    near: float = 0.05
    far: float = 100.0


def gather_lights(scene, gpu_scene, use_proxies: bool) -> list[RasterLight]:
    out = []
    for light in scene.lights:
        d = np.asarray(light.direction, float)
        d = d / max(np.linalg.norm(d), 1e-12)
        out.append(RasterLight(light.kind, np.asarray(light.position, float), d, light.radiance_scale.astype(float),
                               cos_outer=float(np.cos(light.outer_cone)), cos_inner=float(np.cos(light.inner_cone))))
    if use_proxies:
        for p in gpu_scene.proxies:
            out.append(RasterLight("proxy", p["position"], p["normal"], p["intensity"], lobe=p["flatness"]))
    return out[:MAX_LIGHTS]


def assign_shadow_slots(lights: list[RasterLight], eye: np.ndarray, budget: int, scene_diagonal: float) -> int:
    """Give the strongest local lights a cube-map slot; returns how many slots are used."""
    local = [k for k, li in enumerate(lights) if li.kind != "directional"]
    score = [float(np.max(lights[k].radiance)) / (float(np.sum((lights[k].position - eye) ** 2)) + 1.0) for k in local]
    order = [local[i] for i in np.argsort(score)[::-1]][:budget]
    for slot, k in enumerate(order):
        lights[k].slot = slot
        lights[k].far = max(scene_diagonal, 1.0)
        lights[k].near = max(lights[k].far * 1e-4, 1e-3)
    return len(order)


def pack(lights: list[RasterLight]) -> bytes:
    rows = np.zeros((MAX_LIGHTS, 16), np.float32)
    for k, li in enumerate(lights):
        rows[k, 0:3] = li.position
        rows[k, 3] = KIND[li.kind]
        rows[k, 4:7] = li.direction
        rows[k, 7] = li.slot
        rows[k, 8:11] = li.radiance
        rows[k, 11] = li.lobe
        rows[k, 12:16] = (li.cos_outer, li.cos_inner, li.near, li.far)
    return rows.tobytes()
