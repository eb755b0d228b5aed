"""GL fence syncs (glFenceSync / glClientWaitSync), which moderngl does not wrap: the host waits
for a frame's GL work without waiting for everything GL has queued since (glFinish), as a swap
chain with frames in flight does. Where the functions are missing, waiting is glFinish."""
from __future__ import annotations

import ctypes

SYNC_GPU_COMMANDS_COMPLETE = 0x9117
SYNC_FLUSH_COMMANDS_BIT = 0x1
FOREVER = 0xFFFFFFFFFFFFFFFF


class Fences:
    """Fences of frames in the order they were inserted."""

    def __init__(self, ctx):
        from app.raster.interop import Unavailable, _gl_loader

        self.ctx, self.pending = ctx, []
        try:
            lookup = _gl_loader()
            addresses = {n: lookup(n) for n in ("glFenceSync", "glClientWaitSync", "glDeleteSync")}
        except Unavailable:
            addresses = {}
        self.available = len(addresses) == 3 and all(addresses.values())
        if self.available:
            self._fence = ctypes.CFUNCTYPE(ctypes.c_void_p, ctypes.c_uint, ctypes.c_uint)(addresses["glFenceSync"])
            self._wait = ctypes.CFUNCTYPE(ctypes.c_uint, ctypes.c_void_p, ctypes.c_uint, ctypes.c_uint64)(
                addresses["glClientWaitSync"])
            self._delete = ctypes.CFUNCTYPE(None, ctypes.c_void_p)(addresses["glDeleteSync"])

    def insert(self) -> None:
        """A fence after the GL work issued so far (a frame's)."""
        if self.available:
            self.pending.append(self._fence(SYNC_GPU_COMMANDS_COMPLETE, 0))

    def wait(self, keep: int = 0) -> None:
        """Until at most `keep` of the fenced frames are unfinished (0: all done)."""
        if not self.available:
            if keep == 0:
                self.ctx.finish()
            return
        while len(self.pending) > keep:
            sync = self.pending.pop(0)
            self._wait(sync, SYNC_FLUSH_COMMANDS_BIT, FOREVER)
            self._delete(sync)

    def release(self) -> None:
        self.wait(0)
