"""`rtlab study`: the study in one command, on the best ray-tracing backend present (tracer=auto):
the five built-in scenes (or the scenes given), every configuration of the study and rtlab's
additions (accumulated, denoised, hybrid), timed as the study did (1920x1080, warm-up, then 60 s
per configuration; --seconds to shorten), quality at full resolution against references that
reach their noise target (two independent halves within mean FLIP 0.01), and the report. It is
`rtlab bench` with the study's protocol, and resumable: each scene is kept as soon as it is
measured (DIR/scenes/), so a run stopped part way, started again with the same settings, goes
on from the first scene it had not finished."""
from __future__ import annotations

import argparse

from app.bench import ALL_CONFIGS, DEFAULT_SCENES, run_bench

STUDY_SIZE = "1920x1080"
STUDY_SECONDS = 60.0  # "Each test was performed at a resolution of 1920 x 1080 over a 60 second period."
REFERENCE_FRAMES = 4096  # the most a reference may take to reach its noise target


def add_arguments(s) -> None:
    s.add_argument("scenes", nargs="*", help="built-in names or files (default: the five built-ins)")
    s.add_argument("--seconds", type=float, default=STUDY_SECONDS,
                   help=f"timed seconds per configuration (default {STUDY_SECONDS:g}, the study's)")
    s.add_argument("--size", default=STUDY_SIZE, help=f"timing and quality resolution (default {STUDY_SIZE})")
    s.add_argument("--configs", help="a subset of the configurations (default: all; see README)")
    s.add_argument("--reference-frames", type=int, default=REFERENCE_FRAMES,
                   help=f"most frames of a converged reference (default {REFERENCE_FRAMES})")
    s.add_argument("--set", action="append", metavar="KEY=VALUE", help="option for every configuration "
                   "(default tracer=auto: a GPU with ray tracing where there is one)")
    s.add_argument("--out", default="study", help="output folder (default ./study); a run there with the same "
                   "settings goes on where it stopped")
    s.add_argument("--quick", action="store_true", help="a smoke run: 160x90, 2 frames a configuration, small "
                   "references")


def run_study(args) -> int:
    sets = list(args.set or [])
    if not any(s.partition("=")[0].strip() == "tracer" for s in sets):
        sets = ["tracer=auto"] + sets
    bench = argparse.Namespace(
        scenes=",".join(args.scenes or DEFAULT_SCENES), configs=args.configs or ",".join(ALL_CONFIGS),
        size="160x90" if args.quick else args.size, seconds=None if args.quick else args.seconds,
        frames=2 if args.quick else None, camera=None,
        quality_size="96x54" if args.quick else args.size,
        reference_frames=16 if args.quick else args.reference_frames, reference_noise=0.01,
        quality_frames=4 if args.quick else None, no_quality=False, path_frames=8 if args.quick else None,
        budget_ms=None, set=sets, out=args.out, quick=args.quick, resume=True,
        cluster=getattr(args, "cluster", None), task_cpus=getattr(args, "task_cpus", None))
    return run_bench(bench)
