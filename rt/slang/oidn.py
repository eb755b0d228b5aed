"""Open Image Denoise on the Slang backend's GPU (SlangBackend.present with an OidnFrame): OIDN's
CUDA device filters the image shown (the device's running mean) in the device's own memory,
guided by the device's G-buffer, with the kernels of shaders/rt/oidn.slang making its inputs and putting the emission
and the sky back; nothing leaves the GPU.

On the CUDA backend OIDN runs in the backend's CUDA context, on the stream slang-rhi submits to
(the default one): it reads and writes the backend's buffers by their device addresses, in
stream order after the frame's work and before the rest of it, so the host waits for none of it;
its GPU time comes from two CUDA events read with the frame (rt/slang/flights.py). On the
Vulkan backend its images live in memory Vulkan exports (BufferUsage.shared) and OIDN imports by
file descriptor; there the host waits for the device before the filter and for the filter
before the frame goes on (no semaphore between the two APIs here yet). Where OIDN has no CUDA
device (no NVIDIA GPU, or OIDN built without one), `missing` says why (the backend's oidn_note)
and the renderer runs OIDN on the CPU (app/raster/oidn.py)."""
from __future__ import annotations

import ctypes
import os
import time

from rt.libcuda import VOID, CudaError, Driver, P
from rt.slang.flights import SLOTS
from rt.slang.images import Image
from rt.slang.oidn_library import EXTERNAL_OPAQUE_FD, FORMAT_FLOAT3, QUALITY, OidnError, library
from rt.slang.pipeline import ComputePipeline

FILE = "oidn.slang"
IMAGES = ("color", "albedo", "normal", "output")  # OIDN's names; "output" is g_denoised


def missing(ordinal: int = 0) -> str | None:
    """Why OIDN has no GPU device for CUDA device `ordinal` here, or None where it has one."""
    try:
        if library().IsCUDADeviceSupported(ordinal):
            return None
    except OidnError as e:
        return str(e)
    return "OIDN has no GPU device here: its CUDA device needs an NVIDIA GPU"


class DeviceOidn:
    def __init__(self, backend):
        self.backend, self.lib = backend, library()
        self.cuda = backend.name == "cuda"
        ordinal = backend.cuda_ordinal() if self.cuda else 0
        reason = missing(ordinal)
        if reason is not None:
            raise OidnError(reason)
        self.cu = None
        if self.cuda:
            try:
                self.cu = Driver({"cuEventCreate": [P(VOID), ctypes.c_uint], "cuEventRecord": [VOID, VOID],
                                  "cuEventSynchronize": [VOID],
                                  "cuEventElapsedTime": [P(ctypes.c_float), VOID, VOID],
                                  "cuEventDestroy_v2": [VOID]})
            except CudaError as e:
                raise OidnError(str(e)) from None
        self.events = [(VOID(), VOID()) for _ in range(SLOTS)]

        def make():
            ids = (ctypes.c_int * 1)(ordinal)
            streams = (VOID * 1)(None)  # the default stream: slang-rhi's on CUDA
            device = self.lib.NewCUDADevice(ids, streams, 1)
            if not device:
                raise OidnError("OIDN's CUDA device could not be made")
            self.lib.CommitDevice(device)
            self.lib.check(device)
            if self.cu is not None:
                for pair in self.events:
                    for e in pair:
                        self.cu.call("cuEventCreate", ctypes.byref(e), 0)
            return device

        self.device = self._in_context(make)
        if not self.cuda and not self.lib.GetDeviceInt(self.device, b"externalMemoryTypes") & EXTERNAL_OPAQUE_FD:
            self.lib.ReleaseDevice(self.device)
            raise OidnError("OIDN's CUDA device cannot import Vulkan's memory")
        self._kernels = {name: ComputePipeline(backend.device, name, FILE) for name in ("oidn_inputs", "oidn_finish")}
        self._present = ComputePipeline(backend.device, "present")  # the denoised image's own display
        self._images: dict = {}  # name -> (device buffer, OIDN buffer or None, bytes)
        self._filter, self._filter_key = None, None

    def _in_context(self, work):
        """work() with the CUDA backend's context current (OIDN's runtime calls then run in it)."""
        if not self.cuda:
            return work()
        try:
            return self.cu.in_context(self.backend.cuda_context(), work)
        except CudaError as e:
            raise OidnError(str(e)) from None

    def _image(self, name: str, nbytes: int):
        """OIDN's image `name` of at least nbytes: (device buffer, OIDN buffer or None)."""
        found = self._images.get(name)
        if found is not None and found[2] >= nbytes:
            return found[:2]
        if found is not None and found[1] is not None:
            self.lib.ReleaseBuffer(found[1])
        if self.cuda:
            buffer, shared = self.backend._buffer(f"oidn.{name}", nbytes // 4, 4), None
        else:
            buffer, (_, fd, size) = self.backend.shared_buffer(nbytes)
            # OIDN (CUDA) takes the descriptor it imports: it gets its own
            shared = self.lib.NewSharedBufferFromFD(self.device, EXTERNAL_OPAQUE_FD, os.dup(fd), size)
            self.lib.check(self.device)
        self._images[name] = (buffer, shared, nbytes)
        self._filter_key = None  # the filter's images moved
        return buffer, shared

    def _filter_for(self, run, w: int, h: int, images: dict):
        key = (w, h, run.quality)
        if self._filter is not None and self._filter_key == key:
            return self._filter
        if self._filter is not None:
            self.lib.ReleaseFilter(self._filter)
        f = self.lib.NewFilter(self.device, b"RT")
        for name, (buffer, shared) in images.items():
            if shared is None:
                self.lib.SetSharedFilterImage(f, name.encode(), VOID(int(buffer.device_address)), FORMAT_FLOAT3, w, h,
                                              0, 12, 12 * w)
            else:
                self.lib.SetFilterImage(f, name.encode(), shared, FORMAT_FLOAT3, w, h, 0, 12, 12 * w)
        self.lib.SetFilterBool(f, b"hdr", True)
        self.lib.SetFilterBool(f, b"cleanAux", True)  # the G-buffer's albedo and normal are noise-free
        self.lib.SetFilterInt(f, b"quality", QUALITY[run.quality])
        self.lib.CommitFilter(f)
        self.lib.check(self.device)
        self._filter, self._filter_key = f, key
        return f

    def run(self, shown: Image, run, exposure: float, display) -> tuple[Image, object]:
        """shown (the running mean, 4 floats a pixel) denoised as run (rt/oidn.py's OidnFrame)
        says, and its tone-mapped 8-bit RGBA into display: (denoised image, display)."""
        b = self.backend
        w, h = b.inputs.width, b.inputs.height
        n = w * h
        images = {name: self._image(name, 12 * n) for name in IMAGES}
        bufs = {name: images[name][0] for name in IMAGES}
        common = {"g_gbuffer": b.gbuffer, "g_shown": shown.buffer, "g_width": w, "g_height": h,
                  "g_has_albedo": int(run.has_albedo), "g_has_emission": int(run.has_emission),
                  "g_ggx": int(run.ggx)}
        self._kernels["oidn_inputs"].dispatch(b._encoding(), w, h, {
            **common, "g_color": bufs["color"], "g_albedo": bufs["albedo"], "g_normal": bufs["normal"]})
        f = self._in_context(lambda: self._filter_for(run, w, h, images))
        b._submit()  # OIDN reads what the frame has made so far
        flight = b._flights.current
        if self.cuda:
            start, end = self.events[flight.slot]

            def execute():
                self.cu.call("cuEventRecord", start, None)
                self.lib.ExecuteFilterAsync(f)
                self.cu.call("cuEventRecord", end, None)

            self._in_context(execute)
            flight.timers["oidn"] = lambda: self._elapsed(start, end)
        else:
            b.device.wait()
            t0 = time.perf_counter()
            self.lib.ExecuteFilter(f)  # returns when the filter is done
            ms = (time.perf_counter() - t0) * 1e3
            flight.timers["oidn"] = lambda: ms
        self.lib.check(self.device)
        result = b._buffer("oidn.result", 3 * n, 4)
        self._kernels["oidn_finish"].dispatch(b._encoding(), w, h, {
            **common, "g_denoised": bufs["output"], "g_result": result})
        out = b._buffer("oidn.shown", n, 16)
        self._present.dispatch(b._encoding(), w, h, {"g_radiance": result, "g_accumulated": out, "g_display": display,
                                                     "g_width": w, "g_height": h, "g_weight": 1.0,
                                                     "g_exposure": float(exposure)})
        return Image(out, n, 4), display

    def _elapsed(self, start, end) -> float:
        ms = ctypes.c_float()

        def read():
            self.cu.call("cuEventSynchronize", end)
            self.cu.call("cuEventElapsedTime", ctypes.byref(ms), start, end)

        self._in_context(read)
        return float(ms.value)

    def close(self) -> None:
        def release():
            if self._filter is not None:
                self.lib.ReleaseFilter(self._filter)
            for _, shared, _ in self._images.values():
                if shared is not None:
                    self.lib.ReleaseBuffer(shared)
            self.lib.ReleaseDevice(self.device)
            if self.cu is not None:
                for pair in self.events:
                    for e in pair:
                        self.cu.call_unchecked("cuEventDestroy_v2", e)

        self._filter, self._images = None, {}
        try:
            self._in_context(release)
        except OidnError:  # the device is gone: nothing to give back
            pass
