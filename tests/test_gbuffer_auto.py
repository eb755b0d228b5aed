"""Option gbuffer=auto (the default; app/graph.py gbuffer_source): the ray-traced passes take
their primary hits from rays where Embree traces and OpenGL is a CPU rasteriser (llvmpipe here),
unless a denoiser or reproject rasterises the G-buffer anyway; the raster G-buffer elsewhere;
raster and rt as asked."""
import pytest

from app.camera import Camera
from app.graph import gbuffer_source
from app.options import Options
from app.renderer import Renderer
from scenes.builtin import build_builtin


def options(*sets):
    o = Options()
    o.apply(list(sets))
    return o


@pytest.mark.parametrize("sets,tracer,software,expected", [
    ((), "embree", True, "rt"),
    ((), "embree", False, "raster"),
    ((), "vulkan", True, "raster"),
    ((), "cuda", False, "raster"),
    (("denoise=svgf",), "embree", True, "raster"),
    (("denoise=oidn",), "embree", True, "raster"),
    (("reproject=true",), "embree", True, "raster"),
    (("gbuffer=raster",), "embree", True, "raster"),
    (("gbuffer=rt",), "cuda", False, "rt"),
])
def test_auto_picks_rays_on_a_cpu_rasteriser_with_embree(sets, tracer, software, expected):
    asked = next((s.split("=")[1] for s in sets if s.startswith("gbuffer=")), "auto")
    assert options(*sets).get("gbuffer") == asked
    assert gbuffer_source(options(*sets), tracer, software, "gi") == expected
    # the G-buffer's own views and the modes that shade on it keep the raster one unless asked
    for mode in ("normal", "hybrid", "forward"):
        assert gbuffer_source(options(*sets), tracer, software, mode) == (asked if asked != "auto" else "raster")


def test_the_default_frame_here_traces_its_primary_hits(gl):
    """On this machine (llvmpipe, Embree) a ray-traced pass's frame runs no raster G-buffer by
    default, and gives the image gbuffer=rt gives; with SVGF it rasterises one."""
    from app.gl_context import software_gl

    assert software_gl(gl)
    scene = build_builtin("arcade")
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    images = {}
    for name, sets in (("auto", ("tracer=embree",)), ("rt", ("tracer=embree", "gbuffer=rt")),
                       ("svgf", ("tracer=embree", "denoise=svgf", "accumulate=false"))):
        r = Renderer(gl, scene, options(*sets))
        job = r.prepare(cam, 64, 36, "ao")
        names = job.gl_before + job.traced + job.gl_after
        r.compute(job)
        r.finish(job)
        images[name] = r.read_linear()
        r.release()
        assert ("gbuffer" in names) == (name == "svgf"), (name, names)
        assert "primary" in names
    assert images["auto"].tobytes() == images["rt"].tobytes()
