"""`rtlab warmup`: every ray-traced pass rendered once, small, on the Embree backend, so that its
compiled kernels are cached before a user's first frame, then on each GPU backend with hardware
ray tracing (warm_gpu_shaders: slangpy's shader caches); and the viewer's cold start, which runs
it in a background process and shows its progress.

The passes compile in parallel processes (one per core, at most one per family of passes that
share kernels), each recording what it compiled and how long that took (rt.backends)."""
from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
import time

from rt.effects import EFFECTS

PROG = "rtlab"

# (key, pass, options): every kernel's code. Families share most of their kernels, so each
# compiles in one process; the heaviest first.
FAMILIES = (
    (("shadows", "shadows", []), ("shadows", "shadows", ["shadows.lights=one"]), ("gi", "gi", []),
     ("gi", "gi", ["gi.bounces=2", "gi.shadows=false"])),
    (("reflections", "reflections", []), ("reflections", "reflections", ["reflections.max_depth=2"]),
     ("hybrid", "hybrid", ["hybrid.gi=true", "hybrid.reflections=true"])),
    (("ao", "ao", []),),
    (("gbuffer=rt", "normal", ["gbuffer=rt"]), ("reference", "reference", [])),
)
# --software-gpu: every pipeline of a software Vulkan device (lavapipe: up to a minute each on a
# CPU; Mesa caches them on disk), in two processes of their own beside the kernels' (the test
# suite's workers would otherwise each compile them). Not hybrid: its device pipelines are these,
# and its Embree kernels are the kernels' processes' to compile
SOFTWARE_FAMILIES = (
    (("vulkan:reference", "reference", ["tracer=vulkan"]),),
    (("vulkan:reflections", "reflections", ["tracer=vulkan"]), ("vulkan:gi", "gi", ["tracer=vulkan"]),
     ("vulkan:ao", "ao", ["tracer=vulkan"]), ("vulkan:shadows", "shadows", ["tracer=vulkan"]),
     ("vulkan:gbuffer=rt", "normal", ["tracer=vulkan", "gbuffer=rt"])),
)
VARIANTS = tuple(v for family in FAMILIES + SOFTWARE_FAMILIES for v in family)


def default_jobs() -> int:
    return max(1, min(len(FAMILIES), os.cpu_count() or 1))


def compile_variants(indices: list[int]) -> None:
    """Render variants VARIANTS[i] (in this process), printing `start I` and `done I SECONDS`."""
    from app.camera import Camera
    from app.gl_context import create_headless_context
    from app.options import Options
    from app.renderer import Renderer
    from rt.backends import record_compile, watch_first_frame
    from scenes.builtin import build_builtin

    ctx = create_headless_context()
    scene = build_builtin("cafe")  # point, emissive and environment lights: every light kind's code
    camera = Camera.from_view(scene.default_view(), scene.diagonal)
    spent, compiled = {}, {}
    for i in indices:
        key, pass_name, sets = VARIANTS[i]
        print(f"start {i}", flush=True)
        on_device = any(s.startswith("tracer=") for s in sets)
        t0 = time.perf_counter()
        options = Options()
        options.apply(sets)
        renderer = Renderer(ctx, scene, options)
        with watch_first_frame("embree", []) as watch:
            renderer.render(camera, 32, 18, pass_name)
        renderer.release()
        spent[key] = spent.get(key, 0.0) + time.perf_counter() - t0
        compiled[key] = compiled.get(key, False) or watch.compiles > 0
        if not on_device and i == max(j for j in indices if VARIANTS[j][0] == key):  # the key's last variant
            record_compile(key, spent[key] if compiled[key] else None)
        print(f"done {i} {time.perf_counter() - t0:.1f}", flush=True)


_workers: list = []  # run_warmup's worker processes


def _stop_workers(signum, frame) -> None:
    for proc in _workers:
        with contextlib.suppress(OSError):
            proc.terminate()
    for proc in _workers:
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=10)
    raise SystemExit(128 + signum)


def run_warmup(jobs: int | None = None, software_gpu: bool = False, force: bool = False) -> int:
    """Compile every variant in `jobs` processes (default: one per core, up to the families'
    count), leaving out the kernels this version has compiled already (unless force), and with
    software_gpu the software Vulkan device's pipelines in processes of their own; progress lines
    `rtlab: warmup K/N: NAME (T s)` as each variant starts."""
    from rt.backends import compiled_keys

    done = set() if force else compiled_keys()
    if software_gpu and not _software_vulkan():
        print(f"{PROG}: no software Vulkan device here: --software-gpu leaves its pipelines out")
        software_gpu = False
    families, start = [], 0
    for family in FAMILIES + (SOFTWARE_FAMILIES if software_gpu else ()):
        indices = list(range(start, start + len(family)))
        start += len(family)
        if family in FAMILIES and {key for key, _, _ in family} <= done:
            continue
        families.append((family in SOFTWARE_FAMILIES, indices))
    kernel_families = [f for software, f in families if not software]
    jobs = max(1, min(jobs or default_jobs(), len(kernel_families) or 1))
    groups = [[] for _ in range(jobs)]
    for indices in kernel_families:  # families in order, to the process with the least so far
        min(groups, key=len).extend(indices)
    groups += [indices for software, indices in families if software]
    todo = sum(len(g) for g in groups)
    if not todo:
        print(f"{PROG}: every kernel is compiled for this version already (--force compiles them again)")
        return warm_gpu_shaders()
    t0 = time.perf_counter()
    signal.signal(signal.SIGTERM, _stop_workers)  # the viewer's stop(): end the workers, then this process
    procs = _workers[:] = [subprocess.Popen([sys.executable, "-m", "app.cli", "warmup", "--variants",
                                             ",".join(map(str, g))], stdout=subprocess.PIPE,
                                            stderr=subprocess.STDOUT, text=True) for g in groups if g]
    lock, started, failures = threading.Lock(), [0], []

    def follow(proc):
        last = ""
        for line in proc.stdout:
            word, _, rest = line.strip().partition(" ")
            if word == "start":
                _, pass_name, sets = VARIANTS[int(rest)]
                with lock:
                    started[0] += 1
                    label = pass_name + (f" ({' '.join(sets)})" if sets else "")
                    print(f"{PROG}: warmup {started[0]}/{todo}: {label} "
                          f"({time.perf_counter() - t0:.0f} s)", flush=True)
            elif word != "done" and line.strip():
                last = line.strip()
        if proc.wait() != 0:
            failures.append(last or f"exit status {proc.returncode}")

    threads = [threading.Thread(target=follow, args=(p,), daemon=True) for p in procs]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    if failures:
        print(f"{PROG}: error: compiling the kernels failed: {failures[0][:300]}", file=sys.stderr)
        return 1
    print(f"{PROG}: kernels compiled and cached in {time.perf_counter() - t0:.0f} s ({len(procs)} processes)")
    return warm_gpu_shaders()


def _software_vulkan() -> bool:
    """Whether this machine's Vulkan device is a software one (lavapipe)."""
    from core.errors import UserError
    from rt.backends import describe_device as describe

    try:
        info = describe("vulkan")
    except UserError:  # no slangpy
        return False
    return info is not None and info.software


GPU_MODES = (*EFFECTS, "hybrid")


def warm_gpu_shaders(kinds: tuple[str, ...] | None = None) -> int:
    """Each pass once on every GPU backend with hardware ray tracing here, so that slangpy's
    on-disk caches (rt/slang/device.py) hold its shaders and pipelines before a user's first
    frame. Software Vulkan (lavapipe) is left out: Mesa caches its pipelines itself, and
    compiling them all costs minutes on a CPU. kinds: the backends to warm (default: those)."""
    from app.camera import Camera
    from app.gl_context import create_headless_context
    from app.options import Options
    from app.renderer import Renderer
    from core.errors import UserError
    from rt.backends import describe_device as describe
    from scenes.builtin import build_builtin

    if kinds is None:
        try:
            kinds = tuple(k for k in ("cuda", "vulkan") if (info := describe(k)) is not None and not info.software)
        except UserError:  # no slangpy
            return 0
    if not kinds:
        return 0
    ctx = create_headless_context()
    scene = build_builtin("cafe")
    camera = Camera.from_view(scene.default_view(), scene.diagonal)
    for kind in kinds:
        t0 = time.perf_counter()
        options = Options()
        options.apply([f"tracer={kind}", "hybrid.gi=true", "hybrid.reflections=true"])
        renderer = Renderer(ctx, scene, options)
        try:
            for mode in GPU_MODES:
                renderer.render(camera, 32, 18, mode)
            options.set("denoise", "svgf")  # the device's SVGF kernels (rt/slang/svgf.py)
            renderer.render(camera, 32, 18, "ao")
        except UserError as e:
            print(f"{PROG}: error: the {kind} shaders: {e}", file=sys.stderr)
            return 1
        finally:
            renderer.release()
        print(f"{PROG}: the {kind} device's shaders compiled and cached in {time.perf_counter() - t0:.0f} s", flush=True)
    ctx.release()
    return 0


class BackgroundWarmup:
    """`rtlab warmup` beside the viewer: one core fewer than the machine has (the viewer keeps
    one), in a session of its own so that stop() ends its workers too."""

    def __init__(self):
        self.status = "compiling ray-tracing kernels in the background (once per version)..."
        self.failed = ""
        jobs = max(1, (os.cpu_count() or 1) - 1)
        self.process = subprocess.Popen([sys.executable, "-m", "app.cli", "warmup", "--jobs", str(jobs)],
                                        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                        start_new_session=True)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        last = ""
        for line in self.process.stdout:
            line = line.strip()
            if "warmup " in line:  # "rtlab: warmup 3/9: shadows (40 s)"
                step = line.split("warmup ", 1)[1]
                self.status = f"compiling ray-tracing kernels in the background: {step}"
            last = line or last
        if self.process.wait() != 0:
            self.failed = f"background kernel compile failed: {last[:200]}"

    @property
    def running(self) -> bool:
        return self.process.poll() is None or self._reader.is_alive()

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()  # the warmup ends its workers and waits for them
            try:
                self.process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(self.process.pid, signal.SIGKILL)  # everything of its session
                self.process.wait()
