"""SVGF with and without the resolve against raw accumulation: FLIP against 1024 frames.
argv: SIZE SCENES CONFIGS [REFERENCE_FRAMES]; env TRACER (default embree), ONLY (variant names, comma-separated)."""
import os, sys, time
sys.path.insert(0, ".")
from app.bench import CONFIGS, render_image, DENOISE_FRAMES
from app.camera import Camera
from app.gl_context import create_headless_context
from app.loading import open_scene
from app.options import Options
from app.quality import mean_bias, mean_flip
from app.renderer import Renderer

size = tuple(int(x) for x in sys.argv[1].split("x"))
scenes = sys.argv[2].split(",")
cfgs = sys.argv[3].split(",")
VARIANTS = {"svgf": ["svgf.resolve=false"], "res10": ["svgf.resolve=true"], "res05": ["svgf.resolve=true", "svgf.resolve_alpha=0.05"],
            "res20": ["svgf.resolve=true", "svgf.resolve_alpha=0.2"]}
if os.environ.get("ONLY"):
    VARIANTS = {k: v for k, v in VARIANTS.items() if k in os.environ["ONLY"].split(",")}
BASE = (f"tracer={os.environ.get('TRACER', 'embree')}",)
ctx = create_headless_context()
for name in scenes:
    scene = open_scene(name)
    opts = Options()
    opts.apply(list(BASE))
    r = Renderer(ctx, scene, opts, prefetch=True)
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    for cfg in cfgs:
        pass_name, sets = CONFIGS[cfg]
        t0 = time.perf_counter()
        conv = render_image(r, cam, size, pass_name, sets, int(sys.argv[4]) if len(sys.argv) > 4 else 1024, seed=1,
                            base=BASE)
        raw16 = render_image(r, cam, size, pass_name, sets, 16, base=BASE)
        line = [f"{name:7} {cfg:5} raw16 {mean_flip(conv, raw16):.4f} ({mean_bias(conv, raw16):+.3f})"]
        for v, extra in VARIANTS.items():
            img = render_image(r, cam, size, pass_name, sets + ["denoise=svgf"] + extra, DENOISE_FRAMES,
                               base=BASE, accumulate=False)
            line.append(f"{v} {mean_flip(conv, img):.4f} ({mean_bias(conv, img):+.3f})")
        print(" | ".join(line), f"[{time.perf_counter() - t0:.0f} s]", flush=True)
    r.release()
