"""`rtlab bench`: frame times per technique per scene (the study's measurement), plus image
quality against the converged reference path tracer (what the study judged by eye).

Timing: warm-up frames, then timed frames of the technique's own pass at --size.
Quality: at --quality-size, the forward renderer with that one effect ray traced (the hybrid
pass), one frame (noise) and accumulated (bias), against the reference path tracer.
"""
from __future__ import annotations

import csv
import io
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from app.camera import Camera, parse_camera
from app.gl_context import check_frame_size, create_headless_context
from app.headless import parse_size
from app.image_io import atomic_path, write_png, write_text
from app.loading import open_scene
from app.machine import machine_info
from app.options import Options
from app.raster.gl_fence import Fences
from app.renderer import Renderer
from core.errors import UserError
from rt.hybrid import EFFECTS as HYBRID_EFFECTS

# name: (pass, options); ray-traced ones also run as NAME+acc with accumulation on, and the
# one-sample ones as NAME+svgf and NAME+oidn: each frame denoised, without accumulation
CONFIGS = {
    "forward": ("forward", []),
    "reflections": ("reflections", []),
    "shadows_all": ("shadows", ["shadows.lights=all"]),
    "shadows_one": ("shadows", ["shadows.lights=one"]),
    "gi_1": ("gi", ["gi.rays_per_pixel=1", "gi.shadows=false"]),
    "gi_4": ("gi", ["gi.rays_per_pixel=4", "gi.shadows=false"]),
    "gi_shadows": ("gi", ["gi.rays_per_pixel=1", "gi.shadows=true"]),
    "ao_1": ("ao", ["ao.rays_per_pixel=1"]),
    "ao_4": ("ao", ["ao.rays_per_pixel=4"]),
    "hybrid": ("hybrid", []),
    "hybrid_gi": ("hybrid", ["hybrid.gi=true"]),  # RT shadows and RT GI (one ray a pixel) in the forward frame
}
HYBRID_EFFECT = {"reflections": "reflections", "shadows_all": "shadows", "shadows_one": "shadows", "gi_1": "gi",
                 "gi_4": "gi", "gi_shadows": "gi", "ao_1": "ao", "ao_4": "ao"}
DENOISERS = ("svgf", "oidn")
# profiler entries that move images between GL, the host and a ray-tracing device
TRANSFERS = ("gbuffer_readback", "gbuffer_share", "device_readback", "upload", "share")
DENOISED = ("gi_1", "gi_shadows", "ao_1", "shadows_one")
DENOISE_FRAMES = 16  # a denoised configuration's image: its 16th frame (SVGF's history fills), against 16 accumulated
ALL_CONFIGS = (list(CONFIGS) + [f"{c}+acc" for c in CONFIGS if c != "forward"]
               + [f"{c}+{d}" for c in DENOISED for d in DENOISERS])
DEFAULT_SCENES = ("arcade", "street", "cafe", "park", "temple")


def parse_configs(text: str | None) -> list[str]:
    if not text:
        return ALL_CONFIGS
    out = []
    for name in (c.strip() for c in text.split(",")):
        if name not in ALL_CONFIGS:
            raise UserError(f"--configs: unknown configuration {name!r}; choose from {', '.join(ALL_CONFIGS)}")
        out.append(name)
    if "forward" not in out:
        out.insert(0, "forward")  # every cost is relative to the forward baseline
    return out


def config_options(config: str) -> tuple[str, list[str]]:
    base, _, suffix = config.partition("+")
    pass_name, sets = CONFIGS[base]
    if suffix in DENOISERS:
        return pass_name, sets + ["accumulate=false", f"denoise={suffix}"]
    return pass_name, sets + [f"accumulate={'true' if suffix else 'false'}"]


def quality_options(config: str) -> list[str]:
    """The forward renderer with only this configuration's effect ray traced."""
    base = config.partition("+")[0]
    _, sets = CONFIGS[base]
    if base.startswith("hybrid"):
        return list(sets)
    effect = HYBRID_EFFECT[base]
    return sets + [f"hybrid.{e}={'true' if e == effect else 'false'}" for e in HYBRID_EFFECTS]


class Progress:
    def __init__(self, total: float, stream=sys.stderr):
        self.total, self.done, self.t0, self.stream = max(total, 1e-9), 0.0, time.perf_counter(), stream
        self.tty = stream.isatty()

    def update(self, amount: float, label: str) -> None:
        self.done += amount
        frac = min(self.done / self.total, 1.0)
        elapsed = time.perf_counter() - self.t0
        eta = elapsed / frac * (1 - frac) if frac > 0 else 0
        bar = "#" * int(frac * 30)
        line = f"[{bar:<30}] {frac:5.1%}  {elapsed:6.0f}s elapsed, ETA {eta:5.0f}s  {label}"
        if self.tty:
            self.stream.write("\r" + line[:150].ljust(150))
            if frac >= 1:
                self.stream.write("\n")
        else:
            self.stream.write(line + "\n")
        self.stream.flush()


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
            "gpu_ms": gpu_ms, "host_overhead_ms": ft["mean"] - gpu_ms}


def render_image(renderer: Renderer, camera: Camera, size, pass_name: str, sets: list[str], frames: int,
                 seed: int = 0, base: tuple = (), accumulate: bool = True) -> np.ndarray:
    """The displayed image after `frames` frames: their mean, or with accumulate False the last."""
    opts = Options()
    opts.apply(list(base) + sets + [f"accumulate={'true' if accumulate else 'false'}"])
    renderer.options = opts
    renderer.seed = seed
    renderer.reset()
    for _ in range(frames):
        renderer.render(camera, *size, pass_name)
    return renderer.read_display()


def run_bench(args) -> int:
    size = parse_size(args.size if not args.quick or args.size != "1280x720" else "160x90")
    quality_size = parse_size(args.quality_size) if args.quality_size else (
        (96, 54) if args.quick else (max(size[0] // 4, 32), max(size[1] // 4, 18)))
    configs = parse_configs(args.configs)
    scenes = [s.strip() for s in (args.scenes or ",".join(DEFAULT_SCENES)).split(",") if s.strip()]
    if args.frames is not None and args.frames < 1:
        raise UserError("--frames must be at least 1")
    if args.seconds is not None and args.seconds <= 0:
        raise UserError("--seconds must be positive")
    if not args.reference_noise > 0:
        raise UserError("--reference-noise must be positive (a mean FLIP, e.g. 0.01)")
    frames = args.frames if args.frames is not None else (2 if args.quick else None)
    seconds = args.seconds if args.seconds is not None else 5.0
    warmup = 1 if args.quick else 2
    ref_frames = args.reference_frames or (16 if args.quick else 256)
    acc_frames = args.quality_frames or (4 if args.quick else 32)
    out = Path(args.out)
    try:
        (out / "images").mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UserError(f"cannot create {out}: {e.strerror}") from None
    common = tuple(args.set or ())  # options for every configuration
    Options().apply(list(common))  # a bad option fails before measuring
    loaded = [(spec, open_scene(spec)) for spec in scenes]  # fail on a bad scene before measuring
    ctx = create_headless_context()
    check_frame_size(ctx, *size)
    timed_configs = [c for c in configs]
    quality_configs = [c for c in configs if "+" not in c] if not args.no_quality else []
    denoised = [c for c in configs if c.partition("+")[2] in DENOISERS] if not args.no_quality else []
    path_frames = 0 if args.no_quality else (args.path_frames if args.path_frames is not None else
                                             (8 if args.quick else 60))
    if path_frames < 0:
        raise UserError("--path-frames must be 0 or more")
    work = len(loaded) * (len(timed_configs) + (len(quality_configs) + 4 if quality_configs else 0) + len(denoised)
                          + (1 if path_frames else 0))
    progress = Progress(work)
    settings = {"size": list(size), "frames": frames, "seconds": None if frames else seconds, "warmup": warmup,
                "quality_size": list(quality_size), "reference_frames": ref_frames,
                "reference_noise": args.reference_noise,
                "quality_frames": acc_frames, "quality": bool(quality_configs), "budget_ms": args.budget_ms,
                "options": list(common)}
    # resumable (rtlab study): each scene's rows are kept as soon as it is measured, and a run with the
    # same settings and configurations takes them instead of measuring the scene again
    resume = getattr(args, "resume", False)
    machine = machine_info(ctx)
    kept_as = {"settings": settings, "configs": configs, "camera": args.camera, "machine": machine}
    results, scene_info = [], {}
    for spec, scene in loaded:
        part = out / "scenes" / f"{_file_name(spec)}.json"
        found = _kept_scene(part, kept_as) if resume else None
        if found is not None:
            rows, scene_info[scene.name] = found["rows"], found["info"]
            results += rows
            progress.update(work / len(loaded), f"{scene.name}: measured before ({part}), kept")
            continue
        camera = parse_camera(args.camera, scene) if args.camera else Camera.from_view(scene.default_view(),
                                                                                        scene.diagonal)
        options = Options()
        options.apply(list(common))
        renderer = Renderer(ctx, scene, options, prefetch=True)
        t0 = time.perf_counter()
        backend = renderer.ray_tracing()
        build_s = time.perf_counter() - t0
        tracer = {"name": backend.name, "device": getattr(backend, "adapter", "CPU")}
        scene_info[scene.name] = {**scene.stats(), "bvh_build_s": build_s, "camera": camera.to_string(),
                                  "tracer": tracer}
        rows = []
        for config in timed_configs:
            row = time_config(ctx, renderer, camera, size, config, warmup, frames, seconds, common)
            row["scene"], row["tracer"] = scene.name, tracer["name"]
            rows.append(row)
            progress.update(1, f"{scene.name} {config}: {row['frame_ms']['mean']:.1f} ms")
        base = next(r for r in rows if r["config"] == "forward")["frame_ms"]["mean"]
        for r in rows:
            r["relative_cost"] = r["frame_ms"]["mean"] / base
        if quality_configs:
            scene_info[scene.name]["reference"] = measure_quality(
                renderer, camera, quality_size, scene.name, rows, quality_configs, ref_frames, acc_frames,
                out / "images", progress, common, args.reference_noise)
        if denoised:
            measure_denoisers(renderer, camera, quality_size, scene.name, rows, denoised, ref_frames, out / "images",
                              progress, common)
        if path_frames:
            scene_info[scene.name]["path"] = measure_path(renderer, camera, quality_size, scene.diagonal, path_frames,
                                                          max(ref_frames // 4, 4), common)
            progress.update(1, f"{scene.name} camera path")
        renderer.release()
        results += rows
        if resume:
            _keep_scene(part, {**kept_as, "rows": rows, "info": scene_info[scene.name]})
    from app.recommend import recommend

    tracer = next(iter(scene_info.values()))["tracer"]
    doc = {"machine": machine, "created": time.strftime("%Y-%m-%d %H:%M:%S"),
           "settings": settings,
           "tracer": tracer,
           "scenes": scene_info, "results": results,
           "recommendations": {s: recommend([r for r in results if r["scene"] == s], args.budget_ms)
                               for s in scene_info} if quality_configs else {}}
    write_results(out, doc)
    from app.report import write_report

    write_report(out, doc, html=False)
    print(f"bench: {len(results)} runs over {len(scene_info)} scene(s) -> {out}/results.json, results.csv, report.md")
    return 0


def _file_name(spec: str) -> str:
    """A scene spec (built-in name, name:detail, or a path) as a file name."""
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in Path(spec).name)[:100] or "scene"


def _kept_scene(path: Path, kept_as: dict):
    """A scene's rows kept by an earlier run with the same settings, or None."""
    try:
        found = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    same = all(found.get(k) == json.loads(json.dumps(v)) for k, v in kept_as.items())
    return found if same and isinstance(found.get("rows"), list) and isinstance(found.get("info"), dict) else None


def _keep_scene(path: Path, record: dict) -> None:
    """Written whole (a temporary file renamed): an interrupted run leaves the last scene out."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(record))
    os.replace(tmp, path)


def converge_reference(renderer, camera, size, max_frames: int, target: float, base: tuple = ()):
    """The reference path tracer accumulated in doubling rounds until its own noise is below
    `target` or max_frames are spent: after each round the mean of its first half of frames and
    the mean of its second (2 x all - first: independent numbers, frame indices differ) are
    compared, FLIP and RMSE of the displayed images. Returns (the displayed reference of every
    frame so far, {frames, half_frames, half_flip, half_rmse, target_flip, reached})."""
    from app.quality import mean_flip, rmse, to_display

    opts = Options()
    opts.apply(list(base) + ["accumulate=true"])
    renderer.options, renderer.seed = opts, 1
    renderer.reset()
    exposure = float(opts.get("exposure"))
    done, first = 0, None
    half = max(1, min(max_frames // 8, 32))
    info = {}
    while True:
        while done < half:
            renderer.render(camera, *size, "reference")
            done += 1
        if first is None:  # the first half of the next comparison
            first = renderer.read_linear().copy()
        while done < 2 * half:
            renderer.render(camera, *size, "reference")
            done += 1
        everything = renderer.read_linear().copy()
        a, b = to_display(first, exposure), to_display(2.0 * everything - first, exposure)
        info = {"frames": done, "half_frames": half, "half_flip": mean_flip(a, b), "half_rmse": rmse(a, b),
                "target_flip": target}
        if info["half_flip"] <= target or 4 * half > max_frames:
            break
        first, half = everything, 2 * half
    info["reached"] = info["half_flip"] <= target
    return renderer.read_display(), info


def measure_quality(renderer, camera, size, scene_name, rows, configs, ref_frames, acc_frames, images, progress,
                    base: tuple = (), ref_noise: float = 0.01) -> dict:
    """Each configuration's quality into its rows; returns the reference's own noise
    (converge_reference)."""
    ref, noise = converge_reference(renderer, camera, size, ref_frames, ref_noise, base)
    write_png(images / f"{scene_name}_reference.png", ref)
    if not noise["reached"]:
        print(f"bench: warning: {scene_name}'s reference still differs from itself by FLIP {noise['half_flip']:.4f} "
              f"between two halves of {noise['half_frames']} frames (target {ref_noise}; --reference-frames "
              f"{ref_frames} spent): its quality figures carry that noise", file=sys.stderr)
    progress.update(2, f"{scene_name} reference ({noise['frames']} frames, FLIP {noise['half_flip']:.4f} "
                       "between halves)")
    from app.quality import mean_flip, psnr

    fwd = render_image(renderer, camera, size, "forward", [], 1, base=base)
    write_png(images / f"{scene_name}_forward.png", fwd)
    flip_fwd = mean_flip(ref, fwd)
    progress.update(2, f"{scene_name} forward quality")
    by_config = {r["config"]: r for r in rows}
    for config in configs:
        if config == "forward":
            by_config[config]["quality"] = {"flip_single": flip_fwd, "flip_accumulated": flip_fwd,
                                            "psnr_single": psnr(ref, fwd), "psnr_accumulated": psnr(ref, fwd),
                                            "gain": 0.0}
            progress.update(1, f"{scene_name} forward")
            continue
        sets = quality_options(config)
        single = render_image(renderer, camera, size, "hybrid", sets, 1, base=base)
        acc = render_image(renderer, camera, size, "hybrid", sets, acc_frames, base=base)
        write_png(images / f"{scene_name}_{config}.png", acc)
        q = {"flip_single": mean_flip(ref, single), "flip_accumulated": mean_flip(ref, acc),
             "psnr_single": psnr(ref, single), "psnr_accumulated": psnr(ref, acc)}
        q["gain"] = flip_fwd - q["flip_accumulated"]
        for r in rows:  # the +acc variant shares the images of its configuration; the denoised ones
            if r["config"] in (config, f"{config}+acc"):  # are measured by what they do (measure_denoisers)
                r["quality"] = q
        progress.update(1, f"{scene_name} {config} quality: FLIP {q['flip_accumulated']:.3f}")
    return noise


def measure_denoisers(renderer, camera, size, scene_name, rows, configs, converged_frames, images, progress,
                      base: tuple = ()) -> None:
    """Each denoised configuration's image (its DENOISE_FRAMES-th frame, the denoiser's own
    history built over the ones before) against the same pass converged over converged_frames
    accumulated frames (another seed), beside that pass's one raw frame and DENOISE_FRAMES
    accumulated raw frames: mean FLIP of each, and the bias of the mean brightness (the denoised
    and the accumulated image's), into the rows' "denoise"."""
    from app.quality import mean_bias, mean_flip

    by_config = {r["config"]: r for r in rows}
    for name in dict.fromkeys(c.partition("+")[0] for c in configs):
        pass_name, sets = CONFIGS[name]
        converged = render_image(renderer, camera, size, pass_name, sets, converged_frames, seed=1, base=base)
        raw = {n: render_image(renderer, camera, size, pass_name, sets, n, base=base) for n in (1, DENOISE_FRAMES)}
        write_png(images / f"{scene_name}_{name}_converged.png", converged)
        for config in (c for c in configs if c.partition("+")[0] == name):
            denoiser = config.partition("+")[2]
            image = render_image(renderer, camera, size, pass_name, sets + [f"denoise={denoiser}"], DENOISE_FRAMES,
                                 base=base, accumulate=False)
            write_png(images / f"{scene_name}_{config}.png", image)
            by_config[config]["denoise"] = {
                "frames": DENOISE_FRAMES, "converged_frames": converged_frames, "flip": mean_flip(converged, image),
                "flip_raw_1": mean_flip(converged, raw[1]), f"flip_raw_{DENOISE_FRAMES}": mean_flip(converged,
                                                                                                  raw[DENOISE_FRAMES]),
                "bias": mean_bias(converged, image), f"bias_raw_{DENOISE_FRAMES}": mean_bias(converged,
                                                                                          raw[DENOISE_FRAMES])}
            d = by_config[config]["denoise"]
            progress.update(1, f"{scene_name} {config}: FLIP {d['flip']:.4f}, bias {100 * d['bias']:+.1f} % (raw: 1 "
                               f"frame {d['flip_raw_1']:.4f}, {DENOISE_FRAMES} frames {d[f'flip_raw_{DENOISE_FRAMES}']:.4f})")


PATH_CONFIG = "gi_1"  # the configuration flown along the camera path (PATH_VARIANTS: accumulated, denoised)
PATH_CHECKS = 4  # frames of the path compared with their converged image (the last one among them)
PATH_VARIANTS = {"restart": ["accumulate=true", "reproject=false"], "reproject": ["accumulate=true", "reproject=true"],
                 "svgf": ["accumulate=false", "denoise=svgf"]}


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
        opts.apply(list(base) + sets + extra)
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


def write_results(out: Path, doc: dict) -> None:
    write_text(out / "results.json", json.dumps(doc, indent=1))
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["scene", "config", "pass", "accumulate", "frames", "mean_ms", "median_ms", "p5_ms", "p95_ms", "fps",
                "rays_per_frame", "mrays_per_s", "relative_cost", "transfer_ms", "flip_single", "flip_accumulated",
                "psnr_single", "psnr_accumulated", "gain"])
    for r in doc["results"]:
        q = r.get("quality") or {}
        f = r["frame_ms"]
        w.writerow([r["scene"], r["config"], r["pass"], r["accumulate"], r["frames"], f"{f['mean']:.3f}",
                    f"{f['median']:.3f}", f"{f['p5']:.3f}", f"{f['p95']:.3f}", f"{r['fps']:.3f}",
                    int(r["rays_per_frame"]), f"{r['mrays_per_s']:.3f}", f"{r['relative_cost']:.3f}",
                    f"{r['transfer_ms']:.3f}"] + [("" if q.get(k) is None else f"{q[k]:.4f}")
                                                  for k in ("flip_single", "flip_accumulated", "psnr_single",
                                                            "psnr_accumulated", "gain")])
    with atomic_path(out / "results.csv") as tmp:
        Path(tmp).write_text(buf.getvalue())
