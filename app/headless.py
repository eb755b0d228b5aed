"""`rtlab shot`: render a scene without a window and write PNG / raw float32 images."""
from __future__ import annotations

import contextlib
import sys
import time
from pathlib import Path

import numpy as np

from app.camera import Camera, parse_camera
from app.compare import DIFF, REFERENCE_FRAMES, check_compare, compose, flip_map, split_columns
from app.gl_context import check_frame_size, create_headless_context
from app.graph import check_denoise
from app.image_io import check_output, write_npy, write_png
from app.loading import open_scene
from app.options import Options
from app.passes import CHANNEL_VIEWS, RASTER, check_pass
from app.renderer import Renderer
from core.errors import UserError
from rt.backends import compile_keys, compile_notices, resolve, watch_first_frame


def parse_size(text: str) -> tuple[int, int]:
    w, sep, h = text.lower().partition("x")
    try:
        width, height = int(w), int(h)
    except ValueError:
        raise UserError(f"--size expects WIDTHxHEIGHT, got {text!r}") from None
    if not sep or not (1 <= width <= 16384 and 1 <= height <= 16384):
        raise UserError(f"--size expects WIDTHxHEIGHT within 1..16384, got {text!r}")
    return width, height


PROGRESS_FRAMES = 2000  # longer runs print an estimate and their progress
MAX_FRAMES = 100_000_000


def run_shot(args) -> int:
    check_pass(args.pass_name)
    options = Options()
    options.apply(args.set or [])
    check_denoise(args.pass_name, options)
    width, height = parse_size(args.size)
    if not 1 <= args.frames <= MAX_FRAMES:
        raise UserError(f"--frames must be within 1..{MAX_FRAMES:,}, got {args.frames}")
    compare = getattr(args, "compare", None)
    check_compare(args.pass_name, compare, getattr(args, "split", 0.5))
    suffix = f"_vs_{compare}" if compare else ""
    out = args.out or f"{Path(args.scene).stem.replace(':', '_')}_{args.pass_name}{suffix}.png"
    check_output(out, ".png", "screenshots")  # every output is checked before any work
    if args.raw:
        check_output(args.raw, ".npy", "raw images")
    scene = open_scene(args.scene)
    camera = parse_camera(args.camera, scene) if args.camera else Camera.from_view(scene.default_view(), scene.diagonal)
    ctx = create_headless_context()
    check_frame_size(ctx, width, height, "raster" if args.pass_name in RASTER + CHANNEL_VIEWS else "ray-traced")
    traced = args.pass_name not in RASTER + CHANNEL_VIEWS or (compare not in (None, *RASTER))
    renderer = Renderer(ctx, scene, options, prefetch=traced)
    renderer.seed = args.seed
    tracer = resolve(options.get("tracer"))
    keys = compile_keys(tracer, args.pass_name, renderer.gbuffer_source(args.pass_name))
    right_pass = "reference" if compare == DIFF else compare
    right = compile_keys(tracer, right_pass, renderer.gbuffer_source(right_pass)) if compare else []
    for line in compile_notices(list(dict.fromkeys(keys + right))):  # a wait that would otherwise look like a hang
        print(f"rtlab: {line}", file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    _render_frames(renderer, camera, width, height, args.pass_name, args.frames,
                   first=watch_first_frame(tracer, keys))  # the first frame compiles what is missing
    elapsed = time.perf_counter() - t0
    for line in renderer.notices:
        print(f"rtlab: {line}", file=sys.stderr, flush=True)
    display, linear = renderer.read_display(), (renderer.read_linear() if args.raw else None)
    note = ""
    if compare:
        display, linear, note = _compared(renderer, camera, width, height, args, display, linear, elapsed)
    write_png(out, display)
    if args.raw:
        write_npy(args.raw, linear)
    print(f"{scene.name}: {args.pass_name} {width}x{height}, {args.frames} frame(s) in {elapsed:.2f} s{note} -> {out}"
          + (f", {args.raw}" if args.raw else ""))
    renderer.release()
    return 0


def _compared(renderer, camera, width: int, height: int, args, left: np.ndarray, left_linear, left_s: float):
    """The split image of `--compare`, its raw image (None where not asked for: the linear
    images, or beside `diff` each pixel's FLIP, split at the same column), and what the summary
    line adds."""
    right_name = args.compare
    t0 = time.perf_counter()
    raw = left_linear is not None
    if right_name == DIFF:
        frames = max(REFERENCE_FRAMES, args.frames)
        _render_frames(renderer, camera, width, height, "reference", frames)
        right, mean, *flip_values = flip_map(renderer.read_display(), left, values=raw)
        right_linear = flip_values[0] if raw else None
        label, note = f"FLIP vs reference ({frames} frames): {mean:.3f}", f", mean FLIP {mean:.4f} vs the reference"
    else:
        _render_frames(renderer, camera, width, height, right_name, args.frames)
        right, right_linear = renderer.read_display(), (renderer.read_linear() if raw else None)
        right_s = time.perf_counter() - t0
        label = f"{right_name}: {right_s / args.frames * 1e3:.1f} ms/frame"
        note = f"; {right_name} {right_s:.2f} s"
    image = compose(left, right, args.split, (f"{args.pass_name}: {left_s / args.frames * 1e3:.1f} ms/frame", label))
    linear = split_columns(left_linear, right_linear, args.split) if raw else None
    return image, linear, note


def _render_frames(renderer, camera, width: int, height: int, pass_name: str, frames: int,
                   first=None) -> None:
    """Renders the frames (the first inside the context manager `first`, if given); a long run
    states its estimate, then its progress every 10 s on stderr (Ctrl-C stops it, and nothing is
    written)."""
    t0 = last = time.perf_counter()
    for k in range(frames):
        with first if (k == 0 and first is not None) else contextlib.nullcontext():
            renderer.render(camera, width, height, pass_name)
        if frames < PROGRESS_FRAMES:
            continue
        now = time.perf_counter()
        if k == 4:
            eta = (now - t0) / 5 * (frames - 5)
            print(f"rtlab: {frames:,} frames will take about {_duration(eta)} (Ctrl-C stops without writing)",
                  file=sys.stderr, flush=True)
        elif now - last >= 10.0 and k > 4:
            last = now
            eta = (now - t0) / (k + 1) * (frames - k - 1)
            print(f"rtlab: frame {k + 1:,} of {frames:,}, about {_duration(eta)} left", file=sys.stderr, flush=True)


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    if seconds < 172800:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.0f} days"
