"""Adding a ray-traced effect touches no rtlab file (docs/ARCHITECTURE.md, "How to add a
ray-traced pass"): a tiny effect written here into a temporary folder, one module and one shader
(a "visibility" ray from each point along its true normal, 1 where nothing lies within
`visibility.radius`), named in RTLAB_EFFECTS, runs through the CLI on Embree and on the Slang
backend (lavapipe), with its option on `--set`, and both give the analytic image: between two
planes h apart, the floor sees the ceiling when the radius passes h."""
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent

PLUGIN = '''
"""A visibility ray along each point's true normal, as an effect from outside rtlab."""
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core.options import opt, register_group
from rt.pass_base import RtPass


@dataclass
class VisibilityOptions:
    radius: float = opt(1.0, "length of the visibility rays (m)", 1e-4, 1e4)


register_group("visibility", VisibilityOptions)


class VisibilityPass(RtPass):
    name = "visibility"
    options = VisibilityOptions
    writes = ("radiance",)
    stream = 77
    lights = False

    @classmethod
    def parameters(cls, opts):
        return {"radius": opts.get("visibility.radius")}


PASS = VisibilityPass
SLANG_SHADER = Path(__file__).with_name("visibility.slang")


def embree_trace(rf):
    out = rf.background()
    s = rf.gb.surface
    radius = VisibilityPass.parameters(rf.options)["radius"]
    blocked = rf.tracer.occluded(rf.data.offset(s, s.ng), s.ng, np.full(len(s), radius, np.float32))
    out[rf.gb.index] = np.where(blocked, 0.0, 1.0)[:, None]
    return rf.outputs(out)
'''

SHADER = '''
import common;
import trace;

GBuffer g_gbuffer;
RWStructuredBuffer<float> g_out;
RWStructuredBuffer<float> g_aux;
RWStructuredBuffer<uint> g_rays_traced;
uniform Environment g_env;
uniform uint g_width;
uniform uint2 g_base;
uniform uint g_write_aux;
uniform float g_radius;

[shader("raygeneration")]
void visibility_rays()
{
    uint2 px = DispatchRaysIndex().xy;
    uint p = px.y * g_width + px.x;
    float4 pos = g_gbuffer.position[p];
    if (pos.w == 0.0)
    {
        write3(g_out, p, environment_radiance(g_env, g_gbuffer.view_dir[p].xyz));
        return;
    }
    float3 ng = g_gbuffer.true_normal[p].xyz;
    InterlockedAdd(g_rays_traced[0], 1);
    write3(g_out, p, float3(occluded(offset_origin(pos.xyz, ng), ng, g_radius) ? 0.0 : 1.0));
}
'''


@pytest.fixture(scope="module")
def plugin(tmp_path_factory):
    """The effect's folder (its module, its shader) and a glTF scene of two 40 m planes 1 m
    apart, the camera between them looking steeply down at the floor."""
    from tests.gltf_writer import textured_scene, write_gltf

    folder = tmp_path_factory.mktemp("effect")
    (folder / "rtlab_visibility.py").write_text(textwrap.dedent(PLUGIN))
    (folder / "visibility.slang").write_text(textwrap.dedent(SHADER))
    grey = {"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1]}, "doubleSided": True}
    doc = textured_scene([grey], [], [((0, 0, 0), 40.0, 0, "up"), ((0, 1, 0), 40.0, 0, "down")], [],
                         ((0, 0.5, 0), (-0.5, 0, 0, float(np.sqrt(0.75))), 0.9))
    write_gltf(folder / "planes.gltf", doc)
    return folder


def shot(plugin, tmp_path, tracer: str, radius: float) -> np.ndarray:
    env = dict(os.environ, RTLAB_EFFECTS="rtlab_visibility",
               PYTHONPATH=os.pathsep.join([str(plugin), str(ROOT), os.environ.get("PYTHONPATH", "")]))
    raw = tmp_path / f"{tracer}_{radius}.npy"
    r = subprocess.run([sys.executable, "-m", "app.cli", "shot", str(plugin / "planes.gltf"), "--pass", "visibility",
                        "--size", "48x32",
                        "--set", f"tracer={tracer}", "--set", f"visibility.radius={radius}", "--set", "gbuffer=rt",
                        "--set", "env=black", "--out", str(tmp_path / "v.png"), "--raw", str(raw)],
                       capture_output=True, text=True, cwd=ROOT, env=env, timeout=600)
    assert r.returncode == 0, r.stderr
    return np.load(raw)


@pytest.mark.parametrize("tracer", ["embree", "vulkan"])
def test_an_effect_from_outside_rtlab_runs_on_both_backends(plugin, tmp_path, tracer):
    short, long = shot(plugin, tmp_path, tracer, 0.5), shot(plugin, tmp_path, tracer, 2.0)
    covered = long.max(-1) < 0.5  # the long rays reach the other plane everywhere it is seen
    assert covered.mean() > 0.9
    assert np.all(short[covered] == 1.0)  # rays shorter than the gap see nothing
