"""Sparse indoor arcade: one room, rows of cabinets, stools, a few ceiling point lights.

Few fine details and little that reflects: the study's case for RT ambient occlusion.
"""
import numpy as np

from scenes.builder import SceneBuilder, box, cylinder, grid, trs, trs_many
from scenes.builtin.textures import carpet


def build(detail: int = 1):
    b = SceneBuilder("arcade", seed=1)
    b.environment.kind = "black"
    b.ambient = (0.04, 0.04, 0.045)  # what an artist would set for the raster baseline
    W, D, H = 16.0, 12.0, 4.0
    n = 160 * detail  # floor/wall tessellation: the size knob's main lever
    b.material("carpet", (1, 1, 1), roughness=0.95, texture=carpet())
    b.material("wall", (0.55, 0.5, 0.62), roughness=0.9)
    b.material("ceiling", (0.35, 0.35, 0.38), roughness=0.9)
    b.material("cabinet", (0.08, 0.08, 0.1), roughness=0.5)
    b.material("cabinet_side", (0.7, 0.12, 0.3), roughness=0.6)
    b.material("panel", (0.15, 0.35, 0.8), roughness=0.5)
    b.material("screen", (0.02, 0.02, 0.02), roughness=0.2, emissive=(0.6, 1.2, 1.5))
    b.material("stool_seat", (0.8, 0.1, 0.1), roughness=0.7)
    b.material("metal", (0.6, 0.6, 0.62), roughness=0.45, metallic=1.0)
    b.material("counter", (0.45, 0.3, 0.18), roughness=0.7)

    b.add(grid(n, n * 3 // 4), "carpet", trs((0, 0, 0), 0, (W, 1, D)))
    b.add(grid(n // 2, n // 3), "ceiling", trs((0, H, 0), 0, (W, 1, D), rotate_x=np.pi))
    for x, ry in ((-W / 2, np.pi / 2), (W / 2, -np.pi / 2)):
        b.add(grid(n // 2, n // 6), "wall", trs((x, H / 2, 0), ry, (D, 1, H), rotate_x=np.pi / 2))
    for z, ry in ((-D / 2, 0.0), (D / 2, np.pi)):
        b.add(grid(n // 2, n // 6), "wall", trs((0, H / 2, z), ry, (W, 1, H), rotate_x=np.pi / 2))

    # two rows of cabinets facing each other, and one row along the back wall
    xs = np.linspace(-5.5, 5.5, 8)
    rows = [(-2.2, 0.0), (2.2, np.pi), (-5.3, 0.0)]
    seg = 16 * detail
    for z, ry in rows:
        for x in xs:
            m = trs((x, 0, z), ry)
            b.add(box(), "cabinet_side", m @ trs((0, 0.95, 0), 0, (0.8, 1.9, 0.8)))
            b.add(box(), "cabinet", m @ trs((0, 1.0, 0.41), 0, (0.7, 1.6, 0.02)))
            b.add(box(), "panel", m @ trs((0, 0.95, 0.55), 0, (0.72, 0.08, 0.35), rotate_x=0.25))
            b.add(box(), "screen", m @ trs((0, 1.4, 0.42), 0, (0.55, 0.45, 0.02), rotate_x=-0.15))
            b.add(box(), "cabinet_side", m @ trs((0, 1.95, 0.3), 0, (0.8, 0.25, 0.3)))
        # stools in front of each cabinet
        dz = 0.95 if ry == 0.0 else -0.95
        t = np.stack([xs, np.zeros_like(xs), np.full_like(xs, z + dz)], 1)
        b.add(cylinder(seg), "metal", trs_many(t, s=(0.04, 0.7, 0.04)))
        b.add(cylinder(seg * 2), "stool_seat", trs_many(t + [0, 0.7, 0], s=(0.22, 0.08, 0.22)))
        b.add(cylinder(seg * 2, caps=False), "metal", trs_many(t, s=(0.2, 0.03, 0.2)))

    # prize counter at the side
    b.box("counter", (5.0, 0, 2.8), (7.6, 1.1, 5.4))
    b.box("metal", (4.95, 1.1, 2.75), (7.65, 1.14, 5.45))

    for x in (-4.0, 0.0, 4.0):
        for z in (-3.0, 3.0):
            b.light(kind="point", position=(x, H - 0.3, z), color=(1.0, 0.9, 0.8), intensity=12.0,
                    name=f"ceiling_{x:+.0f}_{z:+.0f}")
    b.view("aisle", (7.2, 1.7, 0.3), (-3.0, 1.0, -0.6), 65)
    b.view("cabinets", (-6.8, 1.5, 0.0), (2.0, 1.0, -1.2), 60)
    b.view("overhead", (6.5, 3.6, 5.5), (-1.0, 0.5, -1.0), 60)
    return b.build()
