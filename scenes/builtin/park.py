"""Open outdoor square: one sun, grass, trees with dense foliage (many small leaf triangles),
benches, bins, and a shopfront with a yellow emissive sign. The study's case for RT shadows.

`detail` scales the foliage: 1 ~ 0.2M triangles, 5 ~ 2.3M.
"""
import numpy as np

from scenes.builder import SceneBuilder, box, cylinder, grid, lathe, quad, sphere, trs, trs_many
from scenes.builtin.textures import cobbles, grass


def build(detail: int = 1):
    b = SceneBuilder("park", seed=4)
    b.environment.kind = "sky"
    rng = b.rng
    S = 60.0
    b.material("grass", (1, 1, 1), roughness=0.95, texture=grass())
    b.material("path", (1, 1, 1), roughness=0.85, texture=cobbles())
    b.material("bark", (0.22, 0.14, 0.08), roughness=0.95)
    b.material("leaf_a", (0.12, 0.32, 0.06), roughness=0.7)
    b.material("leaf_b", (0.2, 0.38, 0.08), roughness=0.7)
    b.material("bench_wood", (0.45, 0.28, 0.14), roughness=0.7)
    b.material("iron", (0.05, 0.06, 0.05), roughness=0.5, metallic=1.0)
    b.material("bin", (0.1, 0.25, 0.12), roughness=0.5, metallic=0.5)
    b.material("brick", (0.5, 0.25, 0.18), roughness=0.9)
    b.material("shop_window", (0.3, 0.32, 0.35), roughness=0.1, metallic=0.0)
    b.material("sign", (1, 1, 1), emissive=(4.0, 3.2, 0.3))
    b.material("stone", (0.6, 0.58, 0.55), roughness=0.8)

    b.add(grid(48, 48), "grass", trs((0, 0, 0), 0, (S, 1, S)))
    b.add(grid(4, 40), "path", trs((0, 0.02, 0), 0, (4, 1, S)))
    b.add(grid(40, 4), "path", trs((0, 0.02, 4), 0, (S, 1, 4)))
    b.add(cylinder(48), "stone", trs((0, 0, 4), 0, (3.5, 0.5, 3.5)))  # fountain basin
    b.add(cylinder(24), "stone", trs((0, 0.5, 4), 0, (0.4, 1.5, 0.4)))

    # trees: trunk, a few branches, and clouds of small leaf quads
    trees = np.array([(x, z) for x in (-20, -12, 12, 20) for z in (-18, -8, 14, 22)], float)
    trees += rng.uniform(-2, 2, trees.shape)
    leaves_per_tree = (6000, 12000, 24000, 44000, 70000)[detail - 1]
    leaf = quad()
    trunk = lathe([(0.35, 0), (0.28, 0.5), (0.22, 3.5), (0.12, 5.0)], 10)
    for _k, (x, z) in enumerate(trees):
        height = rng.uniform(0.9, 1.2)
        b.add(trunk, "bark", trs((x, 0, z), rng.uniform(0, 6.28), (1, height, 1)))
        for a in rng.uniform(0, 2 * np.pi, 4):
            b.add(cylinder(6, caps=False), "bark",
                  trs((x, 3.0 * height, z), a, (0.08, 2.2, 0.08), rotate_z=-0.9))
        # leaves in an ellipsoid crown, random orientation, ~12 cm each
        u = rng.normal(size=(leaves_per_tree, 3))
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        r = rng.random(leaves_per_tree) ** 0.3
        centre = np.array([x, 5.2 * height, z])
        pos = centre + u * r[:, None] * [2.8, 2.2, 2.8]
        s = rng.uniform(0.09, 0.15, (leaves_per_tree, 1)) * [1, 1.6, 1]
        m = trs_many(pos, rng.uniform(0, 6.28, leaves_per_tree), s, rng.uniform(-1.2, 1.2, leaves_per_tree),
                     rng.uniform(-0.6, 0.6, leaves_per_tree))
        half = leaves_per_tree // 2
        b.add(leaf, "leaf_a", m[:half])
        b.add(leaf, "leaf_b", m[half:])

    # benches and bins along the paths
    bench_pos = [(-3.2, 0, z) for z in (-20, -10, 14, 24)] + [(3.2, 0, z) for z in (-15, 18)]
    for x, y, z in bench_pos:
        ry = np.pi / 2 if x < 0 else -np.pi / 2
        m = trs((x, y, z), ry)
        slats = [(0, 0.45, dz) for dz in (-0.15, 0.0, 0.15)]
        b.add(box(), "bench_wood", m @ trs_many(slats, s=(1.8, 0.04, 0.12)))
        back = [(0, 0.65 + 0.14 * i, -0.26) for i in range(3)]
        b.add(box(), "bench_wood", m @ trs_many(back, s=(1.8, 0.1, 0.03), rx=-0.15))
        legs = [(lx, 0.4, 0.0) for lx in (-0.8, 0.8)]
        b.add(box(), "iron", m @ trs_many(legs, s=(0.05, 0.8, 0.5)))
    bins = np.array([(-3.0, 0, z) for z in (-14, 6, 20)] + [(3.0, 0, -6)], float)
    b.add(lathe([(0.0, 0), (0.25, 0), (0.3, 0.9), (0.28, 0.9), (0.0, 0.92)], 16), "bin", trs_many(bins))

    # shopfront at the end of the path with a yellow emissive sign
    b.box("brick", (-8, 0, -30), (8, 7, -27))
    b.box("shop_window", (-5, 0.4, -27.0), (5, 3.0, -26.95))
    b.box("brick", (-0.6, 0, -27.0), (0.6, 3.0, -26.9))
    b.box("sign", (-4.5, 3.4, -26.95), (4.5, 4.3, -26.85))
    b.add(sphere(8, 16), "stone", trs((0, 2.2, 4), 0, (0.5, 0.5, 0.5)))

    sun_dir = -np.array([0.4, 0.8, 0.45])
    b.light(kind="directional", direction=tuple(sun_dir / np.linalg.norm(sun_dir)), color=(1.0, 0.96, 0.88),
            intensity=4.0, angular_radius=0.00465, name="sun")
    b.view("square", (7.0, 2.0, 30.0), (-1.0, 3.0, 0.0), 60)
    b.view("trees", (-5.0, 1.6, -2.0), (-13.0, 4.0, -8.0), 65)
    b.view("shopfront", (1.5, 1.7, -15.0), (0.0, 3.0, -27.0), 60)
    return b.build()
