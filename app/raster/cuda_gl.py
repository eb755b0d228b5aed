"""CUDA's own OpenGL interop for the CUDA backend (app/raster/interop.py): a GL buffer
registered with CUDA (cuGraphicsGLRegisterBuffer) in the backend's CUDA context, mapped while
the device buffer is copied to or from it on the GPU (cuMemcpyDtoD), unmapped before GL uses it
again. Through the CUDA driver library with ctypes: no CUDA toolkit is needed."""
from __future__ import annotations

import ctypes

from app.raster.interop import Link, Unavailable
from rt.libcuda import VOID, CudaError, Driver, P

REGISTER_NONE = 0


def _driver() -> Driver:
    u64, size, uint = ctypes.c_uint64, ctypes.c_size_t, ctypes.c_uint
    try:
        return Driver({"cuGraphicsGLRegisterBuffer": [P(VOID), uint, uint],
                       "cuGraphicsUnregisterResource": [VOID],
                       "cuGraphicsMapResources": [uint, P(VOID), VOID],
                       "cuGraphicsUnmapResources": [uint, P(VOID), VOID],
                       "cuGraphicsResourceGetMappedPointer_v2": [P(u64), P(size), VOID],
                       "cuMemcpyDtoD_v2": [u64, u64, size]})
    except CudaError as e:
        raise Unavailable(str(e)) from None


class CudaShare:
    def __init__(self, ctx, backend):
        self.ctx, self.backend, self.cu = ctx, backend, _driver()
        self.context = backend.cuda_context()

    def _in_context(self, work) -> None:
        """work() in the backend's CUDA context; a failed driver call in it is Unavailable."""
        try:
            self.cu.in_context(self.context, work)
        except CudaError as e:
            raise Unavailable(f"CUDA's GL interop failed ({e})") from None

    def link(self, nbytes: int) -> Link:
        device, _ = self.backend.shared_buffer(nbytes)
        buffer = self.ctx.buffer(reserve=nbytes)
        resource = ctypes.c_void_p()
        self._in_context(lambda: self.cu.call("cuGraphicsGLRegisterBuffer", ctypes.byref(resource), buffer.glo,
                                               REGISTER_NONE))
        link = Link(buffer, device, nbytes, None)
        link.resource = resource

        def release():
            self._in_context(lambda: self.cu.call_unchecked("cuGraphicsUnregisterResource", resource))
            buffer.release()

        link._release = release
        return link

    def _copy(self, links, to_gl: bool) -> None:
        if not links:
            return
        resources = (ctypes.c_void_p * len(links))(*[link.resource.value for link in links])

        def work():
            self.cu.call("cuGraphicsMapResources", len(links), resources, None)
            try:
                for link in links:
                    pointer, size = ctypes.c_uint64(), ctypes.c_size_t()
                    self.cu.call("cuGraphicsResourceGetMappedPointer_v2", ctypes.byref(pointer), ctypes.byref(size),
                                 link.resource)
                    device = int(link.device.device_address)
                    dst, src = (pointer.value, device) if to_gl else (device, pointer.value)
                    self.cu.call("cuMemcpyDtoD_v2", dst, src, link.nbytes)
            finally:
                # on the default stream, as slang-rhi's work: after the device's work that wrote
                # the buffer, before its next; GL's work after the unmap waits for the copies on
                # the GPU (the mapping waited for GL's before it), so the host waits for nothing
                self.cu.call_unchecked("cuGraphicsUnmapResources", len(links), resources, None)

        self._in_context(work)

    def to_device(self, links) -> None:
        self._copy(links, to_gl=False)  # mapping waits for GL's work on the buffers

    def to_gl(self, links) -> None:
        self._copy(links, to_gl=True)
