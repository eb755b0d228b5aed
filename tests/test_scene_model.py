import hashlib

import numpy as np
import pytest

from core.errors import UserError
from scenes.builtin import BUILTINS, build_builtin, split_name
from scenes.model import Environment, Scene, fix_normals


def digest(scene) -> str:
    h = hashlib.sha256()
    for a in (scene.positions, scene.normals, scene.uvs, scene.indices, scene.material_ids):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


@pytest.fixture(scope="module")
def builtins():
    return {name: build_builtin(name) for name in BUILTINS}


@pytest.mark.parametrize("name", list(BUILTINS))
def test_builtin_invariants(builtins, name):
    s = builtins[name]
    assert s.positions.dtype == np.float32 and s.normals.dtype == np.float32 and s.uvs.dtype == np.float32
    assert s.indices.dtype == np.int32 and s.indices.shape[1] == 3
    assert s.indices.min() >= 0 and s.indices.max() < len(s.positions)
    np.testing.assert_allclose(np.linalg.norm(s.normals, axis=1), 1.0, atol=1e-4)
    assert np.isfinite(s.positions).all()
    assert s.material_ids.shape == (s.triangle_count,)
    assert 0 <= s.material_ids.min() and s.material_ids.max() < len(s.materials)
    assert s.has_light
    assert len(s.views) >= 2
    assert 50_000 <= s.triangle_count <= 300_000
    for v in s.views.values():
        assert np.linalg.norm(np.subtract(v.target, v.eye)) > 0.1


def test_builtins_are_deterministic(builtins):
    for name in BUILTINS:
        assert digest(build_builtin(name)) == digest(builtins[name]), name


def test_archetype_lighting(builtins):
    assert not builtins["cafe"].lights and builtins["cafe"].emissive_triangles().size > 0
    assert [li.kind for li in builtins["street"].lights] == ["directional"]
    assert [li.kind for li in builtins["park"].lights] == ["directional"]
    assert sum(li.kind == "point" for li in builtins["temple"].lights) >= 16
    assert 2 <= sum(li.kind == "point" for li in builtins["arcade"].lights) <= 8
    windows = [m for m in builtins["street"].materials if m.name == "window"]
    assert windows and windows[0].roughness < 0.1
    floor = [m for m in builtins["temple"].materials if m.name == "marble_floor"]
    assert floor and floor[0].roughness < 0.15


def test_detail_scales_triangles():
    assert build_builtin("arcade:2").triangle_count > 2 * build_builtin("arcade").triangle_count
    with pytest.raises(UserError):
        split_name("park:9")
    with pytest.raises(UserError):
        split_name("park:x")


def test_largest_park_exceeds_two_million():
    assert build_builtin("park:5").triangle_count > 2_000_000


def test_emissive_area_and_stats(builtins):
    s = builtins["cafe"]
    st = s.stats()
    assert st["emissive_triangles"] == s.emissive_triangles().size
    assert st["lights"] == 0 and st["triangles"] == s.triangle_count
    assert (s.triangle_areas(s.emissive_triangles()) > 0).all()


def test_validate_rejects_bad_data():
    def make(**kw):
        base = dict(name="t", positions=np.zeros((3, 3)), normals=np.tile([0, 1, 0], (3, 1)), uvs=np.zeros((3, 2)),
                    indices=np.array([[0, 1, 2]]), material_ids=np.zeros(1), materials=[object()])
        base.update(kw)
        return Scene(**base)

    make(positions=np.eye(3)).validate()
    with pytest.raises(UserError, match="non-finite"):
        make(positions=np.array([[0, 0, 0], [1, np.nan, 0], [0, 0, 1]])).validate()
    with pytest.raises(UserError, match="out of range"):
        make(indices=np.array([[0, 1, 3]])).validate()
    with pytest.raises(UserError, match="no triangles"):
        make(indices=np.zeros((0, 3), int), material_ids=np.zeros(0)).validate()


def test_fix_normals_never_nan():
    n = fix_normals(np.array([[0, 0, 0], [np.nan, 1, 0], [3, 4, 0]], np.float32))
    assert np.isfinite(n).all()
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, rtol=1e-6)
    np.testing.assert_allclose(n[2], [0.6, 0.8, 0])


def test_environment_parse_and_radiance():
    assert Environment.parse("black").radiance(np.array([[0, 1, 0]], np.float32)).sum() == 0
    c = Environment.parse("0.1,0.2,0.3")
    np.testing.assert_allclose(c.radiance(np.array([[1, 0, 0]], np.float32))[0], [0.1, 0.2, 0.3])
    sky = Environment.parse("sky").radiance(np.array([[0, 1, 0], [0, -1, 0]], np.float32))
    assert sky[0, 2] > sky[0, 0] and sky[0].sum() > sky[1].sum()  # blue zenith, darker ground
    for bad in ("blue", "1,2", "-1,0,0", "nan,0,0"):
        with pytest.raises(UserError):
            Environment.parse(bad)
