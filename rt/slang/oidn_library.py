"""Intel Open Image Denoise's C API through ctypes, from the library that the `pyoidn` package
ships (its Python wrapper binds neither buffers imported from a file descriptor nor the device
queries that the GPU path needs). Only what rt/slang/oidn.py calls."""
from __future__ import annotations

import ctypes
import importlib.util
import os

VOID, SIZE, INT, CHARS = ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int, ctypes.c_char_p
FORMAT_FLOAT3 = 3
EXTERNAL_OPAQUE_FD = 1  # OIDN_EXTERNAL_MEMORY_TYPE_FLAG_OPAQUE_FD
QUALITY = {"fast": 4, "balanced": 5, "high": 6}

SIGNATURES = {  # name: (result type, argument types)
    "oidnIsCUDADeviceSupported": (ctypes.c_bool, [INT]),
    "oidnNewCUDADevice": (VOID, [ctypes.POINTER(INT), ctypes.POINTER(VOID), INT]),
    "oidnCommitDevice": (None, [VOID]),
    "oidnReleaseDevice": (None, [VOID]),
    "oidnGetDeviceInt": (INT, [VOID, CHARS]),
    "oidnGetDeviceError": (INT, [VOID, ctypes.POINTER(CHARS)]),
    "oidnNewSharedBufferFromFD": (VOID, [VOID, INT, INT, SIZE]),
    "oidnReleaseBuffer": (None, [VOID]),
    "oidnNewFilter": (VOID, [VOID, CHARS]),
    "oidnSetFilterImage": (None, [VOID, CHARS, VOID, INT, SIZE, SIZE, SIZE, SIZE, SIZE]),
    "oidnSetSharedFilterImage": (None, [VOID, CHARS, VOID, INT, SIZE, SIZE, SIZE, SIZE, SIZE]),
    "oidnSetFilterBool": (None, [VOID, CHARS, ctypes.c_bool]),
    "oidnSetFilterInt": (None, [VOID, CHARS, INT]),
    "oidnCommitFilter": (None, [VOID]),
    "oidnExecuteFilter": (None, [VOID]),
    "oidnExecuteFilterAsync": (None, [VOID]),
    "oidnReleaseFilter": (None, [VOID]),
}


class OidnError(RuntimeError):
    """No OIDN library, or a call on its device failed (the device's own message)."""


class Library:
    def __init__(self):
        spec = importlib.util.find_spec("pyoidn")
        if spec is None or spec.origin is None:
            raise OidnError("the pyoidn package is not installed")
        path = os.path.join(os.path.dirname(spec.origin), "oidn", "lib", "libOpenImageDenoise.so.2")
        try:
            lib = ctypes.CDLL(path)
        except OSError as e:
            raise OidnError(f"OIDN's library did not load ({e})") from None
        for name, (result, args) in SIGNATURES.items():
            try:
                f = getattr(lib, name)
            except AttributeError:
                raise OidnError(f"OIDN's library has no {name}") from None
            f.restype, f.argtypes = result, args
            setattr(self, name[4:], f)  # oidnNewFilter -> self.NewFilter

    def check(self, device) -> None:
        """OidnError with the device's message if its last call failed."""
        message = CHARS()
        if self.GetDeviceError(device, ctypes.byref(message)) != 0:
            raise OidnError((message.value or b"unknown error").decode(errors="replace"))


_LIBRARY: list = []


def library() -> Library:
    """The library, loaded once per process (OidnError where it cannot be)."""
    if not _LIBRARY:
        _LIBRARY.append(Library())
    return _LIBRARY[0]
