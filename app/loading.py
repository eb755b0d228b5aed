"""Opening a scene with its progress shown: on a terminal one line that the loaders' stages
(scenes/progress.py) rewrite, once a load has taken longer than a moment, ended with
how long it took; nothing where stderr is not a terminal (logs, pipes, the tests' one-line
errors). The viewer shows the same stages in its panel (app/viewer.py)."""
from __future__ import annotations

import re
import sys
import time

from scenes.loaders import load_scene
from scenes.progress import reporting

DELAY_S = 1.0  # a load shorter than this says nothing
EVERY_S = 0.1  # the line is rewritten at most this often


class TerminalLine:
    def __init__(self, name: str, stream=None, delay: float = DELAY_S):
        self.name, self.stream, self.delay = name, stream or sys.stderr, delay
        self.t0 = time.perf_counter()
        self.shown = 0.0  # when the line was last written (0: never)
        self.width = 0
        self.kind = ""  # the last stage written, its numbers left out: a new stage is written at once
        self.live = bool(getattr(self.stream, "isatty", lambda: False)())

    def __call__(self, text: str) -> None:
        now = time.perf_counter()
        kind = re.sub(r"\d+", "", text)
        if not self.live or now - self.t0 < self.delay or (now - self.shown < EVERY_S and kind == self.kind):
            return
        self.kind = kind
        self._write(f"rtlab: opening {self.name}: {text} ({now - self.t0:.0f} s)")
        self.shown = now

    def _write(self, line: str) -> None:
        self.stream.write("\r" + line.ljust(self.width))
        self.stream.flush()
        self.width = len(line)

    def close(self, ok: bool) -> None:
        if self.shown:
            self._write(f"rtlab: opened {self.name} in {time.perf_counter() - self.t0:.1f} s" if ok else "")
            self.stream.write("\n" if ok else "\r")
            self.stream.flush()


def open_scene(spec: str, stream=None):
    """load_scene(spec), its stages on a terminal line while it runs."""
    line = TerminalLine(spec.replace("\\", "/").rsplit("/", 1)[-1], stream)
    ok = False
    try:
        with reporting(line):
            scene = load_scene(spec)
        ok = True
        return scene
    finally:
        line.close(ok)
