"""What a scene's loading is doing now, for whoever shows it: the loaders name their stages
(stage("materials 120/500")), and the one listener set with reporting() hears them (the CLI's
terminal line: app/loading.py; the viewer's panel). Nothing is said where no one listens.
Beside the loaders, not in them: the scene cache (scenes/cache.py) names its stages too."""
from __future__ import annotations

import contextlib

_listener = [None]


def stage(text: str) -> None:
    listener = _listener[0]
    if listener is not None:
        listener(text)


def counted(what: str, k: int, n: int) -> None:
    """stage() for item k (from 0) of n, said at most ~100 times over the n."""
    if n and (k == n - 1 or k % max(n // 100, 1) == 0):
        stage(f"{what} {k + 1}/{n}")


@contextlib.contextmanager
def reporting(listener):
    """listener(text) hears every stage said inside (one load at a time)."""
    before, _listener[0] = _listener[0], listener
    try:
        yield listener
    finally:
        _listener[0] = before
