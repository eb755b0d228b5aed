"""A scene's loading names its stages (scenes/progress.py); on a terminal the CLI shows
them on one line (app/loading.py), elsewhere nothing."""
import io

import numpy as np

from app.loading import TerminalLine, open_scene
from scenes.loaders import load_scene
from scenes.progress import reporting, stage
from tests.gltf_writer import png_bytes, quad_document, write_glb


class _Tty(io.StringIO):
    def isatty(self):
        return True


def _textured(tmp_path):
    doc, blob = quad_document(None, image=png_bytes(np.full((4, 4, 3), 128, np.uint8)))
    return write_glb(tmp_path / "quad.glb", doc, blob)


def test_loaders_name_their_stages(tmp_path):
    heard = []
    with reporting(heard.append):
        load_scene(str(_textured(tmp_path)))
    assert heard[0] == "reading quad.glb"
    assert "materials and textures 1/1" in heard and "meshes" in heard
    stage("after")  # no one listens any more
    assert heard[-1] != "after"


def test_terminal_line_shows_a_slow_load_and_how_long_it_took():
    out = _Tty()
    line = TerminalLine("big.fbx", out, delay=0.0)
    line("materials and textures 3/500")
    line.close(ok=True)
    text = out.getvalue()
    assert text.startswith("\rrtlab: opening big.fbx: materials and textures 3/500")
    assert "rtlab: opened big.fbx in" in text and text.endswith("\n")
    failed = _Tty()
    line = TerminalLine("bad.fbx", failed, delay=0.0)
    line("reading")
    line.close(ok=False)  # the error's own line follows: this one is cleared, not ended
    assert failed.getvalue().endswith("\r") and "opened" not in failed.getvalue()


def test_nothing_is_said_off_a_terminal_or_for_a_quick_load(tmp_path):
    plain = io.StringIO()
    open_scene(str(_textured(tmp_path)), plain)
    assert plain.getvalue() == ""
    quick = _Tty()
    open_scene("arcade", quick)  # within the delay
    assert quick.getvalue() == ""
