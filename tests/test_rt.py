"""Ray-traced passes: analytic and statistical checks with fixed seeds."""
import numpy as np
import pytest

from app.camera import Camera
from app.options import Options
from app.renderer import Renderer
from rt.embree.blocks import block_keys
from rt.embree.shading import light_rays, one_light_rays
from scenes.builtin import build_builtin
from tests.scenes_for_tests import closed_box, expected_point_radiance, lit_plane, mirror_floor, parallel_planes


def make(gl, scene, sets=()):
    opts = Options()
    opts.apply(list(sets))
    return Renderer(gl, scene, opts)


def run(gl, scene, pass_name, frames=1, size=(64, 48), sets=(), camera=None):
    r = make(gl, scene, sets)
    cam = camera or Camera.from_view(scene.default_view(), scene.diagonal)
    for _ in range(frames):
        r.render(cam, *size, pass_name)
    out = r.read_linear()
    r.release()
    return out


def test_ao_between_parallel_planes(gl):
    h, radius = 1.0, 2.0
    scene = parallel_planes(h)
    cam = Camera(np.array([0.0, 0.5, 0.0]), np.array([0.0, 0.0, -0.3]), np.array([0.0, 1.0, 0.0]), 60)
    cam.fit_clip(10.0)
    pos = run(gl, scene, "position", camera=cam)
    ao = run(gl, scene, "ao", frames=16, sets=[f"ao.radius={radius}", "ao.rays_per_pixel=4"], camera=cam)
    floor = np.abs(pos[..., 1]) < 1e-3
    assert floor.sum() > 500
    assert ao[floor][:, 0].mean() == pytest.approx((h / radius) ** 2, abs=0.01)
    open_floor = run(gl, scene, "ao", frames=4, sets=["ao.radius=0.5"], camera=cam)  # rays shorter than h
    assert open_floor[floor].min() == pytest.approx(1.0)


def test_shadows_plane_matches_analytic(gl):
    albedo, light, intensity = (0.5, 0.6, 0.7), (0.3, 2.0, -0.2), 10.0
    scene = lit_plane(albedo, light, intensity)
    pos = run(gl, scene, "position", size=(96, 72))
    got = run(gl, scene, "shadows", size=(96, 72))
    want = expected_point_radiance(pos, albedo, light, intensity)
    cov = np.abs(pos).sum(-1) > 0
    rel = np.abs(got[cov] - want[cov]) / want[cov]
    assert np.percentile(rel, 99.5) < 0.01


def test_shadows_one_light_accumulates_to_all(gl):
    scene = build_builtin("arcade")
    size = (48, 27)
    ref = run(gl, scene, "shadows", size=size, sets=["shadows.lights=all"], frames=4)
    one = run(gl, scene, "shadows", size=size, sets=["shadows.lights=one"], frames=256)
    # compare 4x4-pixel block means: noise averages out, bias would not
    def blocks(img):
        h, w = img.shape[0] // 3 * 3, img.shape[1] // 3 * 3
        return img[:h, :w].reshape(h // 3, 3, w // 3, 3, 3).mean((1, 3))
    a, b = blocks(ref), blocks(one)
    assert abs(a.mean() / b.mean() - 1) < 0.02
    assert np.median(np.abs(a - b) / np.maximum(a, 1e-3)) < 0.06


def test_gi_converges_to_reference_with_same_bounces(gl):
    scene = closed_box()
    size = (40, 30)
    gi = run(gl, scene, "gi", frames=96, size=size, sets=["gi.rays_per_pixel=2", "gi.bounces=1"])
    ref = run(gl, scene, "reference", frames=192, size=size,
              sets=["reference.max_bounces=1", "reference.rr_start=64"])
    assert np.isfinite(gi).all() and np.isfinite(ref).all()
    assert gi.mean() == pytest.approx(ref.mean(), rel=0.02)
    g = gi.reshape(6, 5, 8, 5, 3).mean((1, 3))
    r = ref.reshape(6, 5, 8, 5, 3).mean((1, 3))
    assert np.median(np.abs(g - r) / np.maximum(r, 1e-3)) < 0.05
    # and more bounces add light
    gi2 = run(gl, scene, "gi", frames=32, size=size, sets=["gi.bounces=3"])
    assert gi2.mean() > gi.mean() * 1.05


def test_mirror_floor_reflects_the_red_wall(gl):
    cam = Camera(np.array([0.0, 1.0, 2.0]), np.array([0.0, 0.0, -1.0]), np.array([0.0, 1.0, 0.0]), 40)
    cam.fit_clip(30.0)
    scene = mirror_floor(0.05)
    pos = run(gl, scene, "position", camera=cam)
    floor = np.abs(pos[..., 1]) < 1e-3
    assert floor.sum() > 1000
    on = run(gl, scene, "reflections", camera=cam, sets=["reflections.roughness_threshold=0.3"])
    off = run(gl, scene, "reflections", camera=cam, sets=["reflections.roughness_threshold=0.01"])
    red_on = on[floor]
    assert (red_on[:, 0] > 3 * red_on[:, 1] + 0.1).mean() > 0.9, "mirror floor does not show the red wall"
    # without the reflection only diffuse light from the wall remains: far less red
    assert np.median(off[floor][:, 0]) < 0.3 * np.median(red_on[:, 0]), "rough floor reflects"
    study = run(gl, scene, "reflections", camera=cam, sets=["reflections.lit=false"])
    assert (study[floor][:, 0] > study[floor][:, 1]).mean() > 0.9


def test_accumulation_resets_on_camera_resize_and_option(gl):
    scene = lit_plane()
    r = make(gl, scene)
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    for _ in range(3):
        r.render(cam, 32, 24, "ao")
    assert r.frame_count == 3
    cam2 = cam.copy()
    cam2.eye = cam2.eye + 0.1
    r.render(cam2, 32, 24, "ao")
    assert r.frame_count == 1
    r.render(cam2, 32, 20, "ao")
    assert r.frame_count == 1
    r.render(cam2, 32, 20, "ao")
    r.options.set("ao.radius", "0.3")
    r.render(cam2, 32, 20, "ao")
    assert r.frame_count == 1
    r.render(cam2, 32, 20, "gi")
    assert r.frame_count == 1
    r.options.set("max_frames", "2")
    for _ in range(4):
        r.render(cam2, 32, 20, "gi")
    assert r.frame_count == 2
    r.release()


@pytest.mark.parametrize("sets", [(), ("max_frames=2",), ("accumulate=false",), ("exposure=3",)])
def test_frame_finished_on_embree_threads_as_in_gl(gl, sets):
    """finish=tracer: Embree's threads accumulate and tone-map the frame (rt/embree/present.py)
    and only the 8-bit image goes to GL; the mean, the max_frames stop and the display are GL's
    (accumulate.frag, tonemap.frag, finish=gl), to float rounding and one 8-bit step at most. And
    auto picks the tracer on this CPU rasteriser."""
    scene = build_builtin("street")
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    out = {}
    for finish in ("gl", "tracer", "auto"):
        r = make(gl, scene, ("gbuffer=rt", "gi.rays_per_pixel=1", f"finish={finish}") + sets)
        for _ in range(3):
            r.render(cam, 96, 54, "gi")
        presented = "present" in r.profiler.frame and "tonemap" not in r.profiler.frame
        out[finish] = (r.read_linear(), r.read_display().astype(int), r.frame_count, presented)
        r.release()
    (lin_g, disp_g, n_g, on_g), (lin_t, disp_t, n_t, on_t) = out["gl"], out["tracer"]
    assert on_t and out["auto"][3] and not on_g
    assert n_g == n_t == {"max_frames=2": 2, "accumulate=false": 0}.get((sets or ("",))[0], 3)
    np.testing.assert_allclose(lin_t, lin_g, rtol=1e-6, atol=1e-7)
    assert np.abs(disp_t - disp_g).max() <= 1 and np.mean(disp_t != disp_g) < 0.01
    np.testing.assert_array_equal(out["auto"][1], disp_t)


def test_accumulation_reduces_noise(gl):
    scene = closed_box()
    one = run(gl, scene, "gi", frames=1, size=(40, 30))
    many = run(gl, scene, "gi", frames=32, size=(40, 30))
    smooth = run(gl, scene, "gi", frames=128, size=(40, 30))
    assert np.abs(many - smooth).mean() < 0.5 * np.abs(one - smooth).mean()


def test_same_command_same_image(gl):
    scene = closed_box()
    a = run(gl, scene, "gi", frames=2, size=(24, 18))
    b = run(gl, scene, "gi", frames=2, size=(24, 18))
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("pass_name", ["shadows", "reflections", "gi", "ao", "hybrid", "reference", "forward"])
def test_cafe_renders_every_pass_without_nan(gl, pass_name):
    scene = build_builtin("cafe")
    img = run(gl, scene, pass_name, frames=2, size=(64, 36))
    assert np.isfinite(img).all()
    assert img.mean() > 1e-3, "café is black"


def test_rt_gbuffer_matches_raster(gl):
    scene = build_builtin("street")
    for channel in ("albedo", "normal", "depth"):
        ras = run(gl, scene, channel, size=(64, 36))
        rtg = run(gl, scene, channel, size=(64, 36), sets=["gbuffer=rt"])
        agree = np.abs(ras - rtg).max(-1) < 1e-2 * max(1.0, float(np.abs(ras).max()))
        assert agree.mean() > 0.9, channel
    a = run(gl, scene, "shadows", size=(64, 36))
    b = run(gl, scene, "shadows", size=(64, 36), sets=["gbuffer=rt"])
    assert abs(a.mean() / b.mean() - 1) < 0.03


def test_hybrid_swaps_effects(gl):
    scene = build_builtin("street")
    size = (64, 36)
    base = run(gl, scene, "hybrid", size=size, sets=["hybrid.shadows=false", "hybrid.ao=false"])
    fwd = run(gl, scene, "forward", size=size, sets=["forward.fxaa=false"])
    np.testing.assert_allclose(base, fwd, atol=1e-4)  # nothing swapped: the forward baseline
    for effect in ("shadows", "ao", "reflections", "gi"):
        img = run(gl, scene, "hybrid", size=size, sets=[f"hybrid.{e}={str(e == effect).lower()}"
                                                        for e in ("shadows", "ao", "reflections", "gi")])
        assert np.isfinite(img).all()
        assert np.abs(img - base).mean() > 1e-4, effect


def prepared_frame(gl, name: str, size=(96, 54)):
    """A renderer on a built-in scene, its default camera, and an AO frame prepared (the raster
    G-buffer read back)."""
    scene = build_builtin(name)
    r = make(gl, scene, ("gbuffer=raster",))
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    return r, cam, r.prepare(cam, *size, "ao")


def test_packed_gbuffer_matches_float_targets(gl):
    """The 24-byte G-buffer the CPU reads back holds what the float targets hold."""
    from app.raster.upload import read_rgba
    from rt.embree.gbuffer import from_raster

    r, cam, job = prepared_frame(gl, "cafe")
    gb = from_raster(job.frame.channels["gbuffer_packed"], cam, 96, 54)
    ch = {n: read_rgba(job.frame.channels[n]).reshape(-1, 4) for n in
          ("g_position", "g_normal", "g_albedo", "g_emissive", "g_face")}
    i, s = gb.index, gb.surface
    assert np.array_equal(np.flatnonzero(ch["g_face"][:, 3] > 0), i)
    depth = ch["g_position"][i, 3]
    assert np.allclose(gb.depth[i], depth)
    assert np.max(np.linalg.norm(s.p - ch["g_position"][i, :3], axis=1) / depth) < 1e-4
    assert np.abs(s.n - ch["g_normal"][i, :3]).max() < 1e-3
    assert np.abs(s.ng - ch["g_face"][i, :3]).max() < 1e-3
    # albedo travels sRGB-encoded in 8 bits: within half a code of the float target's encoding
    from scenes.loaders.common import srgb_to_linear

    codes = np.arange(256) / 255.0
    encode = lambda x: np.interp(x, srgb_to_linear(codes), codes)  # noqa: E731
    assert np.abs(encode(s.albedo) - encode(ch["g_albedo"][i, :3])).max() <= 0.5 / 255 + 1e-4
    assert np.abs(s.metallic - ch["g_albedo"][i, 3]).max() <= 0.5 / 255 + 1e-6
    assert np.abs(s.roughness - ch["g_normal"][i, 3]).max() < 1e-3
    assert np.allclose(s.emissive, ch["g_emissive"][i, :3], rtol=1e-3, atol=1e-4)
    assert np.array_equal(gb.soa, s.soa()[0])  # the rows the ray generators read
    r.release()


@pytest.mark.parametrize("name", ["cafe", "temple", "street"])
def test_generators_read_a_chunk_of_the_gbuffer_rows(gl, name):
    """Rays from columns g0.. of the G-buffer's rows are those from the chunk's own points, for
    every kind of light and for cosine rays (cafe: emissive clusters; temple: point lights;
    street: the sun)."""
    from rt.embree import raygen, rtcore, scratch
    from rt.embree.gbuffer import from_raster
    from rt.embree.sampling import PixelRng

    r, cam, job = prepared_frame(gl, name)
    gb = from_raster(job.frame.channels["gbuffer_packed"], cam, 96, 54)
    data = r.ray_tracing().data
    lo, hi = len(gb.index) // 3, len(gb.index) // 3 + 1000  # 1000: not a whole number of steps
    keys = PixelRng(0, 0, gb.index[lo:hi], 1).key
    own = gb.surface.take(slice(lo, hi)).soa()
    for k in range(data.lights.count):
        a, b = scratch.rays("t.a", hi - lo, True), scratch.rays("t.b", hi - lo, True)
        m = light_rays(data.lights, k, (gb.soa, lo), keys, 0, a[0], a[1], a[2], a[4], a[3])
        assert m == light_rays(data.lights, k, own, keys, 0, b[0], b[1], b[2], b[4], b[3]) and m > 0
        for x, y in zip(a, b, strict=True):
            assert np.array_equal(x[:m], y[:m])
    a, b = scratch.rays("t.a", hi - lo), scratch.rays("t.b", hi - lo)
    m = raygen.hemisphere_live(gb.soa, lo, keys, 0, np.float32(1.0), a, rtcore.target(0),
                               raygen.NOT_TRACED)
    assert m == raygen.hemisphere_live(*own, keys, 0, np.float32(1.0), b, rtcore.target(0),
                                       raygen.NOT_TRACED) and m > 500
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x[:m], y[:m])
    r.release()


def test_one_light_pick_of_a_lone_sun_is_that_suns_own_rays(gl):
    """With a sun as the only light (the street), the one-light estimator picks it everywhere
    with probability 1 (light_sampling._sun_rays): its rays are the sun's own shadow rays drawn from
    the same numbers (its dimensions dim + 1, dim + 2), origin, direction, length and light."""
    from rt.embree import scratch
    from rt.embree.gbuffer import from_raster
    from rt.embree.sampling import PixelRng

    r, cam, job = prepared_frame(gl, "street")
    gb = from_raster(job.frame.channels["gbuffer_packed"], cam, 96, 54)
    lights = r.ray_tracing().data.lights
    assert lights.count == 1 and lights.analytic[0][0] == 2  # one light, a sun
    n = len(gb.index)
    keys = PixelRng(0, 0, gb.index, 1).key
    a, b = scratch.rays("t.a", n, True), scratch.rays("t.b", n, True)
    m = one_light_rays(lights, (gb.soa, 0), keys, 5, a[0], a[1], a[2], a[4], a[3])
    assert m == light_rays(lights, 0, (gb.soa, 0), keys, 6, b[0], b[1], b[2], b[4], b[3]) and m > n // 2
    for x, y in zip(a, b, strict=True):
        assert np.allclose(x[:m], y[:m], rtol=1e-6, atol=1e-7)
    r.release()


@pytest.mark.parametrize("name", ["cafe", "temple", "street"])
def test_generators_tracing_inline_add_what_tracing_after_adds(gl, name):
    """Given a scene handle, generators trace their rays as they make them and add what gets
    through: the same sums (to the bit; GGX's to float rounding) and ray counts as packing,
    tracing and adding after, for every kind of light, the one-light choice and AO rays."""
    from rt.embree import brdf, raygen, rtcore, scratch
    from rt.embree.gbuffer import from_raster
    from rt.embree.sampling import PixelRng

    r, cam, job = prepared_frame(gl, name)
    gb = from_raster(job.frame.channels["gbuffer_packed"], cam, 96, 54)
    data, tracer = r.ray_tracing().data, r.ray_tracing().tracer
    view = tracer.serial_view()
    assert view.inline_scene() == tracer.handle and tracer.inline_scene() in (0, tracer.handle)
    n = len(gb.index)
    keys = PixelRng(3, 0, gb.index, 1).key
    G = (gb.soa, 0)
    o, d, t, idx, e = scratch.rays("t.a", n, True)

    def fresh(cols):  # a plain accumulator, or a GGX one (rt/embree/brdf.py) with views and alphas
        out = np.zeros((n, cols), np.float32)
        if cols > 3:
            out[:, brdf.VIEW:brdf.VIEW + 3] = np.cos(np.arange(n)[:, None] + [0.0, 2.1, 4.2]) * 0.577
            out[:, brdf.VIEW + 1] = np.abs(out[:, brdf.VIEW + 1])
            out[:, brdf.ALPHA] = 0.05 + 0.9 * (np.arange(n) % 7) / 7
        return out

    def after(m, light, cols=3):
        out = fresh(cols)
        blocked = view.occluded(o[:m], d[:m], t[:m])
        if light:
            raygen.add_unblocked(out, idx, d, e, blocked, m, *G)
        else:
            np.add.at(out[:, 0], idx[:m][~blocked], 1.0)
        return out

    cases = [(lambda sc, acc, k=k: light_rays(data.lights, k, G, keys, 0, o, d, t, e, idx, sc, acc), True)
             for k in range(data.lights.count)]
    cases.append((lambda sc, acc: one_light_rays(data.lights, G, keys, 0, o, d, t, e, idx, sc, acc), True))
    cases.append((lambda sc, acc: raygen.hemisphere_live(*G, keys, 0, np.float32(0.7), (o, d, t, idx),
                                                         rtcore.target(sc), acc), False))
    for make, light in cases:
        m = make(0, raygen.NOT_TRACED)
        expected = after(m, light)
        inline = np.zeros((n, 3), np.float32)
        assert make(view.handle, inline) == m > 0
        assert np.array_equal(inline, expected)
        assert 0 < np.count_nonzero(expected[:, 0]) < n or not light  # some light gets through, not all
        if light:  # GGX's sums too (the same to float rounding: the terms compile in two places)
            m = make(0, raygen.NOT_TRACED)
            expected, inline = after(m, light, brdf.GGX_COLS), fresh(brdf.GGX_COLS)
            make(view.handle, inline)
            assert np.array_equal(inline[:, :3], expected[:, :3]) and np.count_nonzero(expected[:, brdf.SUM_EDV]) > 0
            np.testing.assert_allclose(inline, expected, rtol=1e-3, atol=1e-9)  # sharp lobes: alpha 0.05
    r.release()


@pytest.mark.parametrize("name,sets", [("cafe", ()), ("temple", ()),
                                       ("street", ("ao.rays_per_pixel=3", "gi.rays_per_pixel=2", "gi.bounces=3")),
                                       ("cafe", ("shadows.lights=one", "shadows.greyscale=true")),
                                       ("arcade", ("shadows.lights=one", "ao.greyscale=false", "gi.shadows=false")),
                                       ("street", ("reflections.lit=false", "reflections.roughness_threshold=0.6",
                                                   "reflections.max_depth=3")),
                                       ("temple", ("reflections.max_depth=4", "reflections.roughness_threshold=0.5"))])
def test_whole_frame_kernels_render_the_same_on_any_thread_count(gl, name, sets, monkeypatch):
    """AO, shadows, GI and reflections (one compiled parallel call per frame each) give the same
    images, their other outputs too, and count the same rays on 1 and 3 threads, whose blocks
    of points differ (blocks.block_bounds). Equal to the float32 rounding of vectorised loops:
    a point at a block's edge may take the scalar remainder of a vectorised loop with one block
    size and the vector body with another (GI's light weights: 1 ulp)."""
    from app.passes import PASS_CLASSES
    from rt.embree.backend import EmbreeBackend

    scene = build_builtin(name)
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    trace = EmbreeBackend.trace
    for pass_name in ("ao", "shadows", "gi", "reflections"):
        got = []
        for threads in (1, 3):
            r = make(gl, scene, sets)
            r.pass_outputs = True
            tracer = r.ray_tracing().tracer
            tracer.set_threads(threads)
            outputs = {}

            def keep(self, effect, channels=("radiance",), outputs=outputs):
                result = trace(self, effect, channels)
                outputs.update((k, v.copy()) for k, v in result.items())
                return result

            monkeypatch.setattr(EmbreeBackend, "trace", keep)
            for _ in range(2):  # a second frame: other random numbers, the same buffers reused
                r.render(cam, 80, 45, pass_name)
            got.append((r.read_linear(), tracer.rays_traced, outputs))
            r.release()
        (a, rays_a, out_a), (b, rays_b, out_b) = got
        assert np.allclose(a, b, rtol=1e-5, atol=1e-7) and rays_a == rays_b > 0 and a.std() > 0.01, pass_name
        # all but the specular part, which only glTF's BRDF has (RtPass.splits_specular)
        assert out_a.keys() == out_b.keys() == set(PASS_CLASSES[pass_name].writes) - {"rt_specular"}
        for k in out_a:  # the passes' other outputs too (what hybrid's forward pass reads)
            assert np.allclose(out_a[k], out_b[k], rtol=1e-5, atol=1e-7), k
    monkeypatch.setattr(EmbreeBackend, "trace", trace)


def test_passes_make_radiance_only_unless_asked(gl, monkeypatch):
    """By default (Renderer.pass_outputs False) a pass returns radiance alone, and the image is
    the very same as when its other outputs (rt_direct, rt_ao, ...) are made too."""
    from app.passes import PASS_CLASSES
    from rt.embree.backend import EmbreeBackend

    scene = build_builtin("cafe")
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    trace = EmbreeBackend.trace
    for pass_name in ("ao", "shadows", "gi", "reflections"):
        images = []
        for wanted in (False, True):
            r = make(gl, scene)
            r.pass_outputs = wanted
            keys = []

            def keep(self, effect, channels=("radiance",), keys=keys):
                result = trace(self, effect, channels)
                keys.append(set(result))
                return result

            monkeypatch.setattr(EmbreeBackend, "trace", keep)
            r.render(cam, 80, 45, pass_name)
            images.append(r.read_linear())
            made = set(PASS_CLASSES[pass_name].writes) - {"rt_specular"}  # glTF's BRDF alone has it
            assert keys == [made if wanted else {"radiance"}], pass_name
            r.release()
        assert np.array_equal(images[0], images[1]) and images[0].std() > 0.01, pass_name
    monkeypatch.setattr(EmbreeBackend, "trace", trace)


@pytest.mark.parametrize("pass_name,sets", [
    ("ao", ("ao.rays_per_pixel=2",)), ("shadows", ()), ("shadows", ("shadows.lights=one",)), ("gi", ("gi.bounces=2",)),
    ("gi", ("gi.shadows=false",)), ("reflections", ("reflections.max_depth=2",)),
    ("reference", ("reference.max_bounces=2",))])
def test_recorded_frame_logs_every_ray_it_traces(gl, pass_name, sets):
    """bench --perf's recorded frame (app/perf.py: record_frame) logs exactly the rays the pass
    traced, each kind replayable, and logging changes nothing in the image; a log too small to
    hold them is noticed and the frame recorded again."""
    from app.perf import record_frame
    from rt.embree.tracer import RayLog

    scene = build_builtin("temple")
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    images = []
    for recorded in (False, True):
        # the second frame, recorded or not, is frame 1; the pass's own rays (primary rays: replay_primary)
        r = make(gl, scene, sets + ("accumulate=false", "gbuffer=raster"))
        tracer = r.ray_tracing().tracer
        r.render(cam, 64, 36, pass_name)  # the frame before: sizes the log
        if recorded:
            r.profiler.counters["rays"] = 10  # far too small: the log must grow and the frame run again
            batches = record_frame(r, cam, (64, 36), pass_name)
            logged = sum(b[1].shape[0] for b in batches)
            assert logged > 0 and logged == r.profiler.counters["rays"]  # the rays of the frame logged
            assert {b[0] for b in batches} <= {"occluded", "intersect"}
            assert all(np.isfinite(b[1]).all() and (b[3] > 0).all() for b in batches)
            assert tracer.replay(batches) > 0
        else:
            r.render(cam, 64, 36, pass_name)
        images.append(r.read_linear())
        r.release()
    assert np.array_equal(images[0], images[1])
    log = RayLog(4)
    assert not log.overflowed and len(log) == 0


@pytest.mark.parametrize("env", ["sky", "studio", "0.1,0.2,0.3", "black"])
def test_background_kernel_matches_environment(env):
    """The compiled environment lookup (backgrounds, missed GI rays) is scenes/model.py's."""
    from rt.embree.frame import RtFrame
    from rt.embree.gbuffer import CpuGBuffer
    from scenes.model import Environment

    rng = np.random.default_rng(3)
    n = 4000
    view = rng.normal(size=(n, 3)).astype(np.float32)
    view /= np.linalg.norm(view, axis=1, keepdims=True)
    covered = rng.random(n) < 0.3
    environment = Environment.parse(env)
    gb = CpuGBuffer(80, 50, None, view, covered, np.flatnonzero(covered), None, None)
    got = RtFrame(None, None, gb, environment, None).background()
    want = np.zeros((n, 3), np.float32)
    want[~covered] = environment.radiance(view[~covered])
    assert np.allclose(got, want, atol=1e-6)


def test_chunks_take_equal_shares_of_the_measured_cost():
    from rt.embree.tracer import EmbreeTracer as T

    n = 100_000
    assert T.balanced_bounds(n, 4).tolist() == [0, 25_000, 50_000, 75_000, 100_000]
    # the last quarter of the pixels cost 3x as much each: half the cost lies in each part
    chunks = [slice(0, 75_000), slice(75_000, n)]
    profile = T.cost_profile(None, chunks, {0: 0.75, 75_000: 0.75}, n)
    b = T.balanced_bounds(n, 2, profile)
    assert b[0] == 0 and b[-1] == n and 71_000 < b[1] < 72_000  # 0.9 x cost + 0.1 x pixels: 71.4 k
    cost = np.where(np.arange(n) < 75_000, 1.0, 3.0)
    halves = [cost[: b[1]].sum(), cost[b[1]:].sum()]
    assert abs(halves[0] - halves[1]) / sum(halves) < 0.1
    # a profile blends with the next frame's measurement rather than jumping to it
    again = T.cost_profile(profile, [slice(0, 50_000), slice(50_000, n)], {0: 0.5, 50_000: 0.5}, n)
    assert np.allclose(again, 0.5 * profile + 0.5 * 1.0)
    # one part measured as nearly free still gets no more than 3 x an equal run
    skewed = np.r_[np.full(32, 1e-9), np.full(32, 1.0)]
    sizes = np.diff(T.balanced_bounds(n, 8, skewed))
    assert sizes.max() <= 1.01 * 3 * n / 8 and sizes.min() >= 0.99 * n / 24 and sizes.sum() == n


def test_chunk_balance_keeps_the_image(gl):
    """Chunk bounds follow last frame's cost; every pixel's numbers are its own, so the image
    stays the same whatever the bounds."""
    scene = build_builtin("arcade")
    r = make(gl, scene, ["reference.max_bounces=2"])  # the reference path tracer runs in chunks
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    tracer = r.ray_tracing().tracer
    tracer.set_threads(3)
    first = r.render(cam, 256, 144, "reference") and r.read_linear()
    assert tracer._costs  # measured
    key = next(iter(tracer._costs))
    tracer._costs[key] = np.linspace(1.0, 50.0, tracer.COST_BINS)  # skewed bounds next time
    r.reset()
    second = r.render(cam, 256, 144, "reference") and r.read_linear()
    assert np.abs(first - second).max() < 1e-5
    r.release()


def test_reused_gbuffer_matches_a_fresh_one_and_keeps_its_memory(gl):
    from rt.embree.gbuffer import from_raster

    r, cam, job = prepared_frame(gl, "street")
    fresh = from_raster(job.frame.channels["gbuffer_packed"], cam, 96, 54)
    reused = from_raster(job.frame.channels["gbuffer_packed"], cam, 96, 54, reuse=True)
    for a, b in [(fresh.index, reused.index), (fresh.covered, reused.covered), (fresh.depth, reused.depth),
                 (fresh.view_dir, reused.view_dir)] + [(getattr(fresh.surface, f), getattr(reused.surface, f))
                                                       for f in fresh.surface.__dataclass_fields__]:
        assert np.array_equal(a, b)
    again = from_raster(job.frame.channels["gbuffer_packed"], cam, 96, 54, reuse=True)
    assert np.shares_memory(again.surface.p, reused.surface.p) and np.shares_memory(again.view_dir, reused.view_dir)
    r.release()


def test_frame_keys_are_each_chunks_own(gl):
    """Keys made for the whole frame (for_chunks' streams) are, chunk by chunk, those the chunk
    would make itself, so naming a stream changes no image."""
    from rt.embree.frame import RtFrame
    from rt.embree.gbuffer import from_raster
    from rt.embree.sampling import PixelRng

    r, cam, job = prepared_frame(gl, "arcade")
    rt = r.ray_tracing()
    rt.tracer.set_threads(3)
    rt.tracer.min_chunk = 256  # several chunks on a small image
    gb = from_raster(job.frame.channels["gbuffer_packed"], cam, 96, 54)
    rf = RtFrame(rt.data, rt.tracer, gb, r.environment(), r.options, seed=7, index=3, buffers={})
    seen = {}

    def work(cf):
        seen[cf.c.start] = (cf.c, cf.rng(2).key.copy(), cf.rng(2).dim)

    rf.for_chunks(work, streams=(2,))
    assert len(seen) > 1 and 2 in rf.keys
    for c, keys, dim in seen.values():
        assert np.array_equal(keys, PixelRng(7, 3, gb.index[c], 2).key) and dim == 0

    # and the keys that whole-frame kernels make block by block
    assert np.array_equal(block_keys(gb.index, 5, 70, rf.key_base(2)), PixelRng(7, 3, gb.index[5:70], 2).key)
    assert not np.array_equal(block_keys(gb.index, 5, 70, rf.key_base(3)), PixelRng(7, 3, gb.index[5:70], 2).key)
    r.release()


@pytest.mark.parametrize("tracer", ["embree", "vulkan"])
def test_views_of_the_sky_alone(gl, tracer):
    """Found by the viewer's UI fuzz: G-buffer views with gbuffer=rt where no pixel is covered."""
    from tests.scenes_for_tests import lit_plane

    scene = lit_plane()
    cam = Camera(np.array([0.0, 5.0, 0.0]), np.array([0.0, 10.0, 0.0]), np.array([0.0, 0.0, 1.0]), 60)
    cam.fit_clip(scene.diagonal)
    for name in ("albedo", "normal", "roughness", "metallic", "depth", "motion", "ao", "gi", "reflections"):
        img = run(gl, scene, name, size=(16, 12), camera=cam, sets=("gbuffer=rt", f"tracer={tracer}"))
        assert np.isfinite(img).all(), name
