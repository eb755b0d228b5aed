"""The bench as units of work (app/sweep.py) and on a Ray cluster (app/cluster.py, bench/study
--cluster): a reference made of batches equals one process's, the sweep times the forward frame
again on a kind of machine that has none, and a local Ray cluster of two worker CPUs runs a
quick study with the single-process run's figures, also when a worker is killed mid-run."""
import json
import os
import signal
import socket
import subprocess
import sys
import time

import numpy as np
import pytest
from PIL import Image

from app.sweep import ReferenceRounds, Sweep


def test_reference_batches_add_up_to_one_run(gl):
    """The reference's frames in 1 batch a half or split over 3 workers: the same frames, so the
    same mean (to float rounding), the same display image and the same convergence figures."""
    from app.camera import Camera
    from app.measure import reference_batch
    from app.options import Options
    from app.renderer import Renderer
    from scenes.builtin import build_builtin

    scene = build_builtin("cafe")
    renderer = Renderer(gl, scene, Options())
    camera = Camera.from_view(scene.default_view(), scene.diagonal)
    made = {}
    for split in (1, 3):
        rounds = ReferenceRounds(32, 1e-6, 1.0, split)
        seen = []
        while not rounds.done:
            batches = rounds.batches()
            seen += batches
            for first, count in reversed(batches):  # back in any order
                rounds.add(first, count, reference_batch(renderer, camera, (40, 24), first, count))
        made[split] = (rounds.linear(), rounds.image(), rounds.info, seen)
    renderer.release()
    (lin1, img1, info1, seen1), (lin3, img3, info3, seen3) = made[1], made[3]
    assert sorted(f for f, _ in seen1) == [0, 4, 8, 16] and len(seen3) == 4 * 3  # 4 + 4 frames, then 8, 16 more
    assert sum(n for _, n in seen3) == 32 and info1["frames"] == info3["frames"] == 32
    assert lin1.std() > 0.01  # a real image, noisy at 32 frames
    np.testing.assert_allclose(lin3, lin1, rtol=1e-5, atol=1e-6)
    assert np.abs(img3.astype(int) - img1.astype(int)).max() <= 1 and (img3 != img1).mean() < 1e-3
    assert info3["half_flip"] == pytest.approx(info1["half_flip"], abs=1e-4) and not info3["reached"]


class FakeExecutor:
    """Timings only: every row on the node its unit names (or "a"), the kind of node "b" other."""
    parallelism = 2

    def __init__(self, node_of):
        self.node_of, self.queue, self.units = node_of, [], []

    def submit(self, key, unit, node=None):
        self.queue.append((key, unit, node))
        self.units.append((unit, node))

    def pending(self):
        return len(self.queue)

    def next(self):
        key, unit, node = self.queue.pop(0)
        node = node or self.node_of(unit)
        ms = {"forward": 10.0, "ao_1": 30.0}[unit["config"]] * (2 if node == "b" else 1)
        who = {"host": node, "node": node, "kind": f"kind {node}", "tracer": {"name": "embree", "device": "CPU"},
               "machine": {"cpu": node}, "bvh_build_s": None}
        return key, {"worker": who, "row": {"config": unit["config"], "frame_ms": {"mean": ms}}}


def test_costs_compare_rows_with_the_forward_frame_of_their_kind_of_machine():
    """ao_1 timed on another kind of machine than forward: the sweep times forward again there
    (pinned to that node) and each row's cost is against its own kind's forward frame."""
    from types import SimpleNamespace

    ex = FakeExecutor(lambda unit: "a" if unit["config"] == "forward" else "b")
    got = []
    settings = {"reference_frames": 16, "reference_noise": 0.01, "exposure": 1.0, "path_frames": 0}
    finished, seen = {}, []

    def on_scene(w, rows, info):
        got.append(rows)
        finished[w.spec] = rows

    sweep = Sweep(ex, [("arcade", SimpleNamespace(name="arcade"))], ["forward", "ao_1"], [], [], settings,
                  SimpleNamespace(update=lambda *a: None), None, on_scene,
                  on_unit=lambda sw: seen.append([r["config"] for r in sw.rows_so_far(finished)]))
    sweep.run()
    # the rows so far after each unit (what results.json holds meanwhile): forward, then ao_1, then
    # the forward frame again on ao_1's kind of machine, which finishes the scene
    assert seen == [["forward"], ["forward", "ao_1"], ["forward", "ao_1"]]
    again = [(u, n) for u, n in ex.units if u.get("forward_only")]
    assert again == [({"kind": "time", "scene": "arcade", "config": "forward", "forward_only": True}, "b")]
    rows = {r["config"]: r for r in got[0]}
    assert rows["forward"]["relative_cost"] == 1.0 and rows["forward"]["forward_ms"] == 10.0
    assert rows["ao_1"]["forward_ms"] == 20.0 and rows["ao_1"]["relative_cost"] == 3.0  # 60 ms on b / b's 20 ms
    assert rows["ao_1"]["measured_on"]["kind"] == "kind b"


# -- a local Ray cluster -----------------------------------------------------------------------

def _ray_available() -> bool:
    try:
        import ray  # noqa: F401
    except ImportError:
        if os.environ.get("CI"):
            raise  # CI installs the cluster extra (scripts/test.sh): its tests must run there
        return False
    return True


needs_ray = pytest.mark.skipif(not _ray_available(), reason="Ray not installed (pip install 'rtlab[cluster]')")


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """`ray start --head` on this machine with 2 CPUs and 2 GPUs (Ray only counts GPUs: here the
    GPU tasks run on lavapipe), in its own process group, stopped after."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    temp = tmp_path_factory.mktemp("ray")
    head = subprocess.Popen([sys.executable, "-m", "ray.scripts.scripts", "start", "--head", "--block", "--num-cpus",
                             "2", "--num-gpus", "2", "--port", str(port), "--include-dashboard=false",
                             "--disable-usage-stats", f"--temp-dir={temp}"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    address = f"127.0.0.1:{port}"
    try:
        for _ in range(300):
            try:
                socket.create_connection(("127.0.0.1", port), 1).close()
                break
            except OSError:
                time.sleep(0.2)
        yield address
    finally:
        os.killpg(head.pid, signal.SIGTERM)
        try:
            head.wait(20)
        except subprocess.TimeoutExpired:
            os.killpg(head.pid, signal.SIGKILL)


STUDY = ["arcade", "--configs", "forward,ao_1,gi_1,gi_1+svgf,shadows_one", "--set", "tracer=embree"]
GPU_STUDY = ["arcade", "--configs", "forward,ao_1,shadows_one", "--set", "tracer=vulkan"]


def _study(out, *extra, background=False, study=STUDY):
    cmd = [sys.executable, "-m", "app.cli", "study", "--quick", *study, "--out", str(out), *extra]
    if background:
        return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return subprocess.run(cmd, capture_output=True, text=True, timeout=900)


@pytest.fixture(scope="module")
def single(tmp_path_factory):
    out = tmp_path_factory.mktemp("single")
    r = _study(out)
    assert r.returncode == 0, r.stderr[-2000:]
    return out


def _same_figures(a, b) -> None:
    da, db = (json.loads((p / "results.json").read_text()) for p in (a, b))
    ia = {(r["scene"], r["config"]): r for r in da["results"]}
    ib = {(r["scene"], r["config"]): r for r in db["results"]}
    assert set(ia) == set(ib)
    for key, r in ia.items():
        for part in ("quality", "denoise"):
            if r.get(part):
                assert ib[key][part] == pytest.approx(r[part], abs=1e-5), (key, part)
    assert db["scenes"]["arcade"]["reference"] == pytest.approx(da["scenes"]["arcade"]["reference"], abs=1e-5)
    pa, pb = da["scenes"]["arcade"]["path"], db["scenes"]["arcade"]["path"]
    for variant in ("restart", "reproject", "svgf"):
        assert pb[variant]["flips"] == pytest.approx(pa[variant]["flips"], abs=1e-5), variant
        assert pb[variant]["flicker"] == pytest.approx(pa[variant]["flicker"], abs=1e-5), variant
    ref_a, ref_b = (np.asarray(Image.open(p / "images" / "arcade_reference.png")).astype(int) for p in (a, b))
    assert np.abs(ref_a - ref_b).max() <= 1 and (ref_a != ref_b).mean() < 1e-3
    assert db["machine"]["cluster"]["nodes"] == 1 and all(r["measured_on"]["node"] != "local" for r in db["results"])
    assert "Measured on a Ray cluster" in (b / "report.md").read_text()


@needs_ray
def test_a_quick_study_on_a_local_cluster_gives_the_single_process_figures(cluster, single, tmp_path):
    r = _study(tmp_path, "--cluster", cluster)
    assert r.returncode == 0, r.stderr[-2000:]
    _same_figures(single, tmp_path)
    # rows from two kinds of machine: the report keys them M1, M2 and says which measured each row
    from app.report import write_report

    doc = json.loads((tmp_path / "results.json").read_text())
    for row in doc["results"][1::2]:
        row["measured_on"] = {**row["measured_on"], "kind": "another machine", "host": "elsewhere"}
    write_report(tmp_path, doc, html=True)
    md = (tmp_path / "report.md").read_text()
    assert "| M2: another machine |" in md and "elsewhere" in md
    breakdown = md[md.index("## Per-pass time breakdown"):].split("\n\n")[1]
    assert breakdown.splitlines()[0].endswith("| machine |") and "| M2 |" in breakdown and "| M1 |" in breakdown
    assert "M2: another machine" in (tmp_path / "report.html").read_text()


@needs_ray
def test_a_study_survives_a_worker_killed_mid_run(cluster, single, tmp_path):
    """A Ray worker process SIGKILLed while it runs a unit: the unit runs again, the study
    finishes with the same figures."""
    run = _study(tmp_path, "--cluster", cluster, background=True)
    killed = None
    deadline = time.time() + 300
    while killed is None and time.time() < deadline and run.poll() is None:
        busy = subprocess.run(["pgrep", "-f", "^ray::run_unit"], capture_output=True, text=True).stdout.split()
        if busy:
            time.sleep(1.0)  # well into a unit
            busy = subprocess.run(["pgrep", "-f", "^ray::run_unit"], capture_output=True, text=True).stdout.split()
            if busy:
                killed = int(busy[0])
                os.kill(killed, signal.SIGKILL)
        time.sleep(0.1)
    _, err = run.communicate(timeout=900)
    assert killed is not None, "no unit was seen running"
    assert run.returncode == 0, err[-2000:]
    _same_figures(single, tmp_path)


@needs_ray
def test_gpu_tasks_take_one_gpu_each(cluster, tmp_path):
    """tracer=vulkan on a cluster with GPUs: every unit a task on one of them (lavapipe here),
    two at once, with the single process's figures."""
    alone = _study(tmp_path / "alone", study=GPU_STUDY)
    assert alone.returncode == 0, alone.stderr[-2000:]
    r = _study(tmp_path / "cluster", "--cluster", cluster, study=GPU_STUDY)
    assert r.returncode == 0, r.stderr[-2000:]
    doc = json.loads((tmp_path / "cluster" / "results.json").read_text())
    c = doc["machine"]["cluster"]
    assert c["gpus"] == 2 and c["tasks"] == "one GPU each" and doc["sweep"]["workers"] == 2
    assert {r["measured_on"]["device"] for r in doc["results"]} == {doc["tracer"]["device"]}
    assert {tuple(r["measured_on"]["gpus"]) for r in doc["results"]} <= {("0",), ("1",)}
    assert doc["tracer"]["name"] == "vulkan" and doc["tracer"]["device"] != "CPU"  # lavapipe: "llvmpipe (LLVM ..)"
    base = json.loads((tmp_path / "alone" / "results.json").read_text())
    ia = {r["config"]: r for r in base["results"]}
    for row in doc["results"]:
        if row.get("quality"):
            assert row["quality"] == pytest.approx(ia[row["config"]]["quality"], abs=1e-5), row["config"]


def test_cluster_errors_are_one_line(tmp_path):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # nothing listens there once closed
    for args in (["--cluster", f"127.0.0.1:{port}"], ["--cluster", "nowhere"], ["--cluster", "auto", "--perf"]):
        cmd = [sys.executable, "-m", "app.cli", "bench", "--quick", "--scenes", "arcade", "--out", str(tmp_path), *args]
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 2 and len(lines) == 1 and "--cluster" in lines[0], (args, r.stderr[-500:])
