import csv
import json
import subprocess
import sys

import pytest

from app.bench import ALL_CONFIGS, DENOISERS
from app.recommend import recommend
from app.report import run_report


@pytest.fixture(scope="module")
def quick_bench(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    r = subprocess.run([sys.executable, "-m", "app.cli", "bench", "--quick", "--scenes", "arcade,cafe", "--out",
                        str(out)], capture_output=True, text=True, timeout=1200)
    assert r.returncode == 0, r.stderr[-3000:]
    return out


def test_quick_bench_writes_every_configuration(quick_bench):
    doc = json.loads((quick_bench / "results.json").read_text())
    assert doc["machine"]["cores"] >= 1 and doc["machine"]["gl_renderer"]
    assert set(doc["scenes"]) == {"arcade", "cafe"}
    for scene in ("arcade", "cafe"):
        rows = {r["config"]: r for r in doc["results"] if r["scene"] == scene}
        assert set(rows) == set(ALL_CONFIGS)
        for r in rows.values():
            f = r["frame_ms"]
            assert 0 < f["p5"] <= f["median"] <= f["p95"] and f["mean"] > 0 and r["fps"] > 0
            assert r["relative_cost"] > 0
            assert r["passes_ms"] and all(v >= 0 for v in r["passes_ms"].values())
            split = r["split_ms"]  # every pass has its part of the frame, and the parts add up to it
            assert split["other"] == 0 and sum(split.values()) == pytest.approx(f["mean"])
            assert (split["ray traced"] > 0) == (r["pass"] != "forward") and split["G-buffer"] > 0
            if r["pass"] != "forward":
                assert r["rays_per_frame"] > 0 and r["mrays_per_s"] > 0
            if r["config"].partition("+")[2] in DENOISERS:  # measured as denoised, not as their pass
                assert "quality" not in r and 0 <= r["denoise"]["flip"] <= 1
                continue
            q = r["quality"]
            assert 0 <= q["flip_accumulated"] <= 1 and q["psnr_single"] > 0
        assert rows["forward"]["relative_cost"] == pytest.approx(1.0)
    assert set(doc["recommendations"]) == {"arcade", "cafe"}
    for scene in ("arcade", "cafe"):  # the references' own noise, measured (16 frames at most with --quick)
        ref = doc["scenes"][scene]["reference"]
        assert ref["frames"] <= 16 and ref["frames"] == 2 * ref["half_frames"] and 0 <= ref["half_flip"] <= 1
        assert ref["reached"] == (ref["half_flip"] <= ref["target_flip"])
    assert "The references' own noise" in (quick_bench / "report.md").read_text()
    with open(quick_bench / "results.csv") as f:
        assert len(list(csv.DictReader(f))) == 2 * len(ALL_CONFIGS)
    assert "Recommendations" in (quick_bench / "report.md").read_text()
    assert "## Frame split" in (quick_bench / "report.md").read_text()


def test_report_renders(quick_bench):
    from types import SimpleNamespace

    assert run_report(SimpleNamespace(dir=str(quick_bench), budget_ms=None)) == 0
    md = (quick_bench / "report.md").read_text()
    page = (quick_bench / "report.html").read_text()
    for needle in ("Reflections: frames per second", "| fps | arcade | cafe |", "Per-pass time breakdown",
                   "study's recommendation", "RT ambient occlusion"):
        assert needle in md
    import re

    sources = re.findall(r'<img src="([^"]+)"', page)  # linked beside the report, every one there
    assert len(sources) >= 3 + 2 * 5 and "base64" not in page
    assert all((quick_bench / src).stat().st_size > 100 for src in sources)
    # the answer first: each scene's recommendation, its plot, its images and FLIP maps, then the tables
    assert md.index("## The answer") < md.index("Reflections: frames per second")
    assert page.index("<h2>The answer</h2>") < page.index("Reflections: frames per second")
    for scene in ("arcade", "cafe"):
        assert f"### {scene}: " in md and f"plot_answer_{scene}.png" in sources
        assert f"images/{scene}_reference.png" in sources and f"images/{scene}_forward_flip.png" in sources
    assert "## Against the study" in md and "| arcade | reflections | 962 |" in md
    for title in ("Denoisers", "Camera path", "Frame split"):  # every table of the Markdown is in the HTML too
        assert f"## {title}" in md and f"<h2>{title}</h2>" in page
    for plot in ("plot_fps.png", "plot_cost_quality.png", "plot_rays_error.png"):
        assert (quick_bench / plot).stat().st_size > 1000


def test_report_names_merged_runs_and_their_note(quick_bench, tmp_path):
    """Results concatenated from several bench runs say which, and what whoever merged them noted."""
    from types import SimpleNamespace

    doc = json.loads((quick_bench / "results.json").read_text())
    doc["merged_from"] = ["bench --scenes arcade", "bench --scenes cafe"]
    doc["note"] = "The arcade rows are from the first command."
    (tmp_path / "results.json").write_text(json.dumps(doc))
    assert run_report(SimpleNamespace(dir=str(tmp_path), budget_ms=None)) == 0
    md = (tmp_path / "report.md").read_text()
    assert "Results of 2 bench runs on this machine, concatenated: `rtlab bench --scenes arcade`" in md
    assert "The arcade rows are from the first command." in md


def row(config, ms, gain, accumulate=False):
    return {"config": config, "frame_ms": {"mean": ms}, "accumulate": accumulate, "quality": {"gain": gain}}


def test_recommendation_rule_picks_the_best_gain_per_millisecond():
    rows = [row("forward", 10, 0.0), row("reflections", 60, 0.001), row("shadows_all", 110, 0.02),
            row("shadows_one", 40, 0.018), row("gi_1", 210, 0.06), row("gi_4", 810, 0.07),
            row("ao_1", 20, 0.03), row("ao_4", 50, 0.035), row("ao_1+acc", 21, 0.03, accumulate=True)]
    rec = recommend(rows)
    picked = [c["config"] for c in rec["chosen"]]
    assert picked == ["ao_1", "shadows_one", "gi_1"]  # 3.0, 0.6, 0.3 gain/ms; reflections gain too small
    assert rec["text"] == "RT ambient occlusion + RT shadows + RT global illumination"
    budget = recommend(rows, budget_ms=50)
    assert [c["config"] for c in budget["chosen"]] == ["ao_1", "shadows_one"]
    assert recommend([row("forward", 10, 0.0), row("ao_1", 20, 0.001)])["chosen"] == []


def test_bench_user_errors(tmp_path):
    for args, needle in ((["--configs", "nope"], "unknown configuration"), (["--scenes", "missing.glb"], "no such"),
                         (["--frames", "0"], "--frames")):
        r = subprocess.run([sys.executable, "-m", "app.cli", "bench", "--quick", "--out", str(tmp_path), *args],
                           capture_output=True, text=True, timeout=120)
        assert r.returncode != 0 and needle in r.stderr and "Traceback" not in r.stderr
    r = subprocess.run([sys.executable, "-m", "app.cli", "report", str(tmp_path / "none")], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode != 0 and "results.json" in r.stderr


def test_perf_measures_every_pass_thread_count_and_bvh(tmp_path):
    """`bench --perf`: efficiency per pass, scaling over repeated sweeps of the thread counts,
    BVH builds; the last printed line names the least efficient pass."""
    r = subprocess.run([sys.executable, "-m", "app.cli", "bench", "--perf", "--quick", "--scenes", "arcade",
                        "--perf-rounds", "2", "--frames", "2", "--out", str(tmp_path)], capture_output=True, text=True,
                       timeout=900)
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "perf.json").read_text())
    passes = {row["pass"]: row for row in doc["passes"]}
    assert set(passes) == {"shadows", "ao", "gi", "reflections", "reference"}
    for row in passes.values():
        assert row["rays"] > 0 and row["raw_trace_ms"] > 0 and row["efficiency"] == row["raw_trace_ms"] / row["pass_ms"]
        # the fastest of the frames timed, the medians kept beside them
        assert row["pass_ms"] <= row["pass_ms_median"] and row["raw_trace_ms"] <= row["raw_trace_ms_median"]
        assert row["efficiency_median"] == row["raw_trace_ms_median"] / row["pass_ms_median"]
    worst = min(passes.values(), key=lambda row: row["efficiency"])
    assert r.stdout.strip().splitlines()[-1].startswith(f"min efficiency = {worst['efficiency']:.2f} ({worst['pass']}")
    counts = sorted({row["threads"] for row in doc["scaling"]})
    assert counts[0] == 1 and len(doc["scaling"]) == 4 * len(counts)
    for row in doc["scaling"]:
        assert row["rounds"] == 2 and row["pass_ms"] > 0 and row["raw_trace_ms"] > 0
        assert row["speedup"] == 1.0 if row["threads"] == 1 else row["speedup"] > 0
    assert [b["scene"] for b in doc["bvh"]] == ["park:1", "park:2"] and all(b["build_s"] > 0 for b in doc["bvh"])
    for g in doc["gbuffer"]:  # both G-buffers, and the camera rays alone as the ray-traced one traces them
        assert g["raster_gpu_ms"] > 0 and g["rt_ms"] > 0 and g["rt_raw_trace_ms"] > 0
        assert g["rt_efficiency"] == g["rt_raw_trace_ms"] / g["rt_ms"]
    bad = subprocess.run([sys.executable, "-m", "app.cli", "bench", "--perf", "--quick", "--perf-rounds", "0", "--out",
                          str(tmp_path)], capture_output=True, text=True, timeout=120)
    assert bad.returncode != 0 and "--perf-rounds" in bad.stderr and "Traceback" not in bad.stderr


def test_reference_accumulates_until_its_halves_agree(gl):
    """bench.converge_reference: a noise-free reference (a plane under a point light: direct
    light only, no sky) stops after its first round with halves identical; a noisy one (the
    arcade, a tiny target) spends every frame and says it did not reach the target."""
    from app.bench import converge_reference
    from app.camera import Camera
    from app.options import Options
    from app.renderer import Renderer
    from scenes.builtin import build_builtin
    from tests.scenes_for_tests import lit_plane

    calm = lit_plane((0.5, 0.5, 0.5), (0.0, 2.0, 0.0), 10.0)
    r = Renderer(gl, calm, Options())
    _, info = converge_reference(r, Camera.from_view(calm.default_view(), calm.diagonal), (48, 32), 64, 0.01,
                                 ("env=black", "jitter=false"))  # bounces escape to the black sky; pixel centres
    r.release()
    assert info["reached"] and info["half_flip"] < 1e-6 and info["frames"] == 16
    arcade = build_builtin("arcade")
    r = Renderer(gl, arcade, Options())
    _, info = converge_reference(r, Camera.from_view(arcade.default_view(), arcade.diagonal), (48, 32), 32, 1e-6)
    r.release()
    assert not info["reached"] and info["frames"] == 32 and info["half_frames"] == 16 and info["half_flip"] > 0.01


def test_load_bench_measures_a_generated_big_scene(tmp_path):
    """bench --load --quick: the generated scene opens with the triangles and textures asked,
    and every step reports its times (no step failed)."""
    r = subprocess.run([sys.executable, "-m", "app.cli", "bench", "--load", "--quick", "--out", str(tmp_path)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "load.json").read_text())
    assert doc["textures"] == 20 and abs(doc["triangles"] - 200_000) < 0.05 * 200_000
    rows = doc["results"]
    assert rows["cold"]["load_s"] > 0 and rows["cached"]["load_s"] > 0
    assert rows["embree"]["build_s"] > 0 and rows["embree"]["first_frame_s"] > 0, rows["embree"]
    assert all("error" not in row for row in rows.values()), rows
    from scenes.loaders import load_scene

    scene = load_scene(str(tmp_path / "load_scene_200000_20" / "scene.gltf"))
    assert sum(m.texture is not None for m in scene.materials) == 20


def test_the_camera_path_is_flown_accumulated_and_denoised(quick_bench):
    """bench.measure_path: the dolly accumulated (restarting, reprojected) and denoised by SVGF,
    each with its FLIP at the checked frames and its flicker; the report's table has all three."""
    doc = json.loads((quick_bench / "results.json").read_text())
    for scene in ("arcade", "cafe"):
        p = doc["scenes"][scene]["path"]
        assert p["frames"] == 8 and len(p["checked_frames"]) >= 2
        for key in ("restart", "reproject", "svgf"):
            assert len(p[key]["flips"]) == len(p["checked_frames"]) and 0 < p[key]["flip_mean"] < 1, key
            assert p[key]["flicker"] is not None and p[key]["flicker"] >= 0, key
    assert "FLIP svgf" in (quick_bench / "report.md").read_text()


def test_the_frame_split_of_a_device_backend_counts_gpu_time():
    """With passes timed on the device (NAME_gpu) the parts are GPU time (the host's recording,
    copies and waits are what lies beyond, the bench's host_overhead_ms); on the CPU every
    pass counts."""
    from app.bench_configs import frame_split

    passes = {"gbuffer": 10.0, "gbuffer_share": 0.5, "ao": 0.3, "share": 20.0, "ao_gpu": 6.0, "svgf": 4.0,
              "tonemap": 0.2}
    kinds = {"gbuffer": "gpu", "ao_gpu": "gpu", "svgf": "gpu", "tonemap": "gpu"}
    split = frame_split(passes, 30.0, kinds)
    assert split == pytest.approx({"G-buffer": 10.0, "ray traced": 6.0, "raster lighting": 0.0, "denoise": 4.0,
                                   "finish": 0.2, "other": 0.0, "host beyond": 9.8})
    cpu = frame_split({"gbuffer_rt": 5.0, "gi": 12.0, "upload": 0.5, "tonemap": 0.5, "mystery": 1.0}, 20.0)
    assert cpu["G-buffer"] == 5.0 and cpu["ray traced"] == 12.0 and cpu["finish"] == 1.0 and cpu["other"] == 1.0
    assert cpu["host beyond"] == pytest.approx(1.0)
