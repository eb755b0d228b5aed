"""CUDA's own OpenGL interop for the CUDA backend (app/raster/interop.py): a GL buffer
registered with CUDA (cuGraphicsGLRegisterBuffer) in the backend's CUDA context, mapped while
the device buffer is copied to or from it on the GPU (cuMemcpyDtoD), unmapped before GL uses it
again. Through the CUDA driver library with ctypes: no CUDA toolkit is needed."""
from __future__ import annotations

import ctypes

from app.raster.interop import Link, Unavailable

REGISTER_NONE = 0


def _driver():
    try:
        cuda = ctypes.CDLL("libcuda.so.1")
    except OSError as e:
        raise Unavailable(f"no CUDA driver library ({e})") from None
    names = {"register": "cuGraphicsGLRegisterBuffer", "unregister": "cuGraphicsUnregisterResource",
             "map": "cuGraphicsMapResources", "unmap": "cuGraphicsUnmapResources",
             "pointer": "cuGraphicsResourceGetMappedPointer_v2", "copy": "cuMemcpyDtoD_v2",
             "push": "cuCtxPushCurrent_v2", "pop": "cuCtxPopCurrent_v2"}
    found = {}
    for key, name in names.items():
        try:
            found[key] = getattr(cuda, name)
        except AttributeError:
            raise Unavailable(f"the CUDA driver has no {name}") from None
    found["register"].argtypes = [ctypes.POINTER(ctypes.c_void_p), ctypes.c_uint, ctypes.c_uint]
    found["unregister"].argtypes = [ctypes.c_void_p]
    for key in ("map", "unmap"):
        found[key].argtypes = [ctypes.c_uint, ctypes.POINTER(ctypes.c_void_p), ctypes.c_void_p]
    found["pointer"].argtypes = [ctypes.POINTER(ctypes.c_uint64), ctypes.POINTER(ctypes.c_size_t), ctypes.c_void_p]
    found["copy"].argtypes = [ctypes.c_uint64, ctypes.c_uint64, ctypes.c_size_t]
    found["push"].argtypes = [ctypes.c_void_p]
    found["pop"].argtypes = [ctypes.POINTER(ctypes.c_void_p)]
    return found


class CudaShare:
    def __init__(self, ctx, backend):
        self.ctx, self.backend, self.cu = ctx, backend, _driver()
        self.context = backend.cuda_context()

    def _call(self, key: str, *args) -> None:
        result = self.cu[key](*args)
        if result != 0:
            raise Unavailable(f"CUDA's GL interop failed ({key}: CUDA error {result})")

    def _in_context(self, work) -> None:
        self._call("push", ctypes.c_void_p(self.context))
        try:
            work()
        finally:
            popped = ctypes.c_void_p()
            self.cu["pop"](ctypes.byref(popped))

    def link(self, nbytes: int) -> Link:
        device, _ = self.backend.shared_buffer(nbytes)
        buffer = self.ctx.buffer(reserve=nbytes)
        resource = ctypes.c_void_p()
        self._in_context(lambda: self._call("register", ctypes.byref(resource), buffer.glo, REGISTER_NONE))
        link = Link(buffer, device, nbytes, None)
        link.resource = resource

        def release():
            self._in_context(lambda: self.cu["unregister"](resource))
            buffer.release()

        link._release = release
        return link

    def _copy(self, links, to_gl: bool) -> None:
        if not links:
            return
        resources = (ctypes.c_void_p * len(links))(*[link.resource.value for link in links])

        def work():
            self._call("map", len(links), resources, None)
            try:
                for link in links:
                    pointer, size = ctypes.c_uint64(), ctypes.c_size_t()
                    self._call("pointer", ctypes.byref(pointer), ctypes.byref(size), link.resource)
                    device = int(link.device.device_address)
                    dst, src = (pointer.value, device) if to_gl else (device, pointer.value)
                    self._call("copy", dst, src, link.nbytes)
            finally:
                # on the default stream, as slang-rhi's work: after the device's work that wrote
                # the buffer, before its next; GL's work after the unmap waits for the copies on
                # the GPU (the mapping waited for GL's before it), so the host waits for nothing
                self.cu["unmap"](len(links), resources, None)

        self._in_context(work)

    def to_device(self, links) -> None:
        self._copy(links, to_gl=False)  # mapping waits for GL's work on the buffers

    def to_gl(self, links) -> None:
        self._copy(links, to_gl=True)
