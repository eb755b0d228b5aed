"""Where rtlab keeps what it can make again: compiled kernels, GPU shaders, read scenes."""
from __future__ import annotations

import os
from pathlib import Path


def cache_root() -> Path:
    """~/.cache/rtlab, or $XDG_CACHE_HOME/rtlab."""
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "rtlab"
