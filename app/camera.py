"""Pinhole camera: eye/target/up + vertical fov in degrees; round-trips as a `--camera` string."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.errors import UserError
from scenes.model import View


@dataclass
class Camera:
    eye: np.ndarray
    target: np.ndarray
    up: np.ndarray
    fov: float = 60.0
    near: float = 0.05
    far: float = 500.0

    @staticmethod
    def from_view(view: View, scene_diagonal: float = 100.0) -> Camera:
        cam = Camera(np.array(view.eye, np.float64), np.array(view.target, np.float64),
                     np.array(view.up, np.float64), float(view.fov))
        cam.fit_clip(scene_diagonal)
        return cam

    def fit_clip(self, scene_diagonal: float) -> None:
        """Near/far planes that keep depth precision for a scene of this size."""
        self.far = max(scene_diagonal * 2.0, 1.0)
        self.near = max(self.far * 1e-4, 1e-4)

    def copy(self) -> Camera:
        return Camera(self.eye.copy(), self.target.copy(), self.up.copy(), self.fov, self.near, self.far)

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Right, up, forward unit vectors (right-handed, camera looks along forward)."""
        # plain float arithmetic: np.cross and np.linalg.norm on 3-vectors cost ~0.1 ms a frame,
        # and the basis is asked for several times a frame
        fx, fy, fz = (float(t) - float(e) for t, e in zip(self.target, self.eye))
        n = max((fx * fx + fy * fy + fz * fz) ** 0.5, 1e-12)
        fx, fy, fz = fx / n, fy / n, fz / n
        ux, uy, uz = (float(c) for c in self.up)
        rx, ry, rz = fy * uz - fz * uy, fz * ux - fx * uz, fx * uy - fy * ux
        n = (rx * rx + ry * ry + rz * rz) ** 0.5
        if n < 1e-9:  # looking along up: pick any perpendicular
            ux, uy, uz = (1.0, 0.0, 0.0) if abs(fx) < 0.9 else (0.0, 0.0, 1.0)
            rx, ry, rz = fy * uz - fz * uy, fz * ux - fx * uz, fx * uy - fy * ux
            n = (rx * rx + ry * ry + rz * rz) ** 0.5
        rx, ry, rz = rx / n, ry / n, rz / n
        r, f = np.array((rx, ry, rz)), np.array((fx, fy, fz))
        return r, np.array((ry * fz - rz * fy, rz * fx - rx * fz, rx * fy - ry * fx)), f

    def view_matrix(self) -> np.ndarray:
        r, u, f = self.basis()
        m = np.eye(4)
        m[0, :3], m[1, :3], m[2, :3] = r, u, -f
        m[:3, 3] = -m[:3, :3] @ self.eye
        return m

    def projection_matrix(self, aspect: float) -> np.ndarray:
        t = 1.0 / np.tan(np.radians(self.fov) / 2)
        n, f = self.near, self.far
        m = np.zeros((4, 4))
        m[0, 0] = t / aspect
        m[1, 1] = t
        m[2, 2] = (f + n) / (n - f)
        m[2, 3] = 2 * f * n / (n - f)
        m[3, 2] = -1
        return m

    def primary_rays(self, width: int, height: int, jitter: np.ndarray | None = None):
        """Origins and unit directions (H*W,3) float32 through pixel centres, row 0 at the top."""
        r, u, f = self.basis()
        th = np.tan(np.radians(self.fov) / 2)
        aspect = width / height
        px = (np.arange(width) + 0.5) / width * 2 - 1
        py = 1 - (np.arange(height) + 0.5) / height * 2
        x, y = np.meshgrid(px * th * aspect, py * th)
        if jitter is not None:
            x = x + jitter[..., 0] * 2 * th * aspect / width
            y = y - jitter[..., 1] * 2 * th / height
        d = x[..., None] * r + y[..., None] * u + f
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        d = d.reshape(-1, 3).astype(np.float32)
        o = np.broadcast_to(self.eye.astype(np.float32), d.shape).copy()
        return o, d

    def to_string(self) -> str:
        return View("", tuple(self.eye), tuple(self.target), tuple(self.up), self.fov).to_string()

    def state(self) -> tuple:
        """Hashable state: a change of it is camera motion (resets accumulation)."""
        return tuple(np.round(np.concatenate([self.eye, self.target, self.up, [self.fov]]), 7))


def radical_inverse(i: int, base: int) -> float:
    """The van der Corput radical inverse of i in a base: i's digits mirrored behind the point."""
    value, scale = 0.0, 1.0 / base
    while i > 0:
        i, digit = divmod(i, base)
        value += digit * scale
        scale /= base
    return value


def subpixel_jitter(index: int) -> tuple[float, float]:
    """Accumulated frame index's sample point in the pixel, as an offset from its centre in pixels
    (right, down), each in [-0.5, 0.5): the Halton (2, 3) sequence shifted by half a pixel, so
    frame 0 samples the centre and N frames stratify the pixel (their average converges to the
    box-filtered image)."""
    return tuple((radical_inverse(index, b) + 0.5) % 1.0 - 0.5 for b in (2, 3))


def parse_camera(text: str, scene) -> Camera:
    """A named view of the scene, or 'eye=x,y,z;target=x,y,z;up=x,y,z;fov=DEG'."""
    if "=" not in text:
        if text in scene.views:
            return Camera.from_view(scene.views[text], scene.diagonal)
        names = ", ".join(scene.views) or "(none)"
        raise UserError(f"unknown camera {text!r} for scene {scene.name}; named views: {names}")
    fields = {"up": (0.0, 1.0, 0.0), "fov": 60.0}
    for part in text.split(";"):
        if not part.strip():
            continue
        key, _, value = part.partition("=")
        key = key.strip()
        try:
            if key in ("eye", "target", "up"):
                v = tuple(float(x) for x in value.split(","))
                if len(v) != 3:
                    raise ValueError
                fields[key] = v
            elif key == "fov":
                fields[key] = float(value)
            else:
                raise UserError(f"--camera: unknown field {key!r}; use eye, target, up, fov")
        except ValueError:
            raise UserError(f"--camera: bad value for {key}: {value!r}") from None
    if "eye" not in fields or "target" not in fields:
        raise UserError("--camera needs eye=x,y,z and target=x,y,z")
    vals = np.array(fields["eye"] + fields["target"] + fields["up"] + (fields["fov"],))
    if not np.isfinite(vals).all():
        raise UserError("--camera: values must be finite")
    if np.abs(vals[:9]).max() > 1e12:
        raise UserError("--camera: coordinates must lie within +-1e12 m")
    if not 1.0 <= fields["fov"] <= 170.0:
        raise UserError(f"--camera: fov must be within 1..170 degrees, got {fields['fov']}")
    if np.linalg.norm(np.subtract(fields["target"], fields["eye"])) < 1e-9:
        raise UserError("--camera: eye and target must differ")
    return Camera.from_view(View("cli", fields["eye"], fields["target"], fields["up"], fields["fov"]), scene.diagonal)
