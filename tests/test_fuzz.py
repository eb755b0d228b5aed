"""Property-based fuzzing of the scene readers: mutated glTF, GLB, OBJ/MTL and PLY files and
random bytes each load as a valid scene or fail with one clean line; never a traceback, a
hang or a memory blow-up (each case runs in a forked child with time and memory limits).

RTLAB_FUZZ_CASES sets the number of cases (default 200, as CI runs it) and RTLAB_FUZZ_SEED the
seed (default 0: CI sees the same cases every run); a longer local run:
RTLAB_FUZZ_CASES=5000 RTLAB_FUZZ_SEED=7 python -m pytest tests/test_fuzz.py
"""
import os
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, given, seed, settings

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
