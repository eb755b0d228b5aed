"""Frames in flight on a slangpy device: each frame's submission, its ray count and its
dispatches' timestamps, read once the device has done that frame, while the host goes on to the
next one (end(lag=1)) or at once (lag=0, a frame the host needs finished, e.g. to show it).

The device's ray counter (a running sum spread over COUNTER_WORDS words, which the host adds up:
shaders/rt/common.slang count_rays) is copied into host memory after each frame's work, into one
of two slots, so that the copy of frame N+1 does not overwrite frame N's before it is read. On
Vulkan the copy is recorded with the frame's work; on CUDA slang-rhi runs a recorded copy into
host memory as a synchronous cuMemcpy at submission, which would make the host wait for the frame
there, so the copy is CUDA's asynchronous one, followed by an event that the reading waits on
(_CudaCounter)."""
from __future__ import annotations

import ctypes
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from rt.libcuda import VOID, Driver, P

SLOTS = 2  # frames whose results are kept: the one being recorded and one in flight
COUNTER_WORDS = 256  # the ray counter's words (shaders/rt/common.slang's COUNTER_WORDS)
COUNTER_BYTES = 4 * COUNTER_WORDS


def counter_total(words) -> int:
    """The counter's value: its words' sum, modulo 2^32 as one word would wrap."""
    return int(np.asarray(words, np.uint32).sum(dtype=np.uint64)) % 2**32


@dataclass
class Flight:
    slot: int
    primary: int = 0  # rays counted on the host (the primary hits: one a pixel)
    counted: bool = False  # an effect added to the device's ray counter
    timers: dict = field(default_factory=dict)  # dispatch name -> its GPU time (ms) once done
    submit: int | None = None  # the frame's last submission


class Flights:
    def __init__(self, device, kind: str, counter, cuda_context: int | None = None):
        self.device = device
        self.current = Flight(0)
        self.pending: deque[Flight] = deque()
        self.rays = 0  # rays of the frames read so far
        self.last_rays = 0  # those of the last frame read
        self._counter_read = 0  # the counter's value when last read (it wraps at 2^32: differences are taken)
        self.gpu_ms: dict = {}  # the last frame read's dispatch times
        self.counter = _CudaCounter(cuda_context, counter) if kind == "cuda" else _VulkanCounter(device, counter)

    def end(self, encoder_of, submit, lag: int) -> None:
        """The current frame ends: its counter copied (encoder_of() records with the frame's
        work, submit() submits it and gives the submission's id), then frames read until at most
        lag of them are in flight."""
        f = self.current
        if f.counted:
            self.counter.record(encoder_of, f.slot)
        f.submit = submit()
        if f.counted:
            self.counter.after_submit(f.slot)
        self.pending.append(f)
        self.current = Flight(f.slot ^ 1)
        self.retire(lag)

    def retire(self, lag: int = 0) -> None:
        """Read the frames in flight, oldest first, until at most lag remain (waits for them)."""
        while len(self.pending) > min(lag, SLOTS - 1):
            f = self.pending.popleft()
            if f.submit is not None:
                self.device.wait_for_submit(f.submit)
            before = self.rays
            if f.counted:
                value = self.counter.read(f.slot)
                self.rays += (value - self._counter_read) % 2**32
                self._counter_read = value
            self.rays += f.primary
            self.last_rays = self.rays - before
            self.gpu_ms = {name: timer() for name, timer in f.timers.items()}


class _VulkanCounter:
    """The counter copied into host-visible memory with the frame's work; reading maps it."""

    def __init__(self, device, counter):
        import slangpy as spy

        self.counter = counter
        self.host = [device.create_buffer(size=COUNTER_BYTES, memory_type=spy.MemoryType.read_back,
                                          usage=spy.BufferUsage.copy_destination) for _ in range(SLOTS)]

    def record(self, encoder_of, slot: int) -> None:
        encoder_of().copy_buffer(self.host[slot], 0, self.counter, 0, COUNTER_BYTES)

    def after_submit(self, slot: int) -> None:
        pass

    def read(self, slot: int) -> int:
        return counter_total(self.host[slot].to_numpy().view(np.uint32))


class _CudaCounter:
    """The counter copied by cuMemcpyDtoHAsync into page-locked memory on the stream slang-rhi
    submits to (the default one), then an event; reading waits for the event only."""

    def __init__(self, context: int, counter):
        u64, size = ctypes.c_uint64, ctypes.c_size_t
        self.cu = Driver({"cuMemHostAlloc": [P(VOID), size, ctypes.c_uint], "cuMemFreeHost": [VOID],
                          "cuMemcpyDtoHAsync_v2": [VOID, u64, size, VOID],
                          "cuEventCreate": [P(VOID), ctypes.c_uint], "cuEventRecord": [VOID, VOID],
                          "cuEventSynchronize": [VOID], "cuEventDestroy_v2": [VOID]})
        self.context, self.counter = context, counter
        self.host = VOID()
        self.events = [VOID() for _ in range(SLOTS)]

        def make():
            self.cu.call("cuMemHostAlloc", ctypes.byref(self.host), COUNTER_BYTES * SLOTS, 0)
            for e in self.events:
                self.cu.call("cuEventCreate", ctypes.byref(e), 2)  # 2: no timing

        self.cu.in_context(context, make)
        self.values = np.ctypeslib.as_array((ctypes.c_uint32 * (COUNTER_WORDS * SLOTS)).from_address(self.host.value))

    def record(self, encoder_of, slot: int) -> None:
        pass

    def after_submit(self, slot: int) -> None:
        def copy():
            self.cu.call("cuMemcpyDtoHAsync_v2", self.host.value + COUNTER_BYTES * slot,
                         int(self.counter.device_address), COUNTER_BYTES, None)
            self.cu.call("cuEventRecord", self.events[slot], None)

        self.cu.in_context(self.context, copy)

    def read(self, slot: int) -> int:
        self.cu.in_context(self.context, lambda: self.cu.call("cuEventSynchronize", self.events[slot]))
        return counter_total(self.values[COUNTER_WORDS * slot:COUNTER_WORDS * (slot + 1)])

    def __del__(self):
        try:
            def free():
                for e in self.events:
                    self.cu.call_unchecked("cuEventDestroy_v2", e)
                self.cu.call_unchecked("cuMemFreeHost", self.host)

            self.cu.in_context(self.context, free)
        except Exception:  # noqa: BLE001 - the process is ending or the device is gone
            pass
