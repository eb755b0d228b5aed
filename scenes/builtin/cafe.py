"""Cluttered indoor café lit ONLY by emissive surfaces (pendant lamps, a light strip, screens):
no analytic lights. Glasses, bottles, metal cutlery, many small objects.
The study's case for RT shadows + AO (its shadow pass failed on such a scene).
"""
import numpy as np

from scenes.builder import SceneBuilder, box, cylinder, grid, lathe, quad, sphere, trs, trs_many
from scenes.builtin.textures import checker

BOTTLE = [(0.0, 0.0), (0.035, 0.0), (0.037, 0.01), (0.037, 0.2), (0.03, 0.23), (0.012, 0.27),
          (0.012, 0.31), (0.0, 0.31)]
GLASS = [(0.0, 0.0), (0.03, 0.0), (0.032, 0.005), (0.04, 0.12), (0.036, 0.12), (0.028, 0.01), (0.0, 0.01)]
CUP = [(0.0, 0.0), (0.035, 0.0), (0.045, 0.07), (0.04, 0.07), (0.03, 0.006), (0.0, 0.006)]
SHADE = [(0.02, 0.0), (0.05, -0.02), (0.2, -0.2), (0.19, -0.2), (0.04, -0.03)]


def build(detail: int = 1):
    b = SceneBuilder("cafe", seed=3)
    b.environment.kind = "black"
    b.ambient = (0.06, 0.045, 0.03)  # what an artist would set for the raster baseline
    rng = b.rng
    W, D, H = 10.0, 8.0, 3.2
    n = 64 * detail
    seg = 12 * detail
    b.material("floor", (1, 1, 1), roughness=0.6, texture=checker(128, 16, (0.55, 0.5, 0.45), (0.12, 0.1, 0.09)))
    b.material("wall", (0.62, 0.5, 0.38), roughness=0.9)
    b.material("ceiling", (0.4, 0.36, 0.3), roughness=0.9)
    b.material("wood", (0.35, 0.18, 0.08), roughness=0.55)
    b.material("bar_top", (0.12, 0.1, 0.09), roughness=0.25)
    b.material("shelf", (0.25, 0.14, 0.07), roughness=0.6)
    b.material("glass", (0.85, 0.9, 0.9), roughness=0.05, metallic=0.0)
    b.material("bottle_green", (0.05, 0.3, 0.08), roughness=0.1)
    b.material("bottle_amber", (0.45, 0.2, 0.03), roughness=0.1)
    b.material("bottle_clear", (0.7, 0.75, 0.75), roughness=0.08)
    b.material("cutlery", (0.9, 0.9, 0.88), roughness=0.15, metallic=1.0)
    b.material("cup", (0.9, 0.88, 0.84), roughness=0.3)
    b.material("shade", (0.15, 0.3, 0.25), roughness=0.4, metallic=0.5)
    b.material("lamp", (1, 1, 1), emissive=(150.0, 110.0, 60.0))
    b.material("strip", (1, 1, 1), emissive=(40.0, 30.0, 16.0))
    b.material("screen", (0.02, 0.02, 0.02), roughness=0.2, emissive=(1.2, 1.6, 2.2))
    b.material("cushion", (0.5, 0.1, 0.12), roughness=0.9)

    b.add(grid(n, n), "floor", trs((0, 0, 0), 0, (W, 1, D)))
    b.add(grid(n // 2, n // 2), "ceiling", trs((0, H, 0), 0, (W, 1, D), rotate_x=np.pi))
    for x, ry in ((-W / 2, np.pi / 2), (W / 2, -np.pi / 2)):
        b.add(grid(n // 2, n // 4), "wall", trs((x, H / 2, 0), ry, (D, 1, H), rotate_x=np.pi / 2))
    for z, ry in ((-D / 2, 0.0), (D / 2, np.pi)):
        b.add(grid(n // 2, n // 4), "wall", trs((0, H / 2, z), ry, (W, 1, H), rotate_x=np.pi / 2))

    # bar counter along the back wall, shelves of bottles behind it
    b.box("wood", (-4.0, 0, -2.6), (2.5, 1.05, -1.9))
    b.box("bar_top", (-4.1, 1.05, -2.7), (2.6, 1.1, -1.8))
    shelf_y = (1.3, 1.75, 2.2)
    for y in shelf_y:
        b.box("shelf", (-4.0, y - 0.03, -4.0), (2.5, y, -3.7))
    bottle = lathe(BOTTLE, seg)
    kinds = ("bottle_green", "bottle_amber", "bottle_clear")
    for y in shelf_y:
        xs = np.arange(-3.9, 2.4, 0.11)
        pick = rng.integers(0, 3, xs.size)
        for k, name in enumerate(kinds):
            sel = xs[pick == k]
            t = np.stack([sel, np.full_like(sel, y), np.full_like(sel, -3.85 + 0.05 * rng.random(sel.size))], 1)
            b.add(bottle, name, trs_many(t, s=rng.uniform(0.85, 1.15, (sel.size, 1)) * [1, 1, 1]))
    glass = lathe(GLASS, seg)
    gx = np.arange(-3.8, 2.3, 0.18)
    b.add(glass, "glass", trs_many(np.stack([gx, np.full_like(gx, 1.1), np.full_like(gx, -2.45)], 1)))
    # light strip under the bar top and a screen on the side wall
    b.box("strip", (-4.0, 2.55, -3.98), (2.5, 2.6, -3.9))
    b.add(quad(), "screen", trs((-4.97, 1.9, 1.0), np.pi / 2, (1.6, 0.9, 1)))
    b.add(quad(), "screen", trs((4.97, 1.9, -1.0), -np.pi / 2, (1.2, 0.7, 1)))

    # tables with cups, glasses and cutlery; chairs around them
    tables = np.array([(x, z) for x in (-3.0, -0.5, 2.0, 4.0) for z in (0.3, 2.6)], float)
    tables[:, 0] += rng.uniform(-0.2, 0.2, len(tables))
    t3 = np.stack([tables[:, 0], np.zeros(len(tables)), tables[:, 1]], 1)
    b.add(cylinder(seg), "wood", trs_many(t3, s=(0.05, 0.74, 0.05)))
    b.add(cylinder(seg * 2), "wood", trs_many(t3 + [0, 0.74, 0], s=(0.45, 0.03, 0.45)))
    b.add(cylinder(seg * 2), "wood", trs_many(t3, s=(0.28, 0.02, 0.28)))
    cup = lathe(CUP, seg)
    top = t3 + [0, 0.77, 0]
    for a in np.linspace(0, 2 * np.pi, 4, endpoint=False):
        off = np.array([np.cos(a) * 0.28, 0, np.sin(a) * 0.28])
        b.add(cup, "cup", trs_many(top + off))
        b.add(glass, "glass", trs_many(top + off * 0.55 + [0.08, 0, 0]))
        fork = trs_many(top + off * 0.85 + [0.0, 0.003, 0.07], ry=a, s=(0.18, 0.006, 0.016))
        knife = trs_many(top + off * 0.85 + [0.0, 0.003, -0.07], ry=a, s=(0.2, 0.006, 0.02))
        b.add(box(), "cutlery", fork)
        b.add(box(), "cutlery", knife)
    for a in np.linspace(0, 2 * np.pi, 4, endpoint=False) + np.pi / 4:
        c = t3 + [np.cos(a) * 0.75, 0, np.sin(a) * 0.75]
        ry = -a + np.pi / 2
        b.add(box(), "cushion", trs_many(c + [0, 0.46, 0], ry=ry, s=(0.42, 0.06, 0.42)))
        for lx in (-0.18, 0.18):
            for lz in (-0.18, 0.18):
                off = np.array([lx * np.cos(ry) + lz * np.sin(ry), 0.22, -lx * np.sin(ry) + lz * np.cos(ry)])
                b.add(box(), "wood", trs_many(c + off, s=(0.035, 0.45, 0.035)))
        back = np.array([np.cos(a), 0, np.sin(a)]) * 0.2
        b.add(box(), "wood", trs_many(c + back + [0, 0.75, 0], ry=ry, s=(0.42, 0.55, 0.04)))
    # bar stools
    sx = np.arange(-3.5, 2.2, 0.9)
    st = np.stack([sx, np.zeros_like(sx), np.full_like(sx, -1.4)], 1)
    b.add(cylinder(seg), "cutlery", trs_many(st, s=(0.035, 0.75, 0.035)))
    b.add(cylinder(seg * 2), "cushion", trs_many(st + [0, 0.75, 0], s=(0.2, 0.07, 0.2)))

    # pendant lamps over tables and the bar: the only lights in the room
    shade = lathe(SHADE, seg * 2)
    bulb = sphere(6 * detail, seg)
    lamps = np.concatenate([t3 + [0, 2.2, 0], np.array([(x, 2.4, -2.25) for x in (-3.0, -1.0, 1.0)])])
    cord = np.stack([np.full(len(lamps), 0.006), H - lamps[:, 1], np.full(len(lamps), 0.006)], 1)
    b.add(cylinder(6), "shade", trs_many(lamps, s=cord))
    b.add(shade, "shade", trs_many(lamps))
    b.add(bulb, "lamp", trs_many(lamps + [0, -0.12, 0], s=(0.06, 0.06, 0.06)))
    b.view("room", (4.3, 1.6, 3.6), (-1.5, 1.0, -1.5), 65)
    b.view("bar", (-1.0, 1.4, 1.2), (-1.0, 1.2, -3.5), 60)
    b.view("table", (-1.6, 1.3, 1.6), (-3.0, 0.75, 0.3), 55)
    return b.build()
