"""What the bench measures on one renderer: a configuration's timed frames, images after some
frames, a batch of the reference's frames (summed, so batches made anywhere add up to one run),
each effect's quality image, the denoisers against their converged pass, and the scripted camera
path. A unit of the sweep (app/sweep_work.py) is one of these on a worker's renderer."""
from __future__ import annotations

import time

import numpy as np

from app.bench_configs import (
    CONFIGS,
    DENOISE_FRAMES,
    FLICKER_FRAMES,
    PATH_CHECKS,
    PATH_CONFIG,
    PATH_VARIANTS,
    RAW_FRAMES,
    TRANSFERS,
    config_options,
    frame_split,
    quality_options,
)
from app.camera import Camera
from app.options import Options
from app.raster.gl_fence import Fences
from app.renderer import Renderer


def stats(ms: list[float]) -> dict:
    a = np.asarray(ms, float)
    return {"mean": float(a.mean()), "median": float(np.median(a)), "p5": float(np.percentile(a, 5)),
            "p95": float(np.percentile(a, 95)), "min": float(a.min()), "max": float(a.max())}


def time_config(ctx, renderer: Renderer, camera: Camera, size, config: str, warmup: int, frames: int | None,
                seconds: float | None, base: tuple = ()) -> dict:
    """base: options set for every configuration (bench --set, e.g. tracer=vulkan)."""
    pass_name, sets = config_options(config)
    opts = Options()
    opts.apply(list(base) + sets)
    renderer.options = opts
    renderer.reset()
    for _ in range(warmup):
        renderer.render(camera, *size, pass_name)
    ctx.finish()
    # as a swap chain presents: the host waits for the GL work of the frame frames_in_flight - 1
    # before this one (the device backend's end_frame likewise), not for this frame's
    fences, keep = Fences(ctx), int(opts.get("frames_in_flight")) - 1
    times, passes, rays = [], {}, []
    start = time.perf_counter()
    while True:
        t0 = time.perf_counter()
        renderer.render(camera, *size, pass_name)
        fences.insert()
        fences.wait(keep)
        times.append((time.perf_counter() - t0) * 1e3)
        for name, ms in renderer.profiler.frame.items():
            passes.setdefault(name, []).append(ms)
        rays.append(renderer.profiler.counters.get("rays", 0))
        n = len(times)
        if frames is not None and n >= frames:
            break
        if frames is None and n >= 2 and time.perf_counter() - start >= seconds:
            break
    fences.release()
    renderer.settle()
    ft = stats(times)
    mean_rays = float(np.mean(rays))
    kind = renderer.profiler.kind
    # GPU work of the frame: GL's timer queries and a GPU backend's timestamps; the rest of the
    # frame time is the host's (Python, waits, transfers)
    gpu_ms = float(sum(np.mean(v) for k, v in passes.items() if kind.get(k) == "gpu"))
    return {"config": config, "pass": pass_name, "options": sets, "accumulate": config.endswith("+acc"),
            "frames": len(times), "frame_ms": ft, "fps": 1000.0 / ft["mean"], "rays_per_frame": mean_rays,
            "mrays_per_s": mean_rays / ft["mean"] / 1e3,
            "passes_ms": {k: float(np.mean(v)) for k, v in passes.items()},
            "pass_kind": {k: kind.get(k, "cpu") for k in passes},
            "transfer_ms": float(sum(np.mean(passes[k]) for k in TRANSFERS if k in passes)),
            "gpu_ms": gpu_ms, "host_overhead_ms": ft["mean"] - gpu_ms,
            "split_ms": frame_split({k: float(np.mean(v)) for k, v in passes.items()}, ft["mean"],
                                    {k: kind.get(k, "cpu") for k in passes})}


def render_image(renderer: Renderer, camera: Camera, size, pass_name: str, sets: list[str], frames: int,
                 seed: int = 0, base: tuple = (), accumulate: bool = True) -> np.ndarray:
    """The displayed image after `frames` frames: their mean, or with accumulate False the last."""
    return render_frames(renderer, camera, size, pass_name, sets, frames, 1, seed, base, accumulate)[-1]


def render_frames(renderer: Renderer, camera: Camera, size, pass_name: str, sets: list[str], frames: int, keep: int,
                  seed: int = 0, base: tuple = (), accumulate: bool = True) -> list[np.ndarray]:
    """The displayed images after each of the last `keep` of `frames` frames (at least the one
    before any frame where frames is 0)."""
    opts = Options()
    opts.apply(list(base) + sets + [f"accumulate={'true' if accumulate else 'false'}"])
    renderer.options, renderer.seed = opts, seed
    renderer.reset()
    shown = []
    for k in range(frames):
        renderer.render(camera, *size, pass_name)
        if k >= frames - keep:
            shown.append(renderer.read_display())
    return shown or [renderer.read_display()]


def reference_batch(renderer: Renderer, camera: Camera, size, first: int, count: int, base: tuple = ()) -> np.ndarray:
    """The sum of the reference path tracer's frames first .. first + count - 1 (seed 1), linear
    RGB, float64: frames are numbered as one run numbers them, so the sums of batches made by any
    number of workers add up to that run's sum (to float rounding)."""
    opts = Options()
    opts.apply(list(base) + ["accumulate=true", "max_frames=0"])
    renderer.options, renderer.seed = opts, 1
    renderer.reset(first_frame=first)
    for _ in range(count):
        renderer.render(camera, *size, "reference")
    return renderer.read_linear().astype(np.float64) * count


def quality_images(renderer: Renderer, camera: Camera, size, config: str, acc_frames: int,
                   base: tuple = ()) -> tuple[np.ndarray, np.ndarray]:
    """The forward frame with this configuration's effect ray traced: one frame and acc_frames
    accumulated (the forward baseline: its one frame, twice)."""
    if config == "forward":
        fwd = render_image(renderer, camera, size, "forward", [], 1, base=base)
        return fwd, fwd
    sets = quality_options(config)
    single = render_image(renderer, camera, size, "hybrid", sets, 1, base=base)
    return single, render_image(renderer, camera, size, "hybrid", sets, acc_frames, base=base)


def denoised_images(renderer: Renderer, camera: Camera, size, name: str, denoisers: list[str], converged_frames: int,
                    base: tuple = ()) -> dict:
    """A one-sample configuration's pass converged over converged_frames accumulated frames
    (seed 1), its raw frames (each of RAW_FRAMES accumulated) and each denoiser's
    DENOISE_FRAMES-th frame (its own history built over the ones before); under "flicker", the
    flicker (quality.flicker) of the last FLICKER_FRAMES frames shown of the raw frames
    accumulated ("raw"), of the raw frames alone ("raw_1") and of each denoiser's."""
    from app.quality import flicker

    pass_name, sets = CONFIGS[name]
    out = {"converged": render_image(renderer, camera, size, pass_name, sets, converged_frames, seed=1, base=base)}
    for n in RAW_FRAMES:
        if n != DENOISE_FRAMES:  # that one comes with its flicker below
            out[f"raw_{n}"] = render_image(renderer, camera, size, pass_name, sets, n, base=base)
    shown = render_frames(renderer, camera, size, pass_name, sets, DENOISE_FRAMES, FLICKER_FRAMES, base=base)
    out[f"raw_{DENOISE_FRAMES}"], out["flicker"] = shown[-1], {"raw": flicker(shown)}
    alone = render_frames(renderer, camera, size, pass_name, sets, FLICKER_FRAMES, FLICKER_FRAMES, base=base,
                          accumulate=False)
    out["flicker"]["raw_1"] = flicker(alone)
    for d in denoisers:
        shown = render_frames(renderer, camera, size, pass_name, sets + [f"denoise={d}"], DENOISE_FRAMES,
                              FLICKER_FRAMES, base=base, accumulate=False)
        out[d], out["flicker"][d] = shown[-1], flicker(shown)
    return out


def path_cameras(camera: Camera, diagonal: float, frames: int) -> list[Camera]:
    """A dolly along the view direction with a slow sideways drift: 0.2 % of the scene's
    diagonal a frame forward, 0.05 % sideways."""
    right, _, forward = camera.basis()
    out = []
    for k in range(frames):
        c = camera.copy()
        step = diagonal * (0.002 * forward + 0.0005 * right) * k
        c.eye, c.target = c.eye + step, c.target + step
        out.append(c)
    return out


def measure_path(renderer, camera, size, diagonal, frames, converged_frames, base: tuple = ()) -> dict:
    """PATH_CONFIG along a scripted camera path (path_cameras): accumulated with reproject on
    and off (the study's restart on motion), and denoised by SVGF (its history reprojected and
    clamped: what it lags or ghosts shows here); at PATH_CHECKS frames of the path, mean FLIP
    against that camera's converged image (converged_frames still frames); and the flicker, the
    mean change of a point's displayed luminance from one frame to the next (where the raster
    G-buffer sees the same surface at the reprojected pixel), over the whole path."""
    from app.quality import mean_flip

    pass_name, sets = CONFIGS[PATH_CONFIG]
    cams = path_cameras(camera, diagonal, frames)
    checks = sorted({int(round(x)) for x in np.linspace(frames - 1, 0, PATH_CHECKS, endpoint=False)})
    converged = {k: render_image(renderer, cams[k], size, pass_name, sets, converged_frames, seed=1, base=base)
                 for k in checks}
    result = {"config": PATH_CONFIG, "frames": frames, "checked_frames": checks, "converged_frames": converged_frames}
    for key, extra in PATH_VARIANTS.items():
        opts = Options()
        # the flicker follows surfaces through the raster G-buffer's motion: rasterised unless asked otherwise
        opts.apply(["gbuffer=raster"] + list(base) + sets + extra)
        renderer.options, renderer.seed = opts, 0
        renderer.reset()
        flips, changes, prev = [], [], None
        for k, cam in enumerate(cams):
            renderer.render(cam, *size, pass_name)
            shown = renderer.read_display().astype(np.float32) / 255.0
            surface = _surface(renderer.frame)
            if prev is not None and surface is not None:
                changes.append(_frame_change(prev, (shown, surface)))
            prev = (shown, surface)
            if k in converged:
                flips.append(mean_flip(converged[k], renderer.read_display()))
        result[key] = {
            "flip_mean": float(np.mean(flips)), "flips": flips,
            "flicker": float(np.mean(changes)) if changes else None}
    return result


def _surface(frame):
    """The frame's raster positions and motion vectors, top row first, or None without them."""
    if "g_position" not in frame.channels or "g_motion" not in frame.channels:
        return None
    out = []
    for name in ("g_position", "g_motion"):
        tex = frame.channels[name]
        w, h = tex.size
        out.append(np.frombuffer(tex.read(), np.float32).reshape(h, w, tex.components)[::-1])
    return out


def _frame_change(prev, now) -> float:
    """Mean |luminance change| of the points seen in both frames: each pixel of `now` against the
    previous frame's pixel its motion vector points back to, where that pixel saw the same point
    (within 1 % of the depth)."""
    (img0, (pos0, _)), (img1, (pos1, motion)) = prev, now
    h, w = img1.shape[:2]
    y, x = np.mgrid[0:h, 0:w]
    px = np.rint(x - motion[..., 0]).astype(int)
    py = np.rint(y + motion[..., 1]).astype(int)  # motion is in GL's y-up pixels; rows run down
    ok = (px >= 0) & (px < w) & (py >= 0) & (py < h) & (pos1[..., 3] > 0)
    pxc, pyc = np.clip(px, 0, w - 1), np.clip(py, 0, h - 1)
    same = ok & (np.linalg.norm(pos0[pyc, pxc, :3] - pos1[..., :3], axis=-1) < 0.01 * np.maximum(pos1[..., 3], 1e-6))
    if not same.any():
        return 0.0
    lum = np.array([0.2126, 0.7152, 0.0722], np.float32)
    return float(np.abs(img1[same] @ lum - img0[pyc, pxc][same] @ lum).mean())
