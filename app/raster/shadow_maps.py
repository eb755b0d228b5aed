"""Shadow maps: a view-fitted orthographic map for the sun and a cube-face atlas for the
strongest local lights (6 faces per row, one row per light). Filtered with PCF in forward.frag."""
from __future__ import annotations

import numpy as np

from app.camera import Camera
from app.gl_context import set_uniform
from app.raster.lights import RasterLight, assign_shadow_slots, gather_lights
from core.passes import Pass

FACE_F = np.array([(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)], float)
FACE_U = np.array([(0, -1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1), (0, -1, 0), (0, -1, 0)], float)


def sun_matrix(light_dir: np.ndarray, camera: Camera, aspect: float, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Orthographic light view-projection fitted to the part of the scene the camera sees."""
    d = light_dir / np.linalg.norm(light_dir)
    up = np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.99 else np.array([1.0, 0.0, 0.0])
    r = np.cross(d, up)
    r /= np.linalg.norm(r)
    u = np.cross(r, d)
    rot = np.stack([r, u, -d])  # light view rows; light looks along d
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    scene_ls = corners @ rot.T
    # camera frustum up to a distance that covers what is visible at useful resolution
    far = min(camera.far, float(np.linalg.norm(hi - lo)))
    cr, cu, cf = camera.basis()
    th = np.tan(np.radians(camera.fov) / 2)
    pts = [camera.eye]
    for dist in (far,):
        for sx in (-1, 1):
            for sy in (-1, 1):
                pts.append(camera.eye + dist * (cf + sx * th * aspect * cr + sy * th * cu))
    frustum_ls = np.array(pts) @ rot.T
    mn = np.maximum(frustum_ls.min(0), scene_ls.min(0))
    mx = np.minimum(frustum_ls.max(0), scene_ls.max(0))
    mn[2], mx[2] = scene_ls[:, 2].min(), scene_ls[:, 2].max()  # every caster along the light
    pad = 1e-3 * (mx - mn).max()
    mn -= pad
    mx += pad
    view = np.eye(4)
    view[:3, :3] = rot
    proj = np.eye(4)
    proj[0, 0], proj[0, 3] = 2 / (mx[0] - mn[0]), -(mx[0] + mn[0]) / (mx[0] - mn[0])
    proj[1, 1], proj[1, 3] = 2 / (mx[1] - mn[1]), -(mx[1] + mn[1]) / (mx[1] - mn[1])
    # light-view z is negative in front: depth = -z mapped from [-mx, -mn]
    proj[2, 2], proj[2, 3] = -2 / (mx[2] - mn[2]), (mx[2] + mn[2]) / (mx[2] - mn[2])
    return proj @ view, float(max(mx[0] - mn[0], mx[1] - mn[1]))


class ShadowMapPass(Pass):
    """Shadow maps of the sun and the strongest point/spot lights for the forward pass (minimal
    ones when ray-traced shadows, rt_direct, replace them), and the lights it shades with."""

    name = "shadow_maps"
    reads = ("rt_direct",)  # optional
    writes = ("sun_shadow", "point_shadow", "lights", "shadow_info")

    def __init__(self, ctx):
        self.ctx = ctx
        self.sun_tex = self.sun_fbo = None
        self.point_tex = self.point_fbo = None

    def _depth_target(self, attr: str, size: tuple):
        tex = getattr(self, attr + "_tex")
        if tex is None or tex.size != size:
            if tex is not None:
                tex.release()
                getattr(self, attr + "_fbo").release()
            tex = self.ctx.depth_texture(size)
            tex.compare_func = "<="
            tex.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
            tex.repeat_x = tex.repeat_y = False
            setattr(self, attr + "_tex", tex)
            setattr(self, attr + "_fbo", self.ctx.framebuffer(depth_attachment=tex))
        return tex, getattr(self, attr + "_fbo")

    def execute(self, frame) -> None:
        opts = frame.options.group("forward")
        lights = gather_lights(frame.scene, frame.gpu, opts.emissive_lights)
        enabled = bool(opts.shadow_maps) and "rt_direct" not in frame.channels  # RT shadows replace the maps
        slots = assign_shadow_slots(lights, frame.camera.eye, opts.point_shadow_budget if enabled else 0,
                                    frame.scene.diagonal)
        frame.channels["lights"] = lights
        frame.channels["shadow_info"] = self._render(frame, lights, slots, enabled)

    def _render(self, frame, lights: list[RasterLight], slots: int, enabled: bool) -> dict:
        """Render the maps; returns what forward.frag needs to look them up."""
        opts = frame.options.group("forward")
        ctx = self.ctx
        info = {"sun_slot": -1, "sun_view_proj": np.eye(4), "sun_texel": 1.0, "rows": max(slots, 1)}
        if not enabled:  # forward.frag still samples the maps: keep minimal ones bound
            self._depth_target("sun", (1, 1))
            self._depth_target("point", (6, 1))
            frame.channels["sun_shadow"] = self.sun_tex
            frame.channels["point_shadow"] = self.point_tex
            return info
        if frame.gpu.alpha_tested:  # masked materials cast shadows only where they are not cut away
            prog, vao = frame.gpu.vao("depth_alpha.vert", "depth_alpha.frag")
            frame.gpu.bind_materials(prog)
        else:  # the plain depth shader: no texture state, so no new shader variants per scene
            prog, vao = frame.gpu.vao("depth_only.vert", "depth_only.frag", with_attributes=False)
        suns = [k for k, li in enumerate(lights) if li.kind == "directional"]
        with frame.profiler.gpu(ctx, "shadow_maps"):
            ctx.enable(ctx.DEPTH_TEST)
            ctx.disable(ctx.CULL_FACE)
            size = opts.shadow_map_size
            _, fbo = self._depth_target("sun", (size, size))
            fbo.use()
            fbo.clear(depth=1.0)
            if suns:
                k = max(suns, key=lambda i: float(np.max(lights[i].radiance)))  # the strongest sun gets the map
                lo, hi = frame.scene.bounds()
                m, extent = sun_matrix(lights[k].direction, frame.camera, frame.aspect, lo, hi)
                fbo.viewport = (0, 0, size, size)
                set_uniform(prog, "light_view_proj", m.T.astype(np.float32))
                vao.render()
                info.update(sun_slot=k, sun_view_proj=m, sun_texel=extent / size)
            face = opts.point_shadow_size
            _, pfbo = self._depth_target("point", (face * 6, face * max(slots, 1)))
            pfbo.use()
            pfbo.clear(depth=1.0)
            for li in lights:
                if li.slot < 0:
                    continue
                for f in range(6):
                    cam = Camera(li.position, li.position + FACE_F[f], FACE_U[f], 90.0, li.near, li.far)
                    m = cam.projection_matrix(1.0) @ cam.view_matrix()
                    pfbo.viewport = (f * face, li.slot * face, face, face)
                    set_uniform(prog, "light_view_proj", m.T.astype(np.float32))
                    vao.render()
            ctx.disable(ctx.DEPTH_TEST)
        frame.channels["sun_shadow"] = self.sun_tex
        frame.channels["point_shadow"] = self.point_tex
        return info

    def release(self) -> None:
        for obj in (self.sun_tex, self.sun_fbo, self.point_tex, self.point_fbo):
            if obj is not None:
                obj.release()
