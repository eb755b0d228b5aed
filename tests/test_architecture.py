"""The layers import downward only, importing does no work, and pass modes are wired from
their passes' reads and writes (docs/ARCHITECTURE.md)."""
import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
LAYERS = {"core": 0, "scenes": 1, "rt": 2, "app": 3}  # a package may import its own layer and those below


def imported_packages(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names & set(LAYERS)


def test_layers_import_downward_only():
    upward = []
    for package, level in LAYERS.items():
        for path in (ROOT / package).rglob("*.py"):
            for name in imported_packages(path):
                if LAYERS[name] > level:
                    upward.append(f"{path.relative_to(ROOT)} imports {name}")
    assert upward == []


def test_the_app_reaches_backends_through_their_interface_only():
    """app/ imports no backend's internals (rt/embree/, rt/slang/), not even inside a function:
    what it needs of them goes through rt/backend.py and rt/backends.py."""
    reached = []
    for path in (ROOT / "app").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else (
                [node.module] if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module else [])
            reached += [f"{path.relative_to(ROOT)} imports {n}" for n in names
                        if n.split(".")[:2] in (["rt", "embree"], ["rt", "slang"])]
    assert reached == []


def test_importing_does_no_process_setup():
    """Importing every module of core, scenes and rt (the kernels aside) leaves the process as it
    was: no allocator settings, no numba cache directory, no Embree loaded."""
    code = """
import os, sys
import core.options, core.passes, scenes.loaders, rt.backend, rt.backends, rt.ao, rt.gi, rt.shadows
import rt.reflections, rt.reference, rt.hybrid, rt.pass_base
import app.passes, app.graph, app.renderer
from rt.embree import rtcore
assert "NUMBA_CACHE_DIR" not in os.environ and "OMP_WAIT_POLICY" not in os.environ, os.environ
assert rtcore._lib is None
print("clean")
"""
    env = {k: v for k, v in __import__("os").environ.items() if k not in ("NUMBA_CACHE_DIR", "OMP_WAIT_POLICY")}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, env=env, timeout=300)
    assert r.returncode == 0 and "clean" in r.stdout, r.stderr


def test_hybrid_graph_asks_backends_for_its_inputs_only():
    """Wired from reads and writes: in hybrid each ray-traced effect makes the image the forward
    pass reads, not its radiance; a standalone effect makes radiance alone; with pass_outputs
    every written channel."""
    from app.graph import active
    from app.options import Options
    from app.passes import PASS_CLASSES
    from app.renderer import wiring

    opts = Options()
    opts.apply(["hybrid.gi=true", "hybrid.reflections=true"])
    names = active("hybrid", opts)
    assert names == ["gbuffer", "gbuffer_pack", "primary", "shadows", "reflections", "gi", "shadow_maps", "ssao",
                     "forward", "accumulation", "display"]  # AO is off while GI is on
    wanted = wiring(PASS_CLASSES, names, every_output=False)
    assert wanted["shadows"] == {"rt_direct"} and wanted["gi"] == {"rt_indirect"}
    assert wanted["reflections"] == {"rt_reflection"} and wanted["primary"] == {"gbuffer"}
    ao = active("ao", opts)
    assert ao == ["gbuffer", "gbuffer_pack", "primary", "ao", "accumulation", "display"]
    assert wiring(PASS_CLASSES, ao, every_output=False)["ao"] == {"radiance"}
    assert wiring(PASS_CLASSES, ao, every_output=True)["ao"] == {"radiance", "rt_ao"}
    opts.set("gbuffer", "rt")
    assert active("ao", opts) == ["primary", "ao", "accumulation", "display"]
    assert active("normal", opts) == ["primary", "gbuffer_view", "accumulation", "display"]


def test_panel_shows_the_option_groups_of_the_modes_graph():
    from app.graph import option_groups

    assert option_groups("hybrid") == ["hybrid", "shadows", "ao", "reflections", "gi", "forward"]
    assert option_groups("reference") == ["reference", "reflections", "svgf", "oidn"]  # and the denoisers'
    assert option_groups("gi") == ["gi", "svgf", "oidn"] and option_groups("forward") == ["forward"]
    assert option_groups("albedo") == []


def test_every_option_is_in_the_panel_of_some_mode():
    """Every key `--set` and the bench take is drawn by the viewer's panel: frame-wide, or in the
    option groups of some pass mode's graph."""
    from app.options import Options
    from app.passes import ALL
    from app.ui_panel import frame_wide_keys, option_keys_for

    opts = Options()
    shown = set(frame_wide_keys(opts)) | {k for mode in ALL for k in option_keys_for(opts, mode)}
    assert set(opts.keys()) - shown == set()
    assert {"jitter", "reproject", "denoise"} <= set(frame_wide_keys(opts))


def test_each_effect_is_one_record_that_both_backends_read():
    """An effect's random stream, own image and parameters are declared once, on its pass
    (rt/effects.py): the streams differ (two effects drawing the same numbers would correlate
    their noise), the aux channel is what the pass writes besides radiance (and its specular
    part, rt_specular, for the denoisers), and both backends trace exactly the effects declared,
    found by name (rt/embree/<effect>.py, shaders/rt/<effect>.slang)."""
    from rt.effects import AUX_CHANNEL, EFFECTS, PASSES, STREAM
    from rt.embree.backend import traces
    from rt.pass_base import SPECULAR
    from rt.slang.backend import EFFECTS as DEVICE_EFFECTS

    assert len(set(STREAM.values())) == len(EFFECTS) and 0 not in STREAM.values()
    for name, p in PASSES.items():
        aux = {AUX_CHANNEL[name]} if name in AUX_CHANNEL else set()
        assert p.name == name and set(p.writes) - {SPECULAR} == {"radiance"} | aux
    assert set(traces()) == set(DEVICE_EFFECTS) == set(EFFECTS)
