"""Intel Open Image Denoise (`denoise=oidn`, through `pyoidn`, on the CPU; rt/oidn.py's options): the image shown
(the running mean while accumulating, else the frame) denoised with the raster G-buffer's
albedo and normal as auxiliary images; the first hit's emission and the sky bypass it. Runs on
the GL thread: the three images are read back, filtered, and the result uploaded in place of
the accumulated image. Where the ray-tracing backend runs OIDN on its GPU (option oidn.device,
rt/slang/oidn.py), the renderer leaves this pass out."""
from __future__ import annotations

import numpy as np

from core.errors import UserError
from core.passes import Pass
from rt.oidn import OidnOptions, glossy_albedo, oidn_frame


def _read(tex) -> np.ndarray:
    """A GL float texture as (H, W, channels) float32, top row first: OIDN's network is not
    symmetric under a vertical flip (1-ray AO's output moves ~4 % between the two), so it sees
    images upright, as on the GPU (rt/slang/oidn.py: the device's images run top row first)."""
    w, h = tex.size
    return np.frombuffer(tex.read(), np.float32).reshape(h, w, tex.components)[::-1]


class OidnPass(Pass):
    name = "oidn"
    options = OidnOptions
    reads = ("accumulated", "g_albedo", "g_normal", "g_emissive", "g_face", "g_position")
    writes = ("accumulated",)

    def __init__(self, ctx):
        self.ctx = ctx
        self.out = None

    def execute(self, frame) -> None:
        try:
            import pyoidn
        except ImportError as e:  # a declared dependency: only a broken install lacks it
            raise UserError(f"denoise=oidn needs the pyoidn package ({e})") from None
        run = oidn_frame(frame.mode, frame.options, frame.scene)
        with frame.profiler.cpu("oidn"):
            shown = np.maximum(_read(frame.channels["accumulated"])[..., :3], 0.0)
            covered = _read(frame.channels["g_face"])[..., 3:4] > 0  # no surface: no albedo, no normal
            # the first hit's emission is not filtered (light sources stay sharp and as bright):
            # left out of OIDN's input and added back, no more than the pixel's radiance
            # (where the effect's radiance holds them: greyscale AO has no emission, and no albedo
            # in it for OIDN to tell texture from noise by: its guide is then white)
            emission = np.clip(_read(frame.channels["g_emissive"])[..., :3], 0.0, shown) * covered * run.has_emission
            color = np.ascontiguousarray(shown - emission)
            g_normal, g_albedo = _read(frame.channels["g_normal"]), _read(frame.channels["g_albedo"])
            if not run.has_albedo:
                albedo = 1.0
            elif run.ggx:  # the view's cosine (from the positions, read back only here) for the specular albedo
                to_eye = np.asarray(frame.camera.eye, np.float32) - _read(frame.channels["g_position"])[..., :3]
                nv = np.clip(np.einsum("...i,...i", g_normal[..., :3], to_eye)
                             / np.maximum(np.linalg.norm(to_eye, axis=-1), 1e-12), 0.0, 1.0)
                albedo = glossy_albedo(g_albedo[..., :3], g_albedo[..., 3], g_normal[..., 3], nv)
            else:
                albedo = np.clip(g_albedo[..., :3], 0.0, 1.0)
            albedo = np.ascontiguousarray(np.broadcast_to(albedo * covered, shown.shape), np.float32)
            normal = np.ascontiguousarray(g_normal[..., :3] * covered)
            out = pyoidn.denoise(color, albedo, normal, hdr=True, clean_aux=True, quality=run.quality)
            out = np.where(covered, np.maximum(out, 0.0) + emission, shown)  # the sky as it was
            w, h = frame.width, frame.height
            if self.out is None or self.out.size != (w, h):
                if self.out is not None:
                    self.out.release()
                self.out = self.ctx.texture((w, h), 4, dtype="f4")  # RGBA, as the accumulated image
            rgba = np.ones((h, w, 4), np.float32)
            rgba[..., :3] = out
            self.out.write(rgba[::-1].tobytes())  # rows as GL keeps them
        frame.channels["accumulated"] = self.out

    def release(self) -> None:
        if self.out is not None:
            self.out.release()
            self.out = None
