"""SVGF variants against raw accumulation: mean FLIP against the converged pass, bias, per scene."""
import sys, time
import numpy as np
from app.bench import CONFIGS, render_image, DENOISE_FRAMES
from app.camera import Camera
from app.gl_context import create_headless_context
from app.loading import open_scene
from app.options import Options
from app.quality import mean_bias, mean_flip
from app.renderer import Renderer

tracer, size = sys.argv[1], tuple(int(x) for x in sys.argv[2].split("x"))
VARIANTS = {"paper": ["svgf.feedback=true", "svgf.alpha=0.2"], "avg_phi4": [], "avg_phi8": ["svgf.phi_color=8"],
            "avg_phi16": ["svgf.phi_color=16"], "fb_a32": ["svgf.feedback=true"]}
ctx = create_headless_context()
for name in ("arcade", "street", "cafe", "park", "temple"):
    scene = open_scene(name)
    opts = Options(); opts.apply([f"tracer={tracer}"])
    r = Renderer(ctx, scene, opts, prefetch=True)
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    for cfg in ("gi_1", "ao_1"):
        pass_name, sets = CONFIGS[cfg]
        base = (f"tracer={tracer}",)
        t0 = time.perf_counter()
        conv = render_image(r, cam, size, pass_name, sets, 1024, seed=1, base=base)
        raw = {n: render_image(r, cam, size, pass_name, sets, n, base=base) for n in (1, 4, 16)}
        line = [f"{name:7} {cfg:5} raw1 {mean_flip(conv, raw[1]):.4f} raw4 {mean_flip(conv, raw[4]):.4f} "
                f"raw16 {mean_flip(conv, raw[16]):.4f} ({mean_bias(conv, raw[16]):+.3f})"]
        for v, extra in VARIANTS.items():
            img = render_image(r, cam, size, pass_name, sets + ["denoise=svgf"] + extra, DENOISE_FRAMES, base=base,
                               accumulate=False)
            line.append(f"{v} {mean_flip(conv, img):.4f} ({mean_bias(conv, img):+.3f})")
        print(" | ".join(line), f"[{time.perf_counter() - t0:.0f} s]", flush=True)
    r.release()
