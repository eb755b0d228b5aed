"""The bench as units of work (app/sweep_work.py) run by an executor: in this process one after
another (LocalExecutor), or as Ray tasks over a cluster (app/cluster.py). The sweep plans the
units, scores what comes back (FLIP and PSNR against the reference), merges the reference from
its batches, and hands each scene's rows on as soon as the scene is done.

The reference accumulates in doubling rounds until its two halves agree (ReferenceRounds); each
round's frames are split into batches, one per worker, whose sums add up to one process's run."""
from __future__ import annotations

from collections import deque

import numpy as np

from app.bench_configs import DENOISE_FRAMES, DENOISE_MATCH, RAW_FRAMES
from app.quality import flip_map, mean_bias, mean_flip, psnr, rel_mse, rmse, to_display

BATCHES_PER_WORKER = 4


class ReferenceRounds:
    """The reference path tracer in doubling rounds: after each round the mean of the first half
    of its frames and the mean of the second are compared (FLIP and RMSE of the displayed
    images); it stops when they agree within `target` or max_frames would be exceeded. Frames
    come as batches (first, count) -> sum, made anywhere in any order."""

    def __init__(self, max_frames: int, target: float, exposure: float, split: int = 1):
        self.max_frames, self.target, self.exposure, self.split = max_frames, target, exposure, max(1, split)
        self.half = max(1, min(max_frames // 8, 32))
        self.first: np.ndarray | None = None  # the sum of frames [0, half)
        self.parts: dict[int, tuple[int, np.ndarray]] = {}  # this round's batches by first frame
        self.waiting: set[int] = set()
        self.info: dict = {}
        self.done = False

    def _split(self, start: int, stop: int) -> list[tuple[int, int]]:
        n = stop - start
        k = min(self.split, n)
        edges = [start + (n * i) // k for i in range(k + 1)]
        return [(a, b - a) for a, b in zip(edges[:-1], edges[1:], strict=True)]

    def batches(self) -> list[tuple[int, int]]:
        """The next round's batches (first frame, count)."""
        h = self.half
        out = (self._split(0, h) + self._split(h, 2 * h)) if self.first is None else self._split(h, 2 * h)
        self.waiting = {first for first, _ in out}
        return out

    def add(self, first: int, count: int, total: np.ndarray) -> bool:
        """A batch's sum; True when it completes the round (then `done` says whether it was the last)."""
        self.parts[first] = (count, total)
        self.waiting.discard(first)
        if self.waiting:
            return False
        h = self.half
        ordered = [self.parts[f] for f in sorted(self.parts)]  # the same sums in the same order, however made
        if self.first is None:
            self.first = _total(p for f, p in sorted(self.parts.items()) if f < h)
            second = _total(p for f, p in sorted(self.parts.items()) if f >= h)
        else:
            second = _total(ordered)
        self.parts = {}
        a, b = to_display(self.first / h, self.exposure), to_display(second / h, self.exposure)
        self.info = {"frames": 2 * h, "half_frames": h, "half_flip": mean_flip(a, b), "half_rmse": rmse(a, b),
                     "target_flip": self.target}
        self.everything = self.first + second
        if self.info["half_flip"] <= self.target or 4 * h > self.max_frames:
            self.done = True
            self.info["reached"] = self.info["half_flip"] <= self.target
        else:
            self.first, self.half = self.everything, 2 * h
        return True

    def linear(self) -> np.ndarray:
        """The mean of every frame made (float32)."""
        return (self.everything / (2 * self.half)).astype(np.float32)

    def image(self) -> np.ndarray:
        return to_display(self.linear(), self.exposure)


def _total(parts) -> np.ndarray:
    out = None
    for _, s in parts:
        out = s.astype(np.float64) if out is None else out + s
    return out


class LocalExecutor:
    """Units run in this process, in the order given, on one worker."""
    parallelism = 1

    def __init__(self, worker):
        self.worker, self.queue = worker, deque()

    def submit(self, key, unit: dict, node: str | None = None) -> None:
        self.queue.append((key, unit))

    def next(self):
        key, unit = self.queue.popleft()
        return key, self.worker.run(unit)

    def pending(self) -> int:
        return len(self.queue)

    def close(self) -> None:
        self.worker.release()


class SceneWork:
    """One scene's units and what has come back of them."""

    def __init__(self, spec: str, name: str, sweep: Sweep):
        self.spec, self.name, self.sweep = spec, name, sweep
        self.rows: dict[str, dict] = {}
        self.forward_by_kind: dict[str, float] = {}
        self.images: dict[str, tuple] = {}  # quality config -> (single, accumulated)
        self.scored: dict[str, dict] = {}  # quality config -> its figures
        # a round's frames in more batches than workers where there are several: a worker busy with
        # another unit does not hold the round back
        split = sweep.executor.parallelism * (BATCHES_PER_WORKER if sweep.executor.parallelism > 1 else 1)
        self.reference = ReferenceRounds(sweep.ref_frames, sweep.ref_noise, sweep.exposure, split)
        self.info: dict = {}
        self.open = 0  # units submitted and not yet back
        self.timed_back = 0

    def units(self) -> list[dict]:
        s = self.sweep
        out = [{"kind": "time", "config": c} for c in s.configs]
        if s.quality_configs:
            out += [{"kind": "reference", "first": f, "count": n} for f, n in self.reference.batches()]
            out += [{"kind": "quality", "config": c} for c in s.quality_configs]
        for name in dict.fromkeys(c.partition("+")[0] for c in s.denoised):
            out.append({"kind": "denoise", "config": name,
                        "denoisers": [c.partition("+")[2] for c in s.denoised if c.partition("+")[0] == name]})
        if s.path_frames:
            out.append({"kind": "path"})
        return [{**u, "scene": self.spec} for u in out]


class Sweep:
    """settings: the bench's (sizes, frames, options); scenes: [(spec, Scene)]."""

    def __init__(self, executor, scenes, configs, quality_configs, denoised, settings: dict, progress, images,
                 on_scene, keep=None, on_unit=None):
        self.executor, self.progress, self.images, self.on_scene = executor, progress, images, on_scene
        self.configs, self.quality_configs, self.denoised = configs, quality_configs, denoised
        self.ref_frames, self.ref_noise = settings["reference_frames"], settings["reference_noise"]
        self.exposure, self.path_frames = settings["exposure"], settings["path_frames"]
        self.scenes = [SceneWork(spec, scene.name, self) for spec, scene in scenes]
        self.keep = keep or (lambda work: None)  # a kept scene's record, or None to measure it
        self.on_unit = on_unit or (lambda sweep: None)  # after each unit is back (results so far)
        self.machines: dict[str, dict] = {}  # kind label -> machine_info of the workers that came back
        self.busy: dict[str, float] = {}  # seconds of worker time by unit kind
        self.units_back = 0

    def summary(self, wall_s: float) -> dict:
        """Units run, worker time by kind, and how busy the executor's workers were."""
        busy = sum(self.busy.values())
        return {"units": self.units_back, "workers": self.executor.parallelism, "wall_s": wall_s,
                "worker_s": dict(self.busy), "utilisation": busy / (wall_s * self.executor.parallelism)
                if wall_s > 0 else None}

    def run(self) -> None:
        from app.image_io import write_png

        self.write_png = write_png
        todo = []
        for work in self.scenes:
            found = self.keep(work)
            if found is None:
                todo.append(work)
        # one scene at a time in this process (its renderer released before the next); a cluster
        # takes every scene's units at once
        waves = [[w] for w in todo] if self.executor.parallelism == 1 else [todo]
        for wave in waves:
            for work in wave:
                for unit in work.units():
                    self._submit(work, unit)
            while self.executor.pending():
                (work, unit), result = self.executor.next()
                work.open -= 1
                self._back(work, unit, result)

    def rows_so_far(self, finished: dict) -> list[dict]:
        """Every scene's rows in order: a finished (or kept) scene's from `finished` by spec, the
        others' timed rows back so far (no quality yet)."""
        out = []
        for work in self.scenes:
            out += finished.get(work.spec) or [work.rows[c] for c in self.configs if c in work.rows]
        return out

    def _submit(self, work: SceneWork, unit: dict, node: str | None = None) -> None:
        work.open += 1
        self.executor.submit((work, unit), unit, node)

    def _back(self, work: SceneWork, unit: dict, result: dict) -> None:
        kind, who = unit["kind"], result["worker"]
        self.busy[kind] = self.busy.get(kind, 0.0) + result.get("seconds", 0.0)
        self.units_back += 1
        self.machines.setdefault(who["kind"], who["machine"])
        if not work.info:
            work.info = {"tracer": who["tracer"]}
        if who.get("bvh_build_s") is not None:
            work.info.setdefault("bvh_build_s", who["bvh_build_s"])
        if kind == "time":
            self._timed(work, unit, result, who)
        elif kind == "reference":
            if work.reference.add(unit["first"], unit["count"], result["sum"]):
                if work.reference.done:
                    self._reference_done(work)
                else:
                    for first, count in work.reference.batches():
                        self._submit(work, {"kind": "reference", "scene": work.spec, "first": first, "count": count})
        elif kind == "quality":
            work.images[unit["config"]] = (result["single"], result["accumulated"])
            self.write_png(self.images / f"{work.name}_{unit['config']}.png", result["accumulated"])
            self._score(work)
        elif kind == "denoise":
            self._denoise(work, unit, result["images"])
        elif kind == "path":
            work.info["path"] = result["path"]
            self.progress.update(1, f"{work.name} camera path")
        if work.open == 0:
            self._finish(work)
        self.on_unit(self)

    def _timed(self, work: SceneWork, unit: dict, result: dict, who: dict) -> None:
        row = result["row"]
        config = unit["config"]
        row.update(scene=work.name, tracer=who["tracer"]["name"],
                   measured_on={"host": who["host"], "node": who["node"], "kind": who["kind"],
                                "device": who["tracer"]["device"], "gpus": who.get("gpus", [])})
        if unit.get("forward_only"):  # the forward baseline again, on a kind of machine that had none
            work.forward_by_kind[who["kind"]] = row["frame_ms"]["mean"]
        else:
            work.rows[config] = row
            if config == "forward":
                work.forward_by_kind.setdefault(who["kind"], row["frame_ms"]["mean"])
            work.timed_back += 1
            self.progress.update(1, f"{work.name} {config}: {row['frame_ms']['mean']:.1f} ms")
        if work.timed_back == len(self.configs) and not unit.get("forward_only"):
            # timings are compared only between rows measured on the same kind of machine: the
            # forward baseline again on each kind that measured rows but not it (once)
            missing = {r["measured_on"]["kind"]: r["measured_on"]["node"] for r in work.rows.values()
                       if r["measured_on"]["kind"] not in work.forward_by_kind}
            for _, node in sorted(missing.items()):
                self._submit(work, {"kind": "time", "scene": work.spec, "config": "forward", "forward_only": True},
                             node)

    def _reference_done(self, work: SceneWork) -> None:
        import sys

        ref = work.reference
        work.info["reference"] = ref.info
        self.write_png(self.images / f"{work.name}_reference.png", ref.image())
        if not ref.info["reached"]:
            print(f"bench: warning: {work.name}'s reference still differs from itself by FLIP "
                  f"{ref.info['half_flip']:.4f} between two halves of {ref.info['half_frames']} frames (target "
                  f"{self.ref_noise}; --reference-frames {self.ref_frames} spent): its quality figures carry that "
                  "noise", file=sys.stderr)
        self.progress.update(2, f"{work.name} reference ({ref.info['frames']} frames, FLIP "
                                f"{ref.info['half_flip']:.4f} between halves)")
        self._score(work)

    def _score(self, work: SceneWork) -> None:
        """Each configuration's quality whose images are back, once the reference is."""
        if not work.reference.done:
            return
        ref = work.reference.image()
        forward = work.images.get("forward")
        if forward is None:
            return
        if "flip_forward" not in work.info:
            work.info["flip_forward"], error_map = flip_map(ref, forward[0])
            self.write_png(self.images / f"{work.name}_forward_flip.png", error_map)
        flip_fwd = work.info["flip_forward"]
        for config, (single, acc) in list(work.images.items()):
            if config in work.scored:
                continue
            if config == "forward":
                q = {"flip_single": flip_fwd, "flip_accumulated": flip_fwd, "psnr_single": psnr(ref, single),
                     "psnr_accumulated": psnr(ref, acc), "gain": 0.0}
                self.progress.update(3, f"{work.name} forward quality")
            else:
                flip_acc, error_map = flip_map(ref, acc)  # the map of the image written, for the report
                self.write_png(self.images / f"{work.name}_{config}_flip.png", error_map)
                q = {"flip_single": mean_flip(ref, single), "flip_accumulated": flip_acc,
                     "psnr_single": psnr(ref, single), "psnr_accumulated": psnr(ref, acc)}
                q["gain"] = flip_fwd - q["flip_accumulated"]
                self.progress.update(1, f"{work.name} {config} quality: FLIP {q['flip_accumulated']:.3f}")
            work.scored[config] = q  # rows take it when the scene is done

    def _denoise(self, work: SceneWork, unit: dict, images: dict) -> None:
        name = unit["config"]
        converged = images["converged"]
        self.write_png(self.images / f"{work.name}_{name}_converged.png", converged)
        raw = {n: images[f"raw_{n}"] for n in RAW_FRAMES}
        raw_flip = {n: mean_flip(converged, raw[n]) for n in RAW_FRAMES}
        flickers = images["flicker"]
        for d in unit["denoisers"]:
            config, image = f"{name}+{d}", images[d]
            self.write_png(self.images / f"{work.name}_{config}.png", image)
            flip, error_map = flip_map(converged, image)
            self.write_png(self.images / f"{work.name}_{config}_flip.png", error_map)
            rec = {"frames": DENOISE_FRAMES, "converged_frames": self.ref_frames, "flip": flip,
                   "match": DENOISE_MATCH.get(d, DENOISE_FRAMES),
                   **{f"flip_raw_{n}": v for n, v in raw_flip.items()},
                   "bias": mean_bias(converged, image),
                   f"bias_raw_{DENOISE_FRAMES}": mean_bias(converged, raw[DENOISE_FRAMES]),
                   "rel_mse": rel_mse(converged, image),
                   f"rel_mse_raw_{DENOISE_FRAMES}": rel_mse(converged, raw[DENOISE_FRAMES]),
                   "flicker": flickers[d], f"flicker_raw_{DENOISE_FRAMES}": flickers["raw"],
                   "flicker_raw_1": flickers["raw_1"]}
            work.info.setdefault("_denoise", {})[config] = rec
            raws = ", ".join(f"{n} {raw_flip[n]:.4f}" for n in RAW_FRAMES)
            self.progress.update(1, f"{work.name} {config}: FLIP {rec['flip']:.4f}, bias {100 * rec['bias']:+.1f} % "
                                    f"(raw frames: {raws})")

    def _finish(self, work: SceneWork) -> None:
        """Every unit of the scene is back: its rows in configuration order, handed on."""
        scored, denoise = work.scored, work.info.pop("_denoise", {})
        rows = []
        for config in self.configs:
            r = work.rows[config]
            # None where no forward frame was measured on that kind of machine (its node was lost)
            r["forward_ms"] = work.forward_by_kind.get(r["measured_on"]["kind"])
            r["relative_cost"] = r["frame_ms"]["mean"] / r["forward_ms"] if r["forward_ms"] else None
            base = config.partition("+")
            if config in denoise:
                r["denoise"] = denoise[config]
            elif base[0] in scored and base[2] in ("", "acc"):  # NAME+acc shares NAME's images
                r["quality"] = scored[base[0]]
            rows.append(r)
        work.info.pop("flip_forward", None)
        self.on_scene(work, rows, work.info)
