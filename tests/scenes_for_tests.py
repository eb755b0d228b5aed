"""Small analytic scenes shared by the rendering tests."""
import numpy as np

from scenes.builder import SceneBuilder, grid, trs


def lit_plane(albedo=(0.5, 0.5, 0.5), light_pos=(0.3, 2.0, -0.2), intensity=10.0, box=None, env="black"):
    """A 20x20 m diffuse plane at y=0 under one point light; optionally an occluding box (lo, hi)."""
    b = SceneBuilder("lit_plane")
    b.environment.kind = env
    b.material("plane", albedo, roughness=1.0)
    b.add(grid(8, 8), "plane", trs((0, 0, 0), 0, (20, 1, 20)))
    if box is not None:
        b.material("box", (0.5, 0.5, 0.5), roughness=1.0)
        b.box("box", *box)
    b.light(kind="point", position=light_pos, intensity=intensity, color=(1, 1, 1))
    b.view("top", (0.0, 6.0, 3.0), (0.0, 0.0, 0.0), 60)
    return b.build()


def expected_point_radiance(positions, albedo, light_pos, intensity, normal=(0, 1, 0)):
    """rho/pi * I cos(theta) / d^2 on the plane."""
    d = np.asarray(light_pos) - positions
    dist2 = (d * d).sum(-1)
    cos = np.clip((d * np.asarray(normal)).sum(-1) / np.sqrt(dist2), 0, None)
    return np.asarray(albedo)[None] / np.pi * (intensity * cos / dist2)[..., None]
