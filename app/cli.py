"""`rtlab` command line. User mistakes print one line and exit non-zero; never a traceback."""
from __future__ import annotations

import argparse
import json
import logging
import sys
import warnings

from app.passes import ALL
from core.errors import UserError
from rt.backends import init_process

PROG = "rtlab"


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2, like every other user error
        raise UserError(f"{self.prog}: {message}")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description="When does ray-traced lighting beat rasterised lighting? View, measure, "
                                       "and explain, pass by pass.",
                epilog="--debug (anywhere): show the traceback of an internal error, and libraries' log lines")
    sub = p.add_subparsers(dest="command", parser_class=_Parser)

    s = sub.add_parser("scenes", help="list built-in scenes (or a file's statistics)")
    s.add_argument("paths", nargs="*", help="scene files or built-in names (name:detail) to describe")
    s.add_argument("--json", action="store_true", help="machine-readable output")

    s = sub.add_parser("shot", help="render a headless screenshot")
    s.add_argument("scene", help="built-in name (arcade, street, cafe, park, temple; name:detail) or a file")
    s.add_argument("--pass", dest="pass_name", default="forward", metavar="NAME", help=f"one of {', '.join(ALL)}")
    s.add_argument("--set", action="append", metavar="KEY=VALUE", help="option, e.g. ao.radius=0.5 (repeatable)")
    s.add_argument("--size", default="640x360", help="WIDTHxHEIGHT (default 640x360)")
    s.add_argument("--frames", type=int, default=1, help="frames to render; accumulated when accumulate=true")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--camera", help='a named view or "eye=x,y,z;target=x,y,z;up=x,y,z;fov=DEG"')
    s.add_argument("--out", help="PNG path (default SCENE_PASS.png)")
    s.add_argument("--raw", help="also write the linear image before tone mapping (.npy, float32 HxWx3; with "
                   "--compare split as the PNG is, and beside diff each pixel's FLIP)")
    s.add_argument("--compare", metavar="PASS|diff", help="a second pass right of the divider (same camera and "
                   "options), or diff: FLIP of --pass against the reference path tracer")
    s.add_argument("--split", type=float, default=0.5, metavar="F", help="the divider at this fraction of the "
                   "width (default 0.5)")

    s = sub.add_parser("view", help="open the interactive viewer")
    s.add_argument("scene", nargs="?", default=None, help="built-in name or file (default arcade)")
    s.add_argument("--pass", dest="pass_name", default="forward", metavar="NAME")
    s.add_argument("--set", action="append", metavar="KEY=VALUE")
    s.add_argument("--size", default="1280x720")
    s.add_argument("--compare", metavar="PASS|diff", help="split view: this pass right of the divider, or diff: "
                   "FLIP of --pass against the reference")
    s.add_argument("--split", type=float, default=0.5, metavar="F", help="the divider at this fraction of the width")
    s.add_argument("--bookmarks", metavar="FILE.json", help="camera bookmarks to load at start (the panel's format)")
    s.add_argument("--exit-after", type=int, default=0, metavar="N", help="render N frames, then exit")
    s.add_argument("--screenshot", metavar="FILE.png", help="save the window (with the UI) before exiting")

    s = sub.add_parser("bench", help="benchmark techniques per scene: frame times, quality, recommendations")
    s.add_argument("--scenes", help="comma-separated built-in names or files (default: the five built-ins)")
    s.add_argument("--configs", help="comma-separated configurations (default: all; see README)")
    s.add_argument("--size", default="1280x720", help="timing resolution (default 1280x720)")
    s.add_argument("--seconds", type=float, help="timed seconds per configuration (default 5)")
    s.add_argument("--frames", type=int, help="timed frames per configuration (instead of --seconds)")
    s.add_argument("--camera", help="a named view or camera string (default: each scene's first view)")
    s.add_argument("--quality-size", help="resolution of the quality measurement (default: a quarter of --size)")
    s.add_argument("--reference-frames", type=int, help="most frames of the converged reference (default 256)")
    s.add_argument("--reference-noise", type=float, default=0.01,
                   help="the reference accumulates until two halves of it differ by at most this mean FLIP "
                        "(default 0.01) or --reference-frames are spent")
    s.add_argument("--quality-frames", type=int, help="accumulated frames for the bias measurement (default 32)")
    s.add_argument("--no-quality", action="store_true", help="time only (no reference, FLIP, PSNR)")
    s.add_argument("--path-frames", type=int, help="frames of the camera path flown with gi_1 accumulated, with and "
                   "without reproject (default 60, --quick 8; 0: none)")
    s.add_argument("--budget-ms", type=float, help="frame-time budget for the recommendation rule")
    s.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="option for every configuration, e.g. tracer=vulkan (repeatable)")
    s.add_argument("--out", default="bench", help="output folder (default ./bench)")
    s.add_argument("--quick", action="store_true", help="small smoke run: 160x90, 2 frames, small reference")
    add_cluster_arguments(s)
    s.add_argument("--perf", action="store_true", help="ray-tracing efficiency, thread scaling, transfers, BVH builds")
    s.add_argument("--load", nargs="?", const="default", metavar="TRIANGLES,TEXTURES",
                   help="big scenes: a generated glTF of that many triangles and textures (default 10000000,500; "
                        "--quick 200000,20): first open, cached reopen, BVH build, device memory, first frame")
    s.add_argument("--perf-sizes", help="sizes for --perf (default 640x360,1280x720)")
    s.add_argument("--perf-rounds", type=int, help="sweeps through the thread counts for --perf's scaling, "
                   "keeping each count's fastest frame (default 2; more on a noisy shared host)")

    s = sub.add_parser("study", help="the whole study on the best backend here: every configuration at 1920x1080, "
                       "converged references, report; resumable")
    from app.study import add_arguments

    add_arguments(s)
    add_cluster_arguments(s)

    s = sub.add_parser("warmup", help="compile every ray-tracing kernel ahead of use (once per version)")
    s.add_argument("--jobs", type=int, metavar="N", help="processes compiling side by side (default: one per "
                   "core, at most 4)")
    s.add_argument("--software-gpu", action="store_true", help="also the software Vulkan device's pipelines "
                   "(lavapipe: minutes on a CPU; the test suite uses them)")
    s.add_argument("--force", action="store_true", help="compile again what this version has compiled already")
    s.add_argument("--variants", help=argparse.SUPPRESS)  # one worker's share (app/warmup.py)

    s = sub.add_parser("devices", help="list the ray-tracing backends available here, and what tracer=auto picks")
    s.add_argument("--json", action="store_true", help="machine-readable output")

    s = sub.add_parser("report", help="write tables, plots and recommendations from a bench folder")
    s.add_argument("dir")
    s.add_argument("--budget-ms", type=float, help="frame-time budget for the recommendation rule")
    return p


def cmd_scenes(args) -> int:
    from scenes.builtin import BUILTINS
    from scenes.loaders import load_scene

    names = args.paths or list(BUILTINS)
    rows = []
    for name in names:
        scene = load_scene(name)
        st = scene.stats()
        st["description"] = BUILTINS[name.partition(":")[0]][1] if name.partition(":")[0] in BUILTINS else ""
        rows.append(st)
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    print(f"{'scene':<10} {'triangles':>10} {'lights':>7} {'emissive':>9} {'materials':>9}  {'bounds (m)':<34} views")
    for r in rows:
        lo, hi = r["bounds_min"], r["bounds_max"]
        bounds = f"{'×'.join(f'{h - lo_:.1f}' for lo_, h in zip(lo, hi, strict=False))}"
        print(f"{r['name']:<10} {r['triangles']:>10,} {r['lights']:>7} {r['emissive_triangles']:>9,} "
              f"{r['materials']:>9}  {bounds:<34} {', '.join(r['views'])}")
        if r["description"]:
            print(f"{'':<10} {r['description']}")
    return 0


def cmd_warmup(args) -> int:
    from app.warmup import compile_variants, run_warmup

    if args.variants:
        compile_variants([int(i) for i in args.variants.split(",")])
        return 0
    if args.jobs is not None and args.jobs < 1:
        raise UserError(f"--jobs must be at least 1, got {args.jobs}")
    return run_warmup(args.jobs, software_gpu=args.software_gpu, force=args.force)


def cmd_devices(args) -> int:
    from app.gl_context import create_headless_context
    from rt.backends import available, resolve

    rows = available()
    try:
        ctx = create_headless_context()
        gl = ctx.info["GL_RENDERER"]
    except UserError as e:
        ctx, gl = None, f"none ({e})"
    if ctx is not None:
        from app.raster.interop import describe

        for r in rows:  # how the hybrid frame's G-buffer and images move between GL and the device
            if r["available"] and r["name"] != "embree":
                r["gl_sharing"] = describe(ctx, r["name"])
                r["interop"] = r["gl_sharing"].startswith("shared memory")  # zero-copy with OpenGL
        ctx.release()
    from rt.backends import oidn_gpu_missing

    oidn_gpu = oidn_gpu_missing()
    for r in rows:  # the denoisers on a GPU backend's own device (rt/svgf.py, rt/oidn.py)
        if r["available"] and r["name"] != "embree":
            r["denoisers"] = "svgf on the device; oidn " + ("on the GPU (OIDN's CUDA device)" if oidn_gpu is None
                                                            else f"on the CPU ({oidn_gpu})")
    auto = resolve("auto")
    if args.json:
        print(json.dumps({"gl": gl, "backends": rows, "auto": auto}, indent=2))
        return 0
    print(f"OpenGL (raster passes): {gl}")
    print("ray tracing (--set tracer=NAME):")
    for r in rows:
        kind = "GPU" if r["hardware"] else "CPU"
        state = f"available, {kind}" if r["available"] else "not available"
        print(f"  {r['name']:<7} {state:<15} {r['device']}")
        if "gl_sharing" in r:
            print(f"  {'':<7} {'':<15} interop: {'yes' if r['interop'] else 'no'} (OpenGL <-> {r['name']}: "
                  f"{r['gl_sharing']})")
        if "denoisers" in r:
            print(f"  {'':<7} {'':<15} denoisers: {r['denoisers']}")
    print(f"tracer=auto picks: {auto}" + ("" if auto != "embree" else " (no GPU with ray tracing here)"))
    return 0


def cmd_view(args) -> int:
    from app.viewer import run_viewer

    return run_viewer(args)


def add_cluster_arguments(s) -> None:
    s.add_argument("--cluster", metavar="ADDRESS", help="run the units of work as Ray tasks on a cluster: auto, "
                   "HOST:PORT or ray://HOST:PORT (pip install 'rtlab[cluster]'; one GPU a task where it has GPUs)")
    s.add_argument("--task-cpus", type=int, metavar="N", help="with --cluster and Embree: CPUs of each unit but "
                   "the timed ones, which take a whole node (default 1)")


def cmd_bench(args) -> int:
    if args.cluster and (args.load or args.perf):
        raise UserError("--cluster runs the bench's sweep; --perf and --load measure one machine")
    if args.load:
        from app.bench_load import run_load_bench

        return run_load_bench(args)
    if args.perf:
        from app.perf import run_perf

        return run_perf(args)
    from app.bench import run_bench

    return run_bench(args)


def cmd_study(args) -> int:
    from app.study import run_study

    return run_study(args)


def cmd_report(args) -> int:
    from app.report import run_report

    return run_report(args)


def _warning_line(message, category, filename, lineno, file=None, line=None):
    print(f"{PROG}: warning: {message}", file=sys.stderr)


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv  # anywhere on the line: tracebacks and third-party logs are shown
    argv = [a for a in argv if a != "--debug"]
    warnings.showwarning = _warning_line
    if not debug:
        logging.disable(logging.CRITICAL)  # libraries' log lines are not rtlab's messages
    parser = build_parser()
    try:
        return _run(parser, argv)
    except UserError as e:
        print(f"{PROG}: error: {e}", file=sys.stderr)
        return e.exit_code
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted; nothing written", file=sys.stderr)
        return 130
    except MemoryError:
        print(f"{PROG}: error: out of memory (try a smaller --size or scene)", file=sys.stderr)
        return 2
    except RecursionError:
        print(f"{PROG}: error: input nested too deeply", file=sys.stderr)
        return 2
    except Exception as e:  # noqa: BLE001 - a bug of rtlab's: one line, the traceback on request
        if debug:
            raise
        print(f"{PROG}: internal error: {type(e).__name__}: {str(e)[:300]} (rerun with --debug for the traceback)",
              file=sys.stderr)
        return 1


def _run(parser, argv: list) -> int:
    init_process()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    if args.command == "bench" and sys.stderr.isatty():
        from rt.backends import kernels_ready

        if not kernels_ready():  # a one-time wait that would otherwise look like a hang
            print(f"{PROG}: the first frame of each ray-traced pass compiles this version's kernels first "
                  f"(`rtlab warmup` does it ahead of use)", file=sys.stderr, flush=True)
    if args.command == "shot":
        from app.headless import run_shot

        return run_shot(args)
    return {"scenes": cmd_scenes, "view": cmd_view, "bench": cmd_bench, "study": cmd_study, "report": cmd_report,
            "devices": cmd_devices, "warmup": cmd_warmup}[args.command](args)


if __name__ == "__main__":
    sys.exit(main())
