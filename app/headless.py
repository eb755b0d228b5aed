"""`rtlab shot`: render a scene without a window and write PNG / raw float32 images."""
from __future__ import annotations

import time
from pathlib import Path

from app.camera import Camera, parse_camera
from app.gl_context import create_headless_context
from app.image_io import write_npy, write_png
from app.options import Options
from app.passes import check_pass
from app.renderer import Renderer
from core.errors import UserError
from scenes.loaders import load_scene


def parse_size(text: str) -> tuple[int, int]:
    w, sep, h = text.lower().partition("x")
    try:
        width, height = int(w), int(h)
    except ValueError:
        raise UserError(f"--size expects WIDTHxHEIGHT, got {text!r}") from None
    if not sep or not (1 <= width <= 16384 and 1 <= height <= 16384):
        raise UserError(f"--size expects WIDTHxHEIGHT within 1..16384, got {text!r}")
    return width, height


def run_shot(args) -> int:
    check_pass(args.pass_name)
    options = Options()
    options.apply(args.set or [])
    width, height = parse_size(args.size)
    if args.frames < 1:
        raise UserError(f"--frames must be at least 1, got {args.frames}")
    out = args.out or f"{Path(args.scene).stem.replace(':', '_')}_{args.pass_name}.png"
    scene = load_scene(args.scene)
    camera = parse_camera(args.camera, scene) if args.camera else Camera.from_view(scene.default_view(), scene.diagonal)
    ctx = create_headless_context()
    renderer = Renderer(ctx, scene, options)
    renderer.seed = args.seed
    t0 = time.perf_counter()
    for _ in range(args.frames):
        renderer.render(camera, width, height, args.pass_name)
    elapsed = time.perf_counter() - t0
    write_png(out, renderer.read_display())
    if args.raw:
        write_npy(args.raw, renderer.read_linear())
    print(f"{scene.name}: {args.pass_name} {width}x{height}, {args.frames} frame(s) in {elapsed:.2f} s -> {out}"
          + (f", {args.raw}" if args.raw else ""))
    renderer.release()
    return 0
