"""Big scene files are read once (scenes/cache.py): the second open comes from rtlab's cache and
gives the same scene; a changed file, or one of the files it refers to, is read again; a broken
cache entry costs nothing but the time."""
import os
import warnings

import numpy as np
import pytest

from scenes import cache
from scenes.loaders import load_scene
from scenes.loaders.gltf import load_gltf
from tests.gltf_writer import mesh_scene, uv_sphere


@pytest.fixture
def cached(tmp_path, monkeypatch):
    """Every file cached (no size floor), into a cache folder of the test's own."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setattr(cache, "MIN_BYTES", 0)
    return tmp_path


def _sphere_gltf(folder, color=(0.8, 0.2, 0.2, 1.0)):
    """A sphere whose buffer is an external .bin file beside the .gltf."""
    import base64
    import json

    pos, nrm, uv, idx = uv_sphere((0.0, 0.0, 0.0), 1.0, 24, 12)
    mat = {"pbrMetallicRoughness": {"baseColorFactor": list(color), "metallicFactor": 0.0}}
    doc = mesh_scene([(pos, nrm, uv, idx, 0)], [mat], [])
    blob = base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1])
    (folder / "sphere.bin").write_bytes(blob)
    doc["buffers"][0]["uri"] = "sphere.bin"
    path = folder / "sphere.gltf"
    path.write_text(json.dumps(doc))
    return path


def _counting(reader):
    calls = []

    def read(path):
        calls.append(path)
        return reader(path)

    return read, calls


def test_the_second_open_comes_from_the_cache(cached):
    path = _sphere_gltf(cached)
    read, calls = _counting(load_gltf)
    first = cache.load_cached(path, read)
    second = cache.load_cached(path, read)
    assert len(calls) == 1 and len(list(cache.cache_dir().glob("*.pickle"))) == 1
    for name in ("positions", "normals", "uvs", "indices", "material_ids"):
        assert np.array_equal(getattr(first, name), getattr(second, name)), name
    assert second.materials[0].base_color == first.materials[0].base_color
    assert load_scene(str(path)).triangle_count == first.triangle_count  # the readers' own way in


def test_a_changed_file_or_buffer_is_read_again(cached):
    path = _sphere_gltf(cached)
    read, calls = _counting(load_gltf)
    cache.load_cached(path, read)
    data = (cached / "sphere.bin").read_bytes()
    (cached / "sphere.bin").write_bytes(data[:-4] + b"\0\0\0\0")  # the buffer the .gltf refers to
    os.utime(cached / "sphere.bin", ns=(1, 1))
    cache.load_cached(path, read)
    assert len(calls) == 2
    _sphere_gltf(cached, color=(0.1, 0.9, 0.1, 1.0))  # the document itself
    scene = cache.load_cached(path, read)
    assert len(calls) == 3 and scene.materials[0].base_color[1] == pytest.approx(0.9)


def test_a_broken_entry_or_the_cache_off_reads_the_file(cached, monkeypatch):
    path = _sphere_gltf(cached)
    read, calls = _counting(load_gltf)
    cache.load_cached(path, read)
    for entry in cache.cache_dir().glob("*.pickle"):
        entry.write_bytes(b"not a pickle")
    assert cache.load_cached(path, read).triangle_count > 0 and len(calls) == 2
    monkeypatch.setenv("RTLAB_SCENE_CACHE", "0")
    cache.load_cached(path, read)
    cache.load_cached(path, read)
    assert len(calls) == 4


def test_warnings_are_said_again_from_the_cache(cached):
    path = _sphere_gltf(cached)

    def read(p):
        warnings.warn("sphere: a feature this reader skips")
        return load_gltf(p)

    for _ in range(2):
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always")
            cache.load_cached(path, read)
        assert [str(w.message) for w in seen] == ["sphere: a feature this reader skips"]
