"""Marble temple: a large sparse hall with a polished marble floor, columns, statues and many
small point lights (braziers). The study's case for RT ambient occlusion.
"""
import numpy as np

from scenes.builder import SceneBuilder, box, grid, lathe, sphere, trs, trs_many
from scenes.builtin.textures import marble

BOWL = [(0.0, 0.0), (0.08, 0.0), (0.05, 0.6), (0.08, 0.9), (0.3, 1.0), (0.32, 1.05), (0.28, 1.05), (0.0, 0.98)]
STATUE = [(0.0, 0.0), (0.45, 0.0), (0.45, 0.6), (0.3, 0.65), (0.24, 1.0), (0.3, 1.4), (0.34, 1.9),
          (0.26, 2.15), (0.1, 2.25), (0.14, 2.35), (0.15, 2.5), (0.1, 2.62), (0.0, 2.65)]


def column_profile(height: float, rings: int):
    base = [(0.0, 0.0), (0.7, 0.0), (0.7, 0.25), (0.6, 0.35), (0.55, 0.45)]
    ys = np.linspace(0.45, height - 0.5, rings)
    shaft = [(0.55 - 0.06 * (y / height), y) for y in ys]
    cap = [(0.6, height - 0.4), (0.75, height - 0.25), (0.75, height), (0.0, height)]
    return base + shaft + cap


def build(detail: int = 1):
    b = SceneBuilder("temple", seed=5)
    b.environment.kind = "black"
    b.ambient = (0.035, 0.028, 0.02)  # what an artist would set for the raster baseline
    W, D, H = 24.0, 44.0, 12.0
    n = 120 * detail
    seg = 32 * detail
    b.material("marble_floor", (1, 1, 1), roughness=0.08, texture=marble())
    b.material("marble", (0.78, 0.74, 0.68), roughness=0.35)
    b.material("wall", (0.6, 0.5, 0.38), roughness=0.85)
    b.material("ceiling", (0.35, 0.28, 0.2), roughness=0.9)
    b.material("bronze", (0.55, 0.35, 0.15), roughness=0.35, metallic=1.0)
    b.material("statue", (0.72, 0.7, 0.66), roughness=0.5)
    b.material("ember", (0.1, 0.02, 0.0), roughness=0.9, emissive=(3.0, 0.9, 0.15))

    b.add(grid(n, n * 2), "marble_floor", trs((0, 0, 0), 0, (W, 1, D)))
    b.add(grid(n // 3, n // 2), "ceiling", trs((0, H, 0), 0, (W, 1, D), rotate_x=np.pi))
    for x, ry in ((-W / 2, np.pi / 2), (W / 2, -np.pi / 2)):
        b.add(grid(n // 2, n // 4), "wall", trs((x, H / 2, 0), ry, (D, 1, H), rotate_x=np.pi / 2))
    for z, ry in ((-D / 2, 0.0), (D / 2, np.pi)):
        b.add(grid(n // 4, n // 4), "wall", trs((0, H / 2, z), ry, (W, 1, H), rotate_x=np.pi / 2))
    # steps and a dais at the far end
    for i in range(3):
        b.box("marble", (-8 + i, 0, -D / 2), (8 - i, 0.3 * (i + 1), -D / 2 + 7 - i * 1.2))

    # two rows of columns
    col = lathe(column_profile(H - 0.5, 12 * detail), seg)
    zs = np.linspace(-15, 17, 9)
    cols = np.array([(x, 0, z) for x in (-7.5, 7.5) for z in zs])
    b.add(col, "marble", trs_many(cols))
    b.add(box(), "marble", trs_many(cols + [0, H - 0.25, 0], s=(1.8, 0.5, 1.8)))
    # architrave beams over the columns
    for x in (-7.5, 7.5):
        b.box("marble", (x - 0.8, H - 0.5, -16), (x + 0.8, H - 0.1, 18))

    # statues on plinths along the walls and on the dais
    statue = lathe(STATUE, seg)
    head = sphere(8 * detail, seg)
    spots = np.array([(x, 0, z) for x in (-10.5, 10.5) for z in (-11, 1, 13)] + [(0, 0.9, -19.0)])
    scale = np.array([1.0] * 6 + [1.8])[:, None]
    b.add(box(), "marble", trs_many(spots + [0, 0.4, 0], s=scale * [1.2, 0.8, 1.2]))
    b.add(statue, "statue", trs_many(spots + [0, 0.8, 0], s=scale * [1, 1, 1]))
    b.add(head, "statue", trs_many(spots + np.concatenate([scale * [0, 0.8 + 2.62, 0]]), s=scale * 0.22))

    # braziers between the columns, each a small warm point light above glowing embers
    bz = np.array([(x, 0, z) for x in (-4.6, 4.6) for z in np.linspace(-14, 16, 9)])
    b.add(lathe(BOWL, seg), "bronze", trs_many(bz))
    b.add(sphere(4, 8), "ember", trs_many(bz + [0, 0.98, 0], s=(0.24, 0.08, 0.24)))
    for k, (x, _y, z) in enumerate(bz):
        b.light(kind="point", position=(x, 1.35, z), color=(1.0, 0.55, 0.2), intensity=6.0, name=f"brazier_{k}")
    # two large braziers flanking the dais
    for x in (-5.5, 5.5):
        b.add(lathe(BOWL, seg), "bronze", trs((x, 0.9, -17.5), 0, (1.6, 1.6, 1.6)))
        b.light(kind="point", position=(x, 0.9 + 2.1, -17.5), color=(1.0, 0.6, 0.25), intensity=25.0,
                name=f"dais_{x:+.0f}")
    b.view("nave", (0.0, 2.2, 20.0), (0.0, 2.5, -20.0), 60)
    b.view("colonnade", (-5.5, 1.5, 16.0), (-7.0, 3.0, -6.0), 60)
    b.view("dais", (3.0, 2.0, -8.0), (0.0, 2.5, -19.0), 60)
    return b.build()
