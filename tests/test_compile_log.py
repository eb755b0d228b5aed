"""What a first frame says about compiling: which passes this version has compiled, how long
compiling took here last time (rt/embree/compile_log.py), and `rtlab shot` saying so."""
import json
import os
import shutil
import subprocess
import sys
import types

import pytest

from rt.embree import compile_log
from rt.embree.jit import njit
from rt.embree.process import cache_dir


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "numba" / "version"
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(folder))
    return folder


def _probe():
    """A kernel of this backend's (by module name) that is not compiled yet."""
    def body(x):
        return x + 1

    fn = types.FunctionType(body.__code__, {}, "probe")
    fn.__module__ = "rt.embree.probe"
    return njit(fn)


def test_notice_until_recorded_then_the_last_time(cache):
    assert compile_log.notice("gi") is not None and "compiling the gi kernels" in compile_log.notice("gi")
    assert "last time" not in compile_log.notice("gi") and "not yet timed on this machine" in compile_log.notice("gi")
    compile_log.record("gi", 42.4)
    assert compile_log.compiled("gi") and compile_log.notice("gi") is None
    (cache / "passes.json").unlink()  # a new version: compiles again, and says how long it took before
    assert "took 42 s here last time" in compile_log.notice("gi")


def test_watch_records_the_time_only_when_something_compiled(cache):
    probe = _probe()
    with compile_log.watch(["ao"]) as w:
        assert probe(1) == 2
    assert w.compiles == 1 and compile_log.compiled("ao") and compile_log.last_seconds("ao") is not None
    with compile_log.watch(["shadows"]) as w:  # nothing compiled: marked, no time
        assert probe(2) == 3
    assert w.compiles == 0 and compile_log.compiled("shadows") and compile_log.last_seconds("shadows") is None


def test_shot_says_what_it_compiles_and_how_long_it_took(tmp_path):
    """A version whose ao kernels are cached but not marked (as after an update that compiled
    them elsewhere): `rtlab shot --pass ao` names the wait and the last time, once."""
    version = tmp_path / "numba" / "v"
    if cache_dir().is_dir():
        shutil.copytree(cache_dir(), version)
    version.mkdir(parents=True, exist_ok=True)
    (version / "passes.json").unlink(missing_ok=True)
    (tmp_path / "numba" / "compile_times.json").write_text(json.dumps({"ao": 12.3}))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(version))
    cmd = [sys.executable, "-m", "app.cli", "shot", "arcade", "--pass", "ao", "--size", "32x18", "--out",
           str(tmp_path / "ao.png")]
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr
    assert "rtlab: compiling the ao kernels (once per version; took 12 s here last time" in r.stderr
    assert "ao" in json.loads((version / "passes.json").read_text())
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0 and "compiling" not in r.stderr, r.stderr
    forward = subprocess.run(cmd[:6] + ["forward"] + cmd[7:], capture_output=True, text=True, env=env, timeout=600)
    assert forward.returncode == 0 and "compiling" not in forward.stderr  # nothing to compile for raster
