"""Fly camera for the viewer: WASD move, Q/E down/up, right-drag look, Shift/Ctrl speed,
scroll wheel scales the base speed. Pure logic, so it is tested without a window."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.camera import Camera


@dataclass
class FlyInput:
    move: tuple = (0.0, 0.0, 0.0)  # right, up, forward in -1..1
    look: tuple = (0.0, 0.0)  # mouse pixels dragged (x right, y down)
    fast: bool = False
    slow: bool = False
    scroll: float = 0.0


class FlyCamera:
    def __init__(self, camera: Camera, scene_diagonal: float):
        self.camera = camera.copy()
        self.speed = max(scene_diagonal, 1.0) * 0.08  # metres per second
        self.sensitivity = 0.0035  # radians per pixel
        self._sync_angles()

    def _sync_angles(self) -> None:
        _, _, f = self.camera.basis()
        self.yaw = float(np.arctan2(f[0], -f[2]))
        self.pitch = float(np.arcsin(np.clip(f[1], -1, 1)))

    def set_camera(self, camera: Camera) -> None:
        self.camera = camera.copy()
        self._sync_angles()

    def forward(self) -> np.ndarray:
        cp = np.cos(self.pitch)
        return np.array([np.sin(self.yaw) * cp, np.sin(self.pitch), -np.cos(self.yaw) * cp])

    def update(self, dt: float, inp: FlyInput) -> bool:
        """Apply one frame of input; returns True if the camera moved."""
        moved = False
        if inp.scroll:
            self.speed = float(np.clip(self.speed * 1.2 ** inp.scroll, 1e-3, 1e4))
        if inp.look[0] or inp.look[1]:
            self.yaw += inp.look[0] * self.sensitivity
            self.pitch = float(np.clip(self.pitch - inp.look[1] * self.sensitivity, -1.55, 1.55))
            moved = True
        f = self.forward()
        up = np.array([0.0, 1.0, 0.0])
        r = np.cross(f, up)
        r /= max(np.linalg.norm(r), 1e-9)
        step = self.speed * dt * (4.0 if inp.fast else 1.0) * (0.25 if inp.slow else 1.0)
        delta = (inp.move[0] * r + inp.move[1] * up + inp.move[2] * f) * step
        if np.any(delta):
            self.camera.eye = self.camera.eye + delta
            moved = True
        self.camera.up = up
        self.camera.target = self.camera.eye + f
        return moved
