"""How much of a GPU frame is the per-frame wait: the bench's frames as they are, then with the
device waits removed (images tear: timing only)."""
import sys, time, warnings
warnings.simplefilter("ignore")
import numpy as np
from app.gl_context import create_headless_context
from app.renderer import Renderer
from app.camera import Camera
from app.options import Options
from scenes.loaders import load_scene
import app.raster.interop as interop

tracer = sys.argv[1]
W, H = 1920, 1080
ctx = create_headless_context()
for scene_name in ("arcade", "cafe"):
    scene = load_scene(scene_name)
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    for pass_name, sets in (("shadows", ["shadows.lights=one"]), ("gi", ["gi.shadows=true"]), ("ao", [])):
        for mode in ("wait", "nowait"):
            o = Options(); o.apply([f"tracer={tracer}", "accumulate=false"] + sets)
            r = Renderer(ctx, scene, o)
            b = r.ray_tracing()
            orig = (interop.Interop.device_done, type(b).gpu_ms, type(b).rays_traced)
            if mode == "nowait":
                interop.Interop.device_done = lambda self: self.backend._submit()
                type(b).gpu_ms = property(lambda self: {})
                type(b).rays_traced = property(lambda self: self._counted)
                if mode == "nowait" and tracer == "cuda":
                    share = r.sharing(b)._share
                    share.cu = dict(share.cu, sync=lambda: 0)
                    enc = type(b)._encoding
                    class Wrap:
                        def __init__(s, e): s.e = e
                        def __getattr__(s, k): return getattr(s.e, k)
                        def copy_buffer(s, *a): pass
                    b._encoding = lambda: Wrap(enc(b)) if True else None
            for _ in range(5):
                r.render(cam, W, H, pass_name)
            ctx.finish(); b.wait()
            n = 150
            t = time.perf_counter()
            for _ in range(n):
                r.render(cam, W, H, pass_name)
                ctx.finish()
            b.wait()
            ms = (time.perf_counter() - t) / n * 1e3
            interop.Interop.device_done, type(b).gpu_ms, type(b).rays_traced = orig
            gpu = r.profiler.frame
            print(f"{tracer} {scene_name} {pass_name} {mode}: {ms:.2f} ms/frame  last frame passes {dict((k, round(v,2)) for k,v in gpu.items())}", flush=True)
            r.release()
