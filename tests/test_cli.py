import json
import os
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from tests.gltf_writer import quad_document, write_gltf


def rtlab(*args, cwd=None, env=None):
    e = dict(os.environ)
    e.update(env or {})
    return subprocess.run([sys.executable, "-m", "app.cli", *args], capture_output=True, text=True, cwd=cwd, env=e,
                          timeout=600)


def test_scenes_lists_builtins_as_json():
    r = rtlab("scenes", "--json")
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)
    assert [row["name"] for row in rows] == ["arcade", "street", "cafe", "park", "temple"]
    for row in rows:
        assert row["triangles"] > 0 and len(row["bounds_min"]) == 3
        assert row["lights"] + row["emissive_triangles"] > 0


def test_scenes_describes_a_file(tmp_path):
    doc, _ = quad_document("data")
    path = write_gltf(tmp_path / "q.gltf", doc)
    r = rtlab("scenes", str(path))
    assert r.returncode == 0, r.stderr
    assert "q" in r.stdout and "2" in r.stdout


def test_shot_writes_png_and_raw(tmp_path):
    out, raw = tmp_path / "a.png", tmp_path / "a.npy"
    r = rtlab("shot", "street", "--size", "96x64", "--out", str(out), "--raw", str(raw), "--camera", "shopfront")
    assert r.returncode == 0, r.stderr
    img = np.asarray(Image.open(out))
    assert img.shape == (64, 96, 3) and img.std() > 5
    lin = np.load(raw)
    assert lin.shape == (64, 96, 3) and lin.dtype == np.float32 and np.isfinite(lin).all() and lin.max() > 0


def test_shot_camera_string_round_trip(tmp_path):
    out = tmp_path / "c.png"
    r = rtlab("shot", "arcade", "--size", "32x32", "--out", str(out),
              "--camera", "eye=0,1.7,5;target=0,1,0;up=0,1,0;fov=50")
    assert r.returncode == 0, r.stderr
    assert out.exists()


BAD = [
    (["shot", "nosuchscene"], "unknown scene"),
    (["shot", "missing.glb"], "no such file"),
    (["shot", "arcade", "--pass", "bogus"], "unknown pass"),
    (["shot", "arcade", "--set", "nope=1"], "unknown option"),
    (["shot", "arcade", "--set", "forward.ssao_samples=0"], "out of range"),
    (["shot", "arcade", "--set", "forward.ssao=maybe"], "expected true or false"),
    (["shot", "arcade", "--set", "env=purple"], "env"),
    (["shot", "arcade", "--set", "novalue"], "KEY=VALUE"),
    (["shot", "arcade", "--size", "big"], "--size"),
    (["shot", "arcade", "--camera", "nowhere"], "unknown camera"),
    (["shot", "arcade", "--camera", "eye=1,2;target=0,0,0"], "--camera"),
    (["shot", "arcade", "--out", "/no/such/dir/x.png"], "does not exist"),
    (["shot", "arcade", "--frames", "0"], "--frames"),
    (["shot", "park:12"], "detail"),
    (["shot"], "required"),
    (["frobnicate"], "invalid choice"),
]


@pytest.mark.parametrize("args,needle", BAD, ids=[" ".join(a) for a, _ in BAD])
def test_user_errors_are_one_line(args, needle, tmp_path):
    r = rtlab(*args, cwd=tmp_path)
    assert r.returncode != 0
    assert "Traceback" not in r.stderr
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, r.stderr
    assert needle in lines[0]


def test_view_without_display_suggests_shot():
    r = rtlab("view", "arcade", env={"DISPLAY": "", "WAYLAND_DISPLAY": ""})
    assert r.returncode != 0
    assert "Traceback" not in r.stderr
    assert "rtlab shot" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_warmup_compiles_every_kernel_and_says_so(tmp_path):
    """rtlab warmup renders every ray-traced pass once, in parallel processes (scripts/test.sh
    runs it), so a user's first frame does not wait for the compiler; each of its nine variants
    says when it starts, and every pass is then recorded compiled; run again, it compiles nothing
    (unless --force)."""
    from app.warmup import FAMILIES

    r = rtlab("warmup", "--jobs", "2", "--force", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "kernels compiled and cached" in r.stdout and "(2 processes)" in r.stdout
    steps = [line for line in r.stdout.splitlines() if " warmup " in line]
    variants = sum(len(family) for family in FAMILIES)
    assert sorted(int(line.split(" warmup ")[1].split("/")[0]) for line in steps) == list(range(1, variants + 1))
    from rt.backends import kernels_ready

    assert kernels_ready()
    again = rtlab("warmup", cwd=tmp_path)
    assert again.returncode == 0 and "compiled for this version already" in again.stdout
    assert " warmup " not in again.stdout
