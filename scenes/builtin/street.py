"""Outdoor urban street: one sun, café fronts with mirror-like shop windows, awnings, tables,
and a large red sign that bounces colour. The study's case for RT reflections + GI.
"""
import numpy as np

from scenes.builder import SceneBuilder, box, cylinder, grid, lathe, trs, trs_many
from scenes.builtin.textures import cobbles


def build(detail: int = 1):
    b = SceneBuilder("street", seed=2)
    b.environment.kind = "sky"
    L = 60.0  # street length along z
    n = 256 * detail
    b.material("road", (0.09, 0.09, 0.1), roughness=0.85)
    b.material("pavement", (1, 1, 1), roughness=0.8, texture=cobbles())
    b.material("facade_a", (0.72, 0.62, 0.48), roughness=0.9)
    b.material("facade_b", (0.6, 0.58, 0.55), roughness=0.9)
    b.material("facade_c", (0.55, 0.35, 0.28), roughness=0.9)
    b.material("window", (0.35, 0.4, 0.45), roughness=0.03, metallic=1.0)  # mirror-like shop glass
    b.material("frame", (0.08, 0.12, 0.1), roughness=0.5)
    b.material("awning_a", (0.1, 0.35, 0.15), roughness=0.8)
    b.material("awning_b", (0.55, 0.08, 0.06), roughness=0.8)
    b.material("red_sign", (0.85, 0.05, 0.03), roughness=0.7)
    b.material("table", (0.75, 0.75, 0.72), roughness=0.35, metallic=1.0)
    b.material("chair", (0.25, 0.15, 0.08), roughness=0.7)
    b.material("lamp_post", (0.05, 0.05, 0.05), roughness=0.4, metallic=1.0)
    b.material("roof", (0.3, 0.2, 0.18), roughness=0.9)

    b.add(grid(n // 4, n), "road", trs((0, 0, 0), 0, (8, 1, L)))
    for side in (-1, 1):
        b.add(grid(n // 8, n), "pavement", trs((side * 6.5, 0.12, 0), 0, (5, 1, L)))
        b.box("pavement", (side * 4 - 0.15, 0, -L / 2), (side * 4 + 0.15, 0.12, L / 2))

    facades = ("facade_a", "facade_b", "facade_c")
    shop_w = 7.5
    zs = np.arange(-L / 2 + shop_w / 2, L / 2, shop_w)
    for side in (-1, 1):
        ry = np.pi / 2 if side < 0 else -np.pi / 2  # fronts face the street
        x0 = side * 9.0
        for k, z in enumerate(zs):
            height = 9.0 + 3.0 * ((k * 7 + (side > 0) * 3) % 4)
            m = trs((x0, 0, z), ry)
            fac = facades[(k + (side > 0)) % 3]
            b.add(box(), fac, m @ trs((0, height / 2, -0.5), 0, (shop_w, height, 1.0)))
            b.add(box(), "roof", m @ trs((0, height + 0.15, -0.4), 0, (shop_w + 0.1, 0.3, 1.2)))
            # shop window and its frame at street level
            b.add(box(), "frame", m @ trs((0, 1.6, 0.05), 0, (shop_w - 0.6, 3.2, 0.1)))
            b.add(box(), "window", m @ trs((0.4, 1.75, 0.11), 0, (shop_w - 2.4, 2.5, 0.02)))
            b.add(box(), "frame", m @ trs((-shop_w / 2 + 1.0, 1.25, 0.12), 0, (0.9, 2.4, 0.04)))
            # upper floor windows
            rows = int((height - 4.0) // 3)
            t = [(wx, 4.8 + 3.0 * r, 0.02) for r in range(rows) for wx in (-2.4, 0.0, 2.4)]
            if t:
                b.add(box(), "window", m @ trs_many(t, s=(1.2, 1.8, 0.06)))
                b.add(box(), "frame", m @ trs_many(np.array(t) + [0, -1.0, 0.05], s=(1.4, 0.12, 0.2)))
            # awning
            awn = "awning_a" if (k + side) % 2 else "awning_b"
            b.add(box(), awn, m @ trs((0, 3.55, 1.1), 0, (shop_w - 0.4, 0.05, 2.2), rotate_x=0.3))
    # big red sign on the left that bounces colour into the street
    b.box("red_sign", (-8.4, 3.8, -6.0), (-8.2, 6.8, 2.0))

    # café tables and chairs on the pavements
    seg = 24 * detail
    pts = [(side * 6.2 + dx, 0.12, z) for side in (-1, 1) for z in zs[1:-1] for dx in (-0.8, 0.9)]
    t = np.array(pts)
    b.add(cylinder(seg), "table", trs_many(t, s=(0.04, 0.74, 0.04)))
    b.add(cylinder(seg * 2), "table", trs_many(t + [0, 0.74, 0], s=(0.4, 0.03, 0.4)))
    b.add(cylinder(seg), "table", trs_many(t, s=(0.25, 0.02, 0.25)))
    for dz in (-0.6, 0.6):
        c = t + [0, 0, dz]
        b.add(box(), "chair", trs_many(c + [0, 0.45, 0], s=(0.42, 0.05, 0.42)))
        b.add(box(), "chair", trs_many(c + [0, 0.7, np.sign(dz) * 0.2], s=(0.42, 0.5, 0.04)))
        for lx in (-0.18, 0.18):
            for lz in (-0.18, 0.18):
                b.add(box(), "chair", trs_many(c + [lx, 0.22, lz], s=(0.035, 0.45, 0.035)))
    # lamp posts
    post = lathe([(0.09, 0), (0.09, 0.4), (0.06, 0.5), (0.05, 4.2), (0.18, 4.3), (0.12, 4.6), (0.0, 4.7)],
                 seg)
    lp = [(side * 4.5, 0.12, z) for side in (-1, 1) for z in np.arange(-L / 2 + 5, L / 2, 12)]
    b.add(post, "lamp_post", trs_many(lp))

    b.light(kind="directional", direction=tuple(-np.array([0.55, 0.75, 0.35]) / np.linalg.norm([0.55, 0.75, 0.35])),
            color=(1.0, 0.95, 0.85), intensity=4.0, angular_radius=0.00465, name="sun")
    b.view("street", (0.5, 1.7, 24.0), (-0.5, 2.5, -10.0), 60)
    b.view("shopfront", (4.0, 1.6, 4.0), (-9.0, 1.8, -2.0), 60)
    b.view("cafe_tables", (6.5, 2.2, 14.0), (5.5, 0.5, 5.0), 55)
    return b.build()
