"""Property-based fuzzing of the scene readers: mutated glTF, GLB, OBJ/MTL and PLY files and
random bytes each load as a valid scene or fail with one clean line; never a traceback, a
hang or a memory blow-up (each case runs in a forked child with time and memory limits).

RTLAB_FUZZ_CASES sets the number of cases (default 200, as CI runs it) and RTLAB_FUZZ_SEED the
seed (default 0: CI sees the same cases every run); a longer local run:
RTLAB_FUZZ_CASES=5000 RTLAB_FUZZ_SEED=7 python -m pytest tests/test_fuzz.py
"""
import math
import os
import tempfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

from app.options import Options
from core.errors import UserError
from tests.fuzz_cases import check_load, scene_cases, write_case

CASES = int(os.environ.get("RTLAB_FUZZ_CASES", "200"))
SEED = int(os.environ.get("RTLAB_FUZZ_SEED", "0"))


@seed(SEED)
@settings(max_examples=CASES, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much])
@given(case=scene_cases())
def test_mutated_scene_files_load_or_fail_in_one_line(case):
    name, data, extra = case
    with tempfile.TemporaryDirectory() as folder:
        path = write_case(Path(folder), name, data, extra)
        problem, outcome = check_load(path)
    assert problem is None, f"{name}: {problem}"


@seed(SEED)
@settings(max_examples=max(CASES // 8, 10), deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much])
@given(case=scene_cases())
def test_mutated_scenes_that_load_render_finite_images(gl, case):
    """What the readers accept, every pass can draw: finite pixels from the raster and the
    ray-traced passes (the odd-but-valid values the mutations leave: huge or tiny scales,
    lights, colours, degenerate triangles)."""
    import warnings

    from hypothesis import assume

    from app.camera import Camera
    from app.renderer import Renderer
    from scenes.loaders import load_scene

    name, data, extra = case
    with tempfile.TemporaryDirectory() as folder:
        path = write_case(Path(folder), name, data, extra)
        problem, outcome = check_load(path)  # in a child first: a blow-up must not take the suite down
        assume(problem is None and (outcome == "scene" or outcome.startswith("scene | ")))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                scene = load_scene(str(path))
            except UserError:
                assume(False)
    renderer = Renderer(gl, scene, Options())
    camera = Camera.from_view(scene.default_view(), scene.diagonal)
    try:
        for pass_name in ("forward", "ao", "gi", "reflections"):
            renderer.render(camera, 24, 16, pass_name)
            assert np.isfinite(renderer.read_linear()).all(), pass_name
    finally:
        renderer.release()


HOSTILE_TEXT = ["", " ", "x", "-1", "0", "1", "1e400", "-1e400", "nan", "inf", "-inf", "1e308", "9" * 5000,
                "0x10", "1_000", "true", "false", "all", "one", "none", "\0", "1,2", "1,2,3", "nan,1,1", "-1,0,0",
                "1e39,1,1", "é", "😀", "=", ";", "auto", "embree", "vulkan", "cuda", "sky", "black"]


@seed(SEED)
@settings(max_examples=CASES, deadline=None, database=None)
@given(key=st.sampled_from(sorted(Options().keys()) + ["nope", "", "ao.", ".radius", "a" * 300]),
       value=st.one_of(st.sampled_from(HOSTILE_TEXT), st.text(max_size=30)))
def test_hostile_option_values_are_one_line_errors_or_valid(key, value):
    """--set KEY=VALUE: a value is accepted as a valid (finite, in range) setting or refused
    with one line; never another exception."""
    options = Options()
    try:
        options.apply([f"{key}={value}"])
    except UserError as e:
        assert "\n" not in str(e) and str(e).strip()
        return
    got = options.get(key)
    if isinstance(got, float):
        assert math.isfinite(got)


@seed(SEED)
@settings(max_examples=CASES, deadline=None, database=None)
@given(size=st.one_of(st.sampled_from(["16x16", "0x0", "-1x5", "1e3x5", "8x", "x8", "16384x16384", "99999999999x1",
                                       "16X9", " 16x9 ", "16x9x2", "9" * 5000 + "x1"]), st.text(max_size=12)),
       camera=st.one_of(st.sampled_from(["eye=0,1e20,0;target=0,0,0", "eye=0,1,0;target=0,1,0", "eye=0,0,0",
                                         "eye=1,2,3;target=0,0,0;fov=0", "eye=1,2,3;target=0,0,0;fov=nan",
                                         "eye=1,2,3;target=0,0,0;up=0,0,0", "eye=0,5,0;target=0,0,0;up=0,1,0",
                                         "eye=1e39,0,0;target=0,0,0", "eye=1,2;target=0,0,0", "nope", ";;;", "="]),
                        st.text(max_size=40)))
def test_hostile_sizes_and_cameras_are_one_line_errors_or_valid(size, camera):
    from app.camera import parse_camera
    from app.headless import parse_size

    scene = _arcade()
    for parse in (lambda: parse_size(size), lambda: parse_camera(camera, scene)):
        try:
            value = parse()
        except UserError as e:
            assert "\n" not in str(e) and str(e).strip()
            continue
        if isinstance(value, tuple):
            assert all(1 <= v <= 16384 for v in value)
        else:
            view = np.asarray(value.view_matrix(), np.float64) if hasattr(value, "view_matrix") else None
            assert view is None or np.isfinite(view).all()


_SCENES = {}


def _arcade():
    from scenes.builtin import build_builtin

    if "arcade" not in _SCENES:
        _SCENES["arcade"] = build_builtin("arcade")
    return _SCENES["arcade"]
