"""The Slang backend's images: device buffers read back only when the host asks (to_numpy)."""
from __future__ import annotations

import numpy as np


class Image:
    """A (pixels, channels) float32 image in a device buffer."""

    def __init__(self, buffer, pixels: int, channels: int):
        self.buffer, self.pixels, self.channels = buffer, pixels, channels

    def to_numpy(self) -> np.ndarray:
        return self.buffer.to_numpy().view(np.float32)[: self.pixels * self.channels].reshape(self.pixels,
                                                                                              self.channels)


class Rgba8:
    """A height x width RGBA8 image in a device buffer, rows bottom-up (present's display)."""

    def __init__(self, buffer, width: int, height: int):
        self.buffer, self.width, self.height = buffer, width, height

    def to_numpy(self) -> np.ndarray:
        n = 4 * self.width * self.height
        return self.buffer.to_numpy().view(np.uint8)[:n].reshape(self.height, self.width, 4)
