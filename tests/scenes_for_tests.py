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


def parallel_planes(h=1.0):
    """A floor and a ceiling h metres above it, both 400 m wide (AO test)."""
    b = SceneBuilder("planes")
    b.material("grey", (0.5, 0.5, 0.5), roughness=1.0)
    b.add(grid(4, 4), "grey", trs((0, 0, 0), 0, (400, 1, 400)))
    b.add(grid(4, 4), "grey", trs((0, h, 0), 0, (400, 1, 400), rotate_x=np.pi))
    b.light(kind="point", position=(0, h / 2, 0), intensity=1.0)
    b.view("inside", (0.0, h * 0.5, 0.0), (0.0, 0.0, -2.0), 60)
    return b.build()


def _room_walls(b) -> None:
    """closed_box's 4 x 3 x 4 m room: floor, ceiling and walls of material "wall", the left one "red"."""
    W, H, D = 4.0, 3.0, 4.0
    b.add(grid(2, 2), "wall", trs((0, 0, 0), 0, (W, 1, D)))
    b.add(grid(2, 2), "wall", trs((0, H, 0), 0, (W, 1, D), rotate_x=np.pi))
    b.add(grid(2, 2), "red", trs((-W / 2, H / 2, 0), np.pi / 2, (D, 1, H), rotate_x=np.pi / 2))
    b.add(grid(2, 2), "wall", trs((W / 2, H / 2, 0), -np.pi / 2, (D, 1, H), rotate_x=np.pi / 2))
    b.add(grid(2, 2), "wall", trs((0, H / 2, -D / 2), 0.0, (W, 1, H), rotate_x=np.pi / 2))
    b.add(grid(2, 2), "wall", trs((0, H / 2, D / 2), np.pi, (W, 1, H), rotate_x=np.pi / 2))


def closed_box(albedo=0.5):
    """A closed 4x3x4 m diffuse room seen from inside, lit by one point light (GI test)."""
    b = SceneBuilder("box")
    b.material("wall", (albedo, albedo, albedo), roughness=1.0)
    b.material("red", (0.8, 0.1, 0.1), roughness=1.0)
    _room_walls(b)
    b.box("wall", (0.2, 0.0, -1.2), (1.2, 1.0, -0.2))
    b.light(kind="point", position=(0.0, 2.5, 0.5), intensity=8.0)
    b.view("room", (0.0, 1.5, 1.9), (0.0, 1.0, -2.0), 70)
    return b.build()


def closed_box_ggx():
    """closed_box's room (same walls, light and view) in glTF's metal-rough materials, for GI
    under brdf=ggx: rough dielectric walls (the left one red), a gold GGX metal box (roughness
    0.3) and a glossy white dielectric box (roughness 0.35) on the floor."""
    b = SceneBuilder("box_ggx")
    b.material("wall", (0.5, 0.5, 0.5), roughness=0.6)
    b.material("red", (0.8, 0.1, 0.1), roughness=0.5)
    b.material("gold", (1.0, 0.78, 0.34), roughness=0.3, metallic=1.0)
    b.material("glossy", (0.8, 0.8, 0.8), roughness=0.35)
    _room_walls(b)
    b.box("gold", (0.2, 0.0, -1.2), (1.2, 1.0, -0.2))
    b.box("glossy", (-1.3, 0.0, -1.4), (-0.5, 0.6, -0.6))
    b.light(kind="point", position=(0.0, 2.5, 0.5), intensity=8.0)
    b.view("room", (0.0, 1.5, 1.9), (0.0, 1.0, -2.0), 70)
    return b.build()


def closed_box_mirror():
    """closed_box_ggx's room lit by its point light and a black one-sided emissive panel facing
    down under the ceiling,
    with near-mirror surfaces, smoother than the reference's brdf.MIRROR_ROUGHNESS: a chrome box
    (roughness 0.05) and a lacquered white one (0.08) beside the gold box (for the reference's
    multiple importance sampling of GGX lobes against lights)."""
    b = SceneBuilder("box_mirror")
    b.material("wall", (0.5, 0.5, 0.5), roughness=0.6)
    b.material("red", (0.8, 0.1, 0.1), roughness=0.5)
    b.material("gold", (1.0, 0.78, 0.34), roughness=0.3, metallic=1.0)
    b.material("chrome", (0.9, 0.9, 0.9), roughness=0.05, metallic=1.0)
    b.material("lacquer", (0.8, 0.8, 0.8), roughness=0.08)
    b.material("panel", (0.0, 0.0, 0.0), roughness=1.0, emissive=(6.0, 5.5, 5.0))
    _room_walls(b)
    b.add(grid(2, 2), "panel", trs((-0.6, 2.7, -0.8), 0, (0.8, 1, 0.8), rotate_x=np.pi))  # 0.3 m under the ceiling
    b.box("gold", (0.2, 0.0, -1.2), (1.2, 1.0, -0.2))
    b.box("chrome", (-1.3, 0.0, -1.4), (-0.5, 0.6, -0.6))
    b.box("lacquer", (-0.2, 0.0, -1.9), (0.4, 1.4, -1.5))
    b.light(kind="point", position=(0.0, 2.5, 0.5), intensity=8.0)
    b.view("room", (0.0, 1.5, 1.9), (0.0, 1.0, -2.0), 70)
    scene = b.build()
    for m in scene.materials:  # the panel emits downwards only, black on both sides (as Mitsuba's area light)
        m.double_sided = m.name != "panel"
    return scene


def mirror_floor(roughness=0.05):
    """A metallic mirror floor in front of a red emissive wall, camera looking down at the floor."""
    b = SceneBuilder("mirror")
    b.material("mirror", (0.95, 0.95, 0.95), roughness=roughness, metallic=1.0)
    b.material("red_wall", (0.1, 0.1, 0.1), roughness=1.0, emissive=(2.0, 0.1, 0.1))
    b.add(grid(2, 2), "mirror", trs((0, 0, 0), 0, (20, 1, 20)))
    b.add(grid(2, 2), "red_wall", trs((0, 2.5, -5), 0.0, (20, 1, 5), rotate_x=np.pi / 2))
    b.view("down", (0.0, 1.0, 2.0), (0.0, 0.0, -1.0), 50)
    return b.build()


def sun_patch_map(h=64, w=128, sky=0.2, sun=500.0):
    """An equirectangular map (h, w, 3) of a dim uniform sky with a small bright sun: 3 x 3 texels
    towards (0.5, 0.7, 0.5) (up, front right of a camera on +Z), holding ~97 % of the light
    that reaches a surface facing it; the map of the environment importance-sampling tests and
    of the Mitsuba reference ggx_spheres_map (tests/refs/make_mitsuba_refs.py)."""
    pixels = np.full((h, w, 3), sky, np.float32)
    col, row = int(0.375 * w), int(0.252 * h)
    pixels[row - 1:row + 2, col - 1:col + 2] = sun
    return pixels
