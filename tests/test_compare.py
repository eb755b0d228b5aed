"""`rtlab shot --compare`: two passes of one camera side by side, or the FLIP map against the
reference, each side the same pixels as that pass's own shot."""
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image


def rtlab(*args):
    return subprocess.run([sys.executable, "-m", "app.cli", *args], capture_output=True, text=True, timeout=600)


def shot(tmp_path, name, *args):
    out = tmp_path / f"{name}.png"
    r = rtlab("shot", "arcade", "--size", "96x54", "--out", str(out), *args)
    assert r.returncode == 0, r.stderr
    return np.asarray(Image.open(out)).astype(int), r.stdout


def test_split_shows_each_pass_on_its_side(tmp_path):
    both, _ = shot(tmp_path, "both", "--pass", "forward", "--compare", "ao", "--split", "0.25")
    left, _ = shot(tmp_path, "left", "--pass", "forward")
    right, _ = shot(tmp_path, "right", "--pass", "ao")
    rows = slice(36, None)  # below the labels (two rows of them at this width)
    x = 24  # the divider: 0.25 of 96
    assert np.abs(both[rows, : x - 1] - left[rows, : x - 1]).max() <= 1
    assert np.abs(both[rows, x + 1:] - right[rows, x + 1:]).max() <= 1
    assert (both[rows, x - 1:x + 1] == 255).all()  # the divider line


def test_diff_is_flip_against_the_reference(tmp_path):
    image, out = shot(tmp_path, "diff", "--pass", "forward", "--compare", "diff")
    assert "mean FLIP" in out
    mean = float(out.split("mean FLIP ")[1].split()[0])
    assert 0.0 < mean < 1.0
    right = image[20:, 50:]
    assert right.std() > 0  # an error map, not the image again
    _, out = shot(tmp_path, "same", "--pass", "reference", "--frames", "64", "--compare", "diff")
    assert float(out.split("mean FLIP ")[1].split()[0]) < 0.5 * mean  # the reference against itself: near 0


@pytest.mark.parametrize("args,needle", [(["--compare", "nope"], "unknown pass"),
                                         (["--compare", "ao", "--split", "2"], "--split must be within 0..1")])
def test_bad_compare_options(tmp_path, args, needle):
    r = rtlab("shot", "arcade", "--size", "16x16", "--out", str(tmp_path / "x.png"), *args)
    assert r.returncode == 2 and needle in r.stderr and r.stderr.count("\n") == 1, r.stderr
    assert not (tmp_path / "x.png").exists()


def test_raw_image_is_split_as_the_png(tmp_path):
    raw = tmp_path / "both.npy"
    shot(tmp_path, "both", "--pass", "forward", "--compare", "ao", "--split", "0.25", "--raw", str(raw))
    left, right = tmp_path / "left.npy", tmp_path / "right.npy"
    shot(tmp_path, "left", "--pass", "forward", "--raw", str(left))
    shot(tmp_path, "right", "--pass", "ao", "--raw", str(right))
    both, left, right = np.load(raw), np.load(left), np.load(right)
    assert np.array_equal(both[:, :24], left[:, :24]) and np.array_equal(both[:, 24:], right[:, 24:])
    flip = tmp_path / "flip.npy"
    _, out = shot(tmp_path, "diff", "--pass", "forward", "--compare", "diff", "--raw", str(flip))
    values = np.load(flip)[:, 48:]  # each pixel's FLIP beside the divider; its mean is the one reported
    assert values.min() >= 0 and values.max() <= 1 and np.array_equal(values[..., 0], values[..., 2])


@pytest.mark.parametrize("width", [320, 160, 96, 40])
def test_labels_never_overlap_and_stay_inside(width):
    from PIL import Image, ImageDraw

    from app.compare import label_layout

    height = width * 9 // 16
    draw = ImageDraw.Draw(Image.new("RGB", (width, height)))
    _, texts, (a, b) = label_layout(draw, width, height, ("forward: 62.3 ms/frame", "ao: 1943.6 ms/frame"))
    assert a[2] < b[0] or a[3] < b[1]  # side by side, or the right one below
    assert all(0 <= x0 < x1 <= width and 0 <= y0 < y1 for x0, y0, x1, y1 in (a, b))
    assert (a[1] == b[1]) == (width >= 320) and texts[1].startswith("ao")
