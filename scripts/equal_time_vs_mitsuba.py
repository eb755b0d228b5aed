"""Issue 43's equal-time yardstick: the error left after the same wall time by rtlab's GI on Embree
(one bounce, shadowed direct light, gi.rays_per_pixel 1 and 4, accumulated frames) and by Mitsuba 3's
`llvm_ad_rgb` path tracer with max_depth 3 (the same light paths), on the closed Lambert room of
tests/scenes_for_tests.closed_box, against a converged Mitsuba reference.

    python scripts/equal_time_vs_mitsuba.py [--size 256x192] [--seconds 2,10] [--reference-spp 32768]
        [--rounds 2] [--out DIR]

Mitsuba is not a dependency of rtlab: `pip install mitsuba` first (its LLVM backend needs libLLVM;
on AVX-512 CPUs LLVM 19, see scripts/cpu_vs_mitsuba.sh). Mitsuba is timed two ways, both after a
warm-up that compiles its kernels: frames of 1 sample per pixel accumulated (as rtlab's are), and
one render call with as many samples as fit the time (its fastest way to a still image); rtlab
as a user's still view accumulates, warm kernels, the default G-buffer. Rounds alternate the two.
The error is the RMSE over pixels and channels of the linear image; the reference's own noise
(half the RMSE between its two halves) is printed with it. The reference is cached in DIR.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

MAX_DEPTH = 3  # Mitsuba's path depth: direct light and one bounce (rtlab gi.bounces=1)


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)))


def mitsuba_reference(mi, scene, spp: int, cache: Path) -> tuple[np.ndarray, float]:
    """The converged image (mean of two halves of spp/2 samples each, distinct seeds) and its noise."""
    from tests.refs.make_mitsuba_refs import PASS_SPP

    if cache.exists():
        data = np.load(cache)
        return data["image"], float(data["noise"])
    calls = max(2, spp // PASS_SPP)
    halves = [np.zeros(0), np.zeros(0)]
    for seed in range(calls):
        img = np.asarray(mi.render(scene, spp=min(spp, PASS_SPP), seed=1000 + seed), np.float64)[..., :3]
        h = seed % 2
        halves[h] = img if not halves[h].size else halves[h] + img
    a, b = halves[0] / (calls // 2 + calls % 2), halves[1] / (calls // 2)
    image, noise = ((a + b) / 2).astype(np.float32), rmse(a, b) / 2
    np.savez(cache, image=image, noise=noise)
    return image, noise


def mitsuba_frames(mi, scene, seconds: float) -> tuple[np.ndarray, int]:
    """1-spp frames accumulated until `seconds` have passed."""
    mi.render(scene, spp=1, seed=999_999)  # warm: its kernels compiled and cached
    total, n, t0 = None, 0, time.perf_counter()
    while n == 0 or time.perf_counter() - t0 < seconds:
        img = np.asarray(mi.render(scene, spp=1, seed=n), np.float32)[..., :3]
        total = img if total is None else total + img
        n += 1
    return total / n, n


def mitsuba_one_call(mi, scene, seconds: float) -> tuple[np.ndarray, int]:
    """One render call whose samples per pixel fit `seconds` (from a timed probe)."""
    probe = 16
    np.asarray(mi.render(scene, spp=probe, seed=999_998))  # warm
    t0 = time.perf_counter()
    np.asarray(mi.render(scene, spp=probe, seed=999_997))
    per_spp = (time.perf_counter() - t0) / probe
    spp = max(1, int(seconds / per_spp))
    return np.asarray(mi.render(scene, spp=spp, seed=7), np.float32)[..., :3], spp


def rtlab_frames(ctx, scene, size, rays: int, seconds: float) -> tuple[np.ndarray, int]:
    """rtlab's GI (Embree) accumulated for `seconds` after warm frames."""
    from app.camera import Camera
    from app.options import Options
    from app.renderer import Renderer

    opts = Options()
    opts.apply(["tracer=embree", "gi.bounces=1", f"gi.rays_per_pixel={rays}", "gi.shadows=true"])
    r = Renderer(ctx, scene, opts)
    cam = Camera.from_view(scene.default_view(), scene.diagonal)
    for _ in range(3):  # warm: kernels compiled, buffers made
        r.render(cam, *size, "gi")
    r.read_linear()
    r.reset()
    n, t0 = 0, time.perf_counter()
    while n == 0 or time.perf_counter() - t0 < seconds:
        r.render(cam, *size, "gi")
        n += 1
    image = r.read_linear()
    r.release()
    return image, n


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="256x192")
    ap.add_argument("--seconds", default="2,10")
    ap.add_argument("--reference-spp", type=int, default=32768)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--out", default="equal_time")
    args = ap.parse_args()
    import mitsuba as mi

    mi.set_variant("llvm_ad_rgb")
    from app.gl_context import create_headless_context
    from tests.refs.make_mitsuba_refs import mitsuba_scene
    from tests.scenes_for_tests import closed_box

    size = tuple(int(x) for x in args.size.split("x"))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    scene = closed_box()
    mscene = mi.load_dict(mitsuba_scene(scene, 0.0, MAX_DEPTH, 1, "diffuse", size))
    t0 = time.perf_counter()
    ref, noise = mitsuba_reference(mi, mscene, args.reference_spp,
                                   out / f"reference_{size[0]}x{size[1]}_{args.reference_spp}.npz")
    print(f"reference: {args.reference_spp} spp, mean {ref.mean():.4f}, its own noise (RMSE) {noise:.5f}"
          f" ({time.perf_counter() - t0:.0f} s)", flush=True)
    ctx = create_headless_context()
    rows = []
    for rnd in range(1, args.rounds + 1):
        for seconds in (float(s) for s in args.seconds.split(",")):
            runs = [("mitsuba frames", lambda s=seconds: mitsuba_frames(mi, mscene, s), "frames"),
                    ("mitsuba one call", lambda s=seconds: mitsuba_one_call(mi, mscene, s), "spp"),
                    ("rtlab gi 1 ray", lambda s=seconds: rtlab_frames(ctx, scene, size, 1, s), "frames"),
                    ("rtlab gi 4 rays", lambda s=seconds: rtlab_frames(ctx, scene, size, 4, s), "frames")]
            for name, fn, unit in runs:
                image, count = fn()
                row = {"round": rnd, "seconds": seconds, "who": name, unit: count, "rmse": rmse(image, ref),
                       "mean": float(image.mean()), "reference_mean": float(ref.mean())}
                rows.append(row)
                print(f"round {rnd}  {seconds:4.0f} s  {name:17s} {count:6d} {unit:6s} RMSE {row['rmse']:.5f}"
                      f"  mean {row['mean']:.4f}", flush=True)
    doc = {"size": list(size), "reference_spp": args.reference_spp, "reference_noise": noise,
           "mitsuba": mi.__version__, "rows": rows}
    (out / "equal_time.json").write_text(json.dumps(doc, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
