"""The CUDA driver library through ctypes (no CUDA toolkit needed): the functions a caller names,
with their argument types, each call checked, and work run with a CUDA context current (pushed,
then popped). Shared by the frames-in-flight ray counter (rt/slang/flights.py) and CUDA's
OpenGL interop (app/raster/cuda_gl.py)."""
from __future__ import annotations

import ctypes

P = ctypes.POINTER
VOID = ctypes.c_void_p
CONTEXT = {"cuCtxPushCurrent_v2": [VOID], "cuCtxPopCurrent_v2": [P(VOID)]}


class CudaError(RuntimeError):
    """The driver library is missing, lacks a function, or a call failed."""


class Driver:
    def __init__(self, signatures: dict[str, list]):
        try:
            lib = ctypes.CDLL("libcuda.so.1")
        except OSError as e:
            raise CudaError(f"no CUDA driver library ({e})") from None
        self.functions = {}
        for name, argtypes in {**CONTEXT, **signatures}.items():
            try:
                function = getattr(lib, name)
            except AttributeError:
                raise CudaError(f"the CUDA driver has no {name}") from None
            function.argtypes = argtypes
            self.functions[name] = function

    def call(self, name: str, *args) -> None:
        """Call a function; CudaError unless it returns CUDA_SUCCESS."""
        result = self.functions[name](*args)
        if result != 0:
            raise CudaError(f"{name}: CUDA error {result}")

    def call_unchecked(self, name: str, *args) -> int:
        """Call a function whose failure the caller can do nothing about (releases)."""
        return self.functions[name](*args)

    def in_context(self, context: int, work):
        """work() with the CUDA context current on this thread; its result."""
        self.call("cuCtxPushCurrent_v2", VOID(context))
        try:
            return work()
        finally:
            popped = VOID()
            self.functions["cuCtxPopCurrent_v2"](ctypes.byref(popped))
