"""Keep freed memory for reuse instead of handing it back to the OS after every frame.

The frame kernels allocate their per-block scratch (hundreds of kB an array) with malloc.
glibc serves blocks that large with mmap, or from a thread's own heap that it shrinks again
when they are freed, so the next block or frame touches fresh pages: each a page fault, and a
page the OS zeroes, and page faults serialise threads on the process's memory map lock.

Raising both thresholds (glibc's mallopt) keeps up to TRIM_THRESHOLD of freed memory in each
arena for the next allocation. Elsewhere than glibc this does nothing."""
from __future__ import annotations

import ctypes

M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3  # glibc's malloc.h
MMAP_THRESHOLD = 32 << 20  # glibc's largest: blocks above it are still mapped on their own
TRIM_THRESHOLD = 256 << 20  # freed memory kept at the top of an arena before it is returned


def keep_freed_memory() -> bool:
    """Raise glibc malloc's mmap and trim thresholds for this process; True if it took."""
    try:
        libc = ctypes.CDLL(None)  # the process's own symbols, the C library's among them
    except OSError:  # Windows
        return False
    if not hasattr(libc, "gnu_get_libc_version") or not hasattr(libc, "mallopt"):  # not glibc
        return False
    return bool(libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(libc.mallopt(M_TRIM_THRESHOLD,
                                                                                      TRIM_THRESHOLD))


def return_freed_memory() -> bool:
    """Hand the memory that keep_freed_memory() keeps back to the OS now (glibc's malloc_trim):
    for moments when a stall does not matter and much was freed, such as the viewer's scene
    switch. True if it took."""
    try:
        libc = ctypes.CDLL(None)
    except OSError:
        return False
    if not hasattr(libc, "malloc_trim"):
        return False
    libc.malloc_trim(0)
    return True
