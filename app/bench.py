"""`rtlab bench`: frame times per technique per scene (the study's measurement), plus image
quality against the converged reference path tracer (what the study judged by eye).

Timing: warm-up frames, then timed frames of the technique's own pass at --size.
Quality: at --quality-size, the forward renderer with that one effect ray traced (the hybrid
pass), one frame (noise) and accumulated (bias), against the reference path tracer.
The measurements are units of work (app/sweep.py) run in this process or, with --cluster, as
Ray tasks over a cluster (app/cluster.py).
"""
from __future__ import annotations

import csv
import io
import json
import os
import sys
import time
from pathlib import Path

# the configurations and the measurements on a renderer, under the names they had here
from app.bench_configs import (  # noqa: E402,F401
    ALL_CONFIGS,
    CONFIGS,
    DEFAULT_SCENES,
    DENOISE_FRAMES,
    DENOISED,
    DENOISERS,
    HYBRID_EFFECT,
    PATH_CONFIG,
    PATH_VARIANTS,
    TRANSFERS,
    config_options,
    parse_configs,
    quality_options,
)
from app.camera import Camera, parse_camera
from app.headless import parse_size
from app.image_io import atomic_path, write_text
from app.loading import open_scene
from app.machine import machine_info, source_commit
from app.measure import measure_path, path_cameras, render_image, stats, time_config  # noqa: E402,F401
from app.options import Options
from core.errors import UserError


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
    opts = Options()
    opts.apply(list(common))  # a bad option fails before measuring
    loaded = [(spec, open_scene(spec)) for spec in scenes]  # fail on a bad scene before measuring
    quality_configs = [c for c in configs if "+" not in c] if not args.no_quality else []
    denoised = [c for c in configs if c.partition("+")[2] in DENOISERS] if not args.no_quality else []
    path_frames = 0 if args.no_quality else (args.path_frames if args.path_frames is not None else
                                             (8 if args.quick else 60))
    if path_frames < 0:
        raise UserError("--path-frames must be 0 or more")
    work = len(loaded) * (len(configs) + (len(quality_configs) + 4 if quality_configs else 0) + len(denoised)
                          + (1 if path_frames else 0))
    settings = {"size": list(size), "frames": frames, "seconds": None if frames else seconds, "warmup": warmup,
                "quality_size": list(quality_size), "reference_frames": ref_frames,
                "reference_noise": args.reference_noise,
                "quality_frames": acc_frames, "quality": bool(quality_configs), "budget_ms": args.budget_ms,
                "options": list(common)}
    worker_settings = {**settings, "camera": args.camera, "path_frames": path_frames}
    cluster = getattr(args, "cluster", None)
    if cluster:
        from app.cluster import RayExecutor

        executor = RayExecutor(cluster, worker_settings, tracer=str(opts.get("tracer")),
                               task_cpus=getattr(args, "task_cpus", None))
        machine = None  # each row says which machine measured it (measured_on); the document names them all
    else:
        from app.sweep import LocalExecutor
        from app.sweep_work import Worker

        worker = Worker(worker_settings, scenes=dict(loaded), keep=1)
        executor = LocalExecutor(worker)
        machine = machine_info(worker.context())
    # resumable (rtlab study): each scene's rows are kept as soon as it is measured, and a run with the
    # same settings and configurations takes them instead of measuring the scene again
    resume = getattr(args, "resume", False)
    kept_as = {"settings": settings, "configs": configs, "camera": args.camera,
               "machine": None if cluster else machine}
    progress = Progress(work)
    results: dict[str, list] = {}
    scene_info: dict[str, dict] = {}
    stats_of = {spec: scene.stats() for spec, scene in loaded}

    def keep(w):
        found = _kept_scene(out / "scenes" / f"{_file_name(w.spec)}.json", kept_as) if resume else None
        if found is not None:
            results[w.spec], scene_info[w.name] = found["rows"], found["info"]
            progress.update(work / len(loaded), f"{w.name}: measured before ({out / 'scenes'}), kept")
        return found

    def on_scene(w, rows, info):
        scene = dict(loaded)[w.spec]
        camera = parse_camera(args.camera, scene) if args.camera else Camera.from_view(scene.default_view(),
                                                                                        scene.diagonal)
        scene_info[w.name] = {**stats_of[w.spec], "bvh_build_s": info.get("bvh_build_s"),
                              "camera": camera.to_string(), **info}
        results[w.spec] = rows
        if resume:
            _keep_scene(out / "scenes" / f"{_file_name(w.spec)}.json",
                        {**kept_as, "rows": rows, "info": scene_info[w.name]})

    def on_unit(sweep):  # results.json as units come back: every row so far, "complete": false
        write_results(out, _document(machine or _cluster_machine(sweep, executor, cluster), settings, scene_info,
                                     sweep.rows_so_far(results), args.budget_ms, False))

    from app.sweep import Sweep

    sweep = Sweep(executor, loaded, configs, quality_configs, denoised,
                  {**settings, "exposure": float(opts.get("exposure")), "path_frames": path_frames}, progress,
                  out / "images", on_scene, keep, on_unit)
    t0 = time.perf_counter()
    try:
        sweep.run()
    finally:
        executor.close()
    summary = sweep.summary(time.perf_counter() - t0)
    rows = [r for spec, _ in loaded for r in results[spec]]
    if cluster:
        machine = _cluster_machine(sweep, executor, cluster, rows)
    doc = _document(machine, settings, scene_info, rows, args.budget_ms, True)
    doc["sweep"] = summary
    write_results(out, doc)
    from app.report import write_report

    write_report(out, json.loads((out / "results.json").read_text()), html=False)
    if cluster and summary["units"]:
        print(f"bench: {summary['units']} units in {summary['wall_s']:.0f} s on {summary['workers']} workers "
              f"({sum(summary['worker_s'].values()):.0f} s of worker time, {100 * summary['utilisation']:.0f} % busy)")
    print(f"bench: {len(rows)} runs over {len(scene_info)} scene(s) -> {out}/results.json, results.csv, report.md")
    return 0


def _cluster_machine(sweep, executor, address: str, rows: list | None = None) -> dict:
    """The machine of a cluster run: the kind that measured the most rows, and the cluster
    (its nodes, how tasks asked for them, each kind of machine and the rows it measured)."""
    kinds: dict[str, int] = {}
    for r in rows or []:
        kind = r["measured_on"]["kind"]
        kinds[kind] = kinds.get(kind, 0) + 1
    first = max(kinds, key=kinds.get) if kinds else next(iter(sweep.machines), None)
    return {**sweep.machines.get(first, {}), "cluster": {**executor.describe(), "address": address,
                                                          "kinds": kinds}}


def _document(machine, settings, scene_info, rows, budget_ms, complete: bool) -> dict:
    """results.json: while the sweep runs, the scenes done so far (no recommendations yet)."""
    from app.recommend import recommend

    tracer = next(iter(scene_info.values()))["tracer"] if scene_info else None
    recs = {s: recommend([r for r in rows if r["scene"] == s], budget_ms)
            for s in scene_info} if complete and settings["quality"] else {}
    return {"machine": machine, "commit": source_commit(), "created": time.strftime("%Y-%m-%d %H:%M:%S"),
            "settings": settings,
            "tracer": tracer, "complete": complete, "scenes": scene_info, "results": rows,
            "recommendations": recs}


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
    """The reference path tracer on this renderer in doubling rounds until its own noise is
    below `target` or max_frames are spent (app/sweep.py: ReferenceRounds). Returns (the
    displayed reference, {frames, half_frames, half_flip, half_rmse, target_flip, reached})."""
    from app.measure import reference_batch
    from app.sweep import ReferenceRounds

    opts = Options()
    opts.apply(list(base))
    rounds = ReferenceRounds(max_frames, target, float(opts.get("exposure")))
    while not rounds.done:
        for first, count in rounds.batches():
            rounds.add(first, count, reference_batch(renderer, camera, size, first, count, base))
    return rounds.image(), rounds.info


def write_results(out: Path, doc: dict) -> None:
    write_text(out / "results.json", json.dumps(doc, indent=1))
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["scene", "config", "pass", "accumulate", "frames", "mean_ms", "median_ms", "p5_ms", "p95_ms", "fps",
                "rays_per_frame", "mrays_per_s", "relative_cost", "transfer_ms", "flip_single", "flip_accumulated",
                "psnr_single", "psnr_accumulated", "gain", "measured_on"])
    for r in doc["results"]:
        q = r.get("quality") or {}
        f = r["frame_ms"]
        cost = r.get("relative_cost")
        w.writerow([r["scene"], r["config"], r["pass"], r["accumulate"], r["frames"], f"{f['mean']:.3f}",
                    f"{f['median']:.3f}", f"{f['p5']:.3f}", f"{f['p95']:.3f}", f"{r['fps']:.3f}",
                    int(r["rays_per_frame"]), f"{r['mrays_per_s']:.3f}", "" if cost is None else f"{cost:.3f}",
                    f"{r['transfer_ms']:.3f}"]
                   + [("" if q.get(k) is None else f"{q[k]:.4f}")
                      for k in ("flip_single", "flip_accumulated", "psnr_single", "psnr_accumulated", "gain")]
                   + [(r.get("measured_on") or {}).get("kind", "")])
    with atomic_path(out / "results.csv") as tmp:
        Path(tmp).write_text(buf.getvalue())
