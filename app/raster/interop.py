"""Memory that OpenGL and a GPU ray-tracing backend (rt/slang) both use, so that the hybrid
frame's G-buffer, the traced images the GL passes read and the displayed image do not go
through host memory.

A Link is one such piece of memory: a moderngl Buffer (`gl`) and a slangpy Buffer (`device`).
On Vulkan they are the same memory: the device's buffer is exported as a file descriptor and
imported into GL (GL_EXT_memory_object_fd); handing it over waits for the side that wrote it
(glFinish, or the device's work). On CUDA, GL's buffer is registered with CUDA (CUDA's own GL
interop, app/raster/cuda_gl.py) and copied to or from the device's buffer on the GPU.

`Interop.create` returns None with the reason where this cannot work (a driver without the
extension, GL and the device on different GPUs, a check that reads back other bytes); the
renderer then copies through host memory as before and says so once."""
from __future__ import annotations

import ctypes
import os

import numpy as np

HANDLE_TYPE_OPAQUE_FD = 0x9586  # GL_HANDLE_TYPE_OPAQUE_FD_EXT
SOFTWARE = ("llvmpipe", "lavapipe", "softpipe", "swrast", "swiftshader")


class Unavailable(Exception):
    """Why memory cannot be shared here (one line for the user)."""


def _gl_loader():
    """GL's function lookup for the context current on this thread: GLFW's for the viewer's
    window, else EGL's (headless contexts)."""
    import sys

    glfw = sys.modules.get("glfw")
    if glfw is not None and glfw.get_current_context():
        return lambda name: glfw.get_proc_address(name)
    try:
        egl = ctypes.CDLL("libEGL.so.1")
    except OSError as e:
        raise Unavailable(f"no EGL to look GL functions up ({e})") from None
    egl.eglGetProcAddress.restype = ctypes.c_void_p
    egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
    return lambda name: egl.eglGetProcAddress(name.encode())


class GL:
    """The few GL entry points moderngl does not wrap."""

    SIGNATURES = {
        "glCreateMemoryObjectsEXT": (None, ctypes.c_int, ctypes.POINTER(ctypes.c_uint)),
        "glDeleteMemoryObjectsEXT": (None, ctypes.c_int, ctypes.POINTER(ctypes.c_uint)),
        "glImportMemoryFdEXT": (None, ctypes.c_uint, ctypes.c_uint64, ctypes.c_uint, ctypes.c_int),
        "glCreateBuffers": (None, ctypes.c_int, ctypes.POINTER(ctypes.c_uint)),
        "glNamedBufferStorageMemEXT": (None, ctypes.c_uint, ctypes.c_ssize_t, ctypes.c_uint, ctypes.c_uint64),
        "glGetError": (ctypes.c_uint,),
    }

    def __init__(self):
        lookup = _gl_loader()
        for name, (result, *args) in self.SIGNATURES.items():
            address = lookup(name)
            if not address:
                raise Unavailable(f"this OpenGL has no {name}")
            setattr(self, name[2:], ctypes.CFUNCTYPE(result, *args)(address))

    def clear(self) -> None:
        """Forget errors of earlier GL calls (moderngl's), so that check() reports ours."""
        for _ in range(16):
            if not self.GetError():
                break

    def check(self, what: str) -> None:
        error = self.GetError()
        if error:
            raise Unavailable(f"{what} failed (GL error 0x{error:04x})")


class Link:
    """nbytes of memory seen by GL (gl: a moderngl Buffer) and by the device (device)."""

    def __init__(self, gl, device, nbytes: int, release):
        self.gl, self.device, self.nbytes, self._release = gl, device, nbytes, release

    def release(self) -> None:
        if self._release is not None:
            self._release()
            self._release = None


def same_gpu(ctx, backend) -> bool:
    """Whether GL and the device run on the same GPU, as far as their names tell: both Mesa's
    CPU implementations, or a device whose adapter name GL's renderer string starts with."""
    renderer = str(ctx.info.get("GL_RENDERER", "")).lower()
    adapter = backend.adapter.lower()
    if any(s in renderer for s in SOFTWARE) or any(s in adapter for s in SOFTWARE):
        return any(s in renderer for s in SOFTWARE) and any(s in adapter for s in SOFTWARE)
    return renderer.startswith(adapter.split("/")[0].strip()) or adapter.startswith(renderer.split("/")[0].strip())


class Interop:
    """The links of one GL context and one backend, by name, recreated when their size changes."""

    def __init__(self, ctx, backend, share):
        self.ctx, self.backend, self._share = ctx, backend, share
        self.kind = backend.name
        self.links: dict[str, Link] = {}

    @classmethod
    def create(cls, ctx, backend) -> "Interop":
        """Sharing between ctx and backend, checked with a pattern written on the device and read
        in GL; raises Unavailable with the reason where it cannot be had."""
        if not hasattr(backend, "shared_buffer"):
            raise Unavailable(f"the {backend.name} backend works in host memory")
        if not same_gpu(ctx, backend):
            raise Unavailable(f"OpenGL ({ctx.info.get('GL_RENDERER')}) and {backend.name} ({backend.adapter}) "
                              f"are not the same GPU")
        if backend.name == "vulkan":
            if "GL_EXT_memory_object_fd" not in ctx.extensions:
                raise Unavailable("this OpenGL has no GL_EXT_memory_object_fd")
            share = _VulkanShare(ctx, backend)
        else:
            from app.raster.cuda_gl import CudaShare

            share = CudaShare(ctx, backend)
        interop = cls(ctx, backend, share)
        interop._check()
        return interop

    def link(self, name: str, nbytes: int) -> Link:
        found = self.links.get(name)
        if found is None or found.nbytes != nbytes:
            if found is not None:
                found.release()
            found = self.links[name] = self._share.link(nbytes)
        return found

    def to_device(self, links) -> None:
        """GL wrote these links: make that visible to the device's next work."""
        self._share.to_device(links)

    def device_done(self) -> None:
        """Wait for the device's work (any thread): what it wrote may then go to GL."""
        self.backend.wait()

    def to_gl(self, links) -> None:
        """The device wrote these links (after device_done): make that visible to GL (GL thread)."""
        self._share.to_gl(links)

    def _check(self) -> None:
        """A pattern through a link each way: the same bytes, or Unavailable."""
        n = 4096
        link = self.link("check", 4 * n)
        try:
            pattern = (np.arange(n, dtype=np.uint32) * 2654435761) & 0xFFFFFFFF
            whole = np.zeros(link.device.size // 4, np.uint32)
            whole[:n] = pattern
            link.device.copy_from_numpy(whole)
            self.device_done()
            self.to_gl([link])
            plain = self.ctx.buffer(reserve=4 * n)
            self.ctx.copy_buffer(plain, link.gl, 4 * n)
            seen = np.frombuffer(plain.read(), np.uint32)
            plain.write(pattern[::-1].astype(np.uint32).tobytes())
            self.ctx.copy_buffer(link.gl, plain, 4 * n)
            plain.release()
            self.to_device([link])
            back = link.device.to_numpy().view(np.uint32)[:n]
        finally:
            link.release()
            del self.links["check"]
        if not np.array_equal(seen, pattern) or not np.array_equal(back, pattern[::-1]):
            raise Unavailable("memory shared between OpenGL and the device read back other bytes")

    def release(self) -> None:
        for link in self.links.values():
            link.release()
        self.links = {}


def describe(ctx, name: str) -> str:
    """One line on whether GL and the named GPU backend share memory here (rtlab devices)."""
    from rt.backends import create

    try:
        backend = create(name)
        interop = Interop.create(ctx, backend)
    except Unavailable as e:
        return f"copies through host memory ({e})"
    except Exception as e:  # noqa: BLE001 - a device that cannot be opened: said by its own row
        return f"copies through host memory ({str(e).splitlines()[0][:120]})"
    interop.release()
    backend.close()
    how = "the device's memory imported into GL" if name == "vulkan" else "CUDA's GL interop, copies on the GPU"
    return f"shared memory ({how})"


class _VulkanShare:
    """Vulkan memory exported as a file descriptor and imported into GL: one memory, no copies."""

    def __init__(self, ctx, backend):
        self.ctx, self.backend, self.gl = ctx, backend, GL()

    def link(self, nbytes: int) -> Link:
        gl = self.gl
        device, (_, fd, size) = self.backend.shared_buffer(nbytes)
        memory, name = ctypes.c_uint(), ctypes.c_uint()
        gl.clear()
        gl.CreateMemoryObjectsEXT(1, ctypes.byref(memory))
        gl.ImportMemoryFdEXT(memory, size, HANDLE_TYPE_OPAQUE_FD, os.dup(fd))  # GL owns the duplicate
        gl.check("importing the device's memory into OpenGL")
        gl.CreateBuffers(1, ctypes.byref(name))
        gl.NamedBufferStorageMemEXT(name, nbytes, memory, 0)
        gl.check("a GL buffer in the device's memory")
        buffer = self.ctx.external_buffer(name.value, nbytes)

        def release():
            buffer.release()  # deletes the GL buffer
            gl.DeleteMemoryObjectsEXT(1, ctypes.byref(memory))

        return Link(buffer, device, nbytes, release)

    def to_device(self, links) -> None:
        self.ctx.finish()

    def to_gl(self, links) -> None:
        pass  # the same memory, and device_done waited for the device
