"""The report's answer (app/report_answer.py): each scene's pick and why, where it differs from
the study, the study's frame rates beside ours, and FLIP maps made from a folder's images."""
import numpy as np
import pytest

from app.image_io import read_png, write_png
from app.quality import flip_map, mean_flip
from app.report_answer import agreement, flip_map_path, scene_answer, strip, study_rows


def _row(scene, config, ms, fps, gain=None):
    r = {"scene": scene, "config": config, "frame_ms": {"mean": ms}, "fps": fps, "accumulate": False}
    if gain is not None:
        r["quality"] = {"gain": gain, "flip_accumulated": 0.3 - gain}
    return r


def _doc():
    rows = [_row("arcade", "forward", 40.0, 25.0, 0.0), _row("arcade", "gi_1", 4.0, 250.0, 0.15),
            _row("arcade", "ao_1", 2.0, 500.0, -0.01), _row("arcade", "reflections", 3.0, 330.0, 0.002),
            _row("mine.glb", "forward", 10.0, 100.0, 0.0), _row("mine.glb", "ao_1", 12.0, 80.0, 0.02)]
    return {"scenes": {"arcade": {}, "mine.glb": {}}, "results": rows}


def test_each_scene_says_what_it_takes_and_why_it_leaves_the_rest():
    a = scene_answer(_doc(), "arcade", None)
    assert a["rec"]["text"] == "RT global illumination" and a["chosen_effects"] == {"gi"}
    text = "\n".join(a["reasons"])
    assert "gi_1): mean FLIP 0.150 closer to the reference than forward, its frame 36.0 ms shorter than forward's" in text
    assert "ao_1): mean FLIP 0.010 further from the reference than forward — left out: it takes" in text
    assert "reflections): mean FLIP 0.002 closer" in text and "less than the 0.005" in text
    assert agreement(a) == "differs: also RT global illumination; not RT ambient occlusion"
    own = scene_answer(_doc(), "mine.glb", None)  # not an archetype of the study
    assert own["study"] is None and agreement(own) == "no study verdict for this scene"
    assert own["rec"]["text"] == "RT ambient occlusion"
    same = {"scene": "x", "study_effects": {"ao"}, "chosen_effects": {"ao"}}
    assert agreement(same) == "agrees with the study"


def test_the_study_frame_rates_stand_beside_ours():
    rows = {(r[0], r[1]): r for r in study_rows(_doc())}
    assert set(rows) == {("arcade", "forward"), ("arcade", "gi_1"), ("arcade", "ao_1"), ("arcade", "reflections")}
    assert rows[("arcade", "reflections")][2:] == ["962", "330.0", "1.26", "13.20"]  # 962/762; 330/25
    assert rows[("arcade", "gi_1")][4] == "0.64"


def test_flip_maps_are_made_from_the_folders_images_where_the_bench_wrote_none(tmp_path):
    rng = np.random.default_rng(7)
    ref = rng.integers(0, 255, (18, 32, 3), dtype=np.uint8)
    test = ref.copy()
    test[4:10, 5:20] = 255 - test[4:10, 5:20]  # a block visibly wrong, the rest identical
    (tmp_path / "images").mkdir()
    write_png(tmp_path / "images/arcade_reference.png", ref)
    write_png(tmp_path / "images/arcade_gi_1.png", test)
    write_png(tmp_path / "images/arcade_forward.png", ref)
    rel = flip_map_path(tmp_path, "arcade", "gi_1")
    assert rel == "images/arcade_gi_1_flip.png"
    error = read_png(tmp_path / rel).astype(float).sum(axis=2)
    assert error[6, 10] > 3 * error[15, 28]  # bright where the images differ, dark where they agree
    value, image = flip_map(ref, test)
    assert value == pytest.approx(mean_flip(ref, test)) and image.shape == (18, 32, 3)
    assert flip_map_path(tmp_path, "arcade", "ao_1") is None  # no image of it
    a = scene_answer(_doc(), "arcade", None)
    captions = [c for c, _ in strip(tmp_path, a)]
    assert captions == ["forward", "gi_1", "reference", "FLIP map: forward vs reference",
                        "FLIP map: gi_1 vs reference"]
