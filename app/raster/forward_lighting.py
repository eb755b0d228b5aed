"""Forward lighting pass: re-rasterises the scene against the G-buffer's depth (a depth
pre-pass), lights every fragment with all lights, shadow maps, SSAO and env reflections."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.gl_context import fullscreen, set_uniform
from app.raster.gpu_scene import ENV_KIND
from app.raster.lights import pack
from app.raster.targets import Targets
from core.options import opt, register_group
from core.passes import Pass

RT_INPUTS = ("rt_direct", "rt_ao", "rt_reflection", "rt_indirect")  # hybrid's ray-traced images


@dataclass
class ForwardOptions:
    shadow_maps: bool = opt(True, "shadow maps for the sun and the strongest point/spot lights")
    shadow_map_size: int = opt(2048, "sun shadow map resolution (texels)", 256, 8192)
    pcf_radius: int = opt(2, "PCF kernel half-width in texels (0 = hard shadows)", 0, 8)
    point_shadow_budget: int = opt(4, "how many point/spot lights get cube shadow maps", 0, 32)
    point_shadow_size: int = opt(512, "cube shadow map face resolution (texels)", 64, 4096)
    ssao: bool = opt(True, "screen-space ambient occlusion on the ambient term")
    ssao_radius: float = opt(0.5, "SSAO hemisphere radius (m)", 0.01, 100.0)
    ssao_samples: int = opt(16, "SSAO kernel samples per pixel", 1, 64)
    ssao_blur: bool = opt(True, "4x4 blur of the SSAO result")
    env_reflections: bool = opt(True, "environment cube map reflections on smooth surfaces")
    roughness_threshold: float = opt(0.25, "env reflections on surfaces smoother than this", 0.0, 1.0)
    ambient: float = opt(1.0, "scale of the ambient term (environment + the scene's ambient hint)", 0.0, 100.0)
    emissive_lights: bool = opt(True, "light from emissive surfaces through proxy point lights")
    fxaa: bool = opt(True, "FXAA after tone mapping")



register_group("forward", ForwardOptions)


class ForwardLightingPass(Pass):
    name = "forward"
    options = ForwardOptions
    reads = ("depth", "ssao", "sun_shadow", "point_shadow", "lights", "shadow_info") + RT_INPUTS
    writes = ("radiance",)

    def __init__(self, ctx):
        self.ctx = ctx
        self.targets = Targets(ctx, {"radiance": (4, "f4")})
        self.ubo = ctx.buffer(reserve=128 * 64)
        self.dummy_ao = ctx.texture((1, 1), 1, np.ones(1, "f4").tobytes(), dtype="f4")
        self.dummy_layers = ctx.texture_array((1, 1, 1), 3, np.zeros(3, "f4").tobytes(), dtype="f4")

    def execute(self, frame) -> None:
        rt_inputs = {name: frame.channels[name] for name in RT_INPUTS if name in frame.channels}
        lights, shadow_info = frame.channels["lights"], frame.channels["shadow_info"]
        opts = frame.options.group("forward")
        use_ssao = opts.ssao and "rt_ao" not in rt_inputs and "rt_indirect" not in rt_inputs
        ctx = self.ctx
        t = self.targets.ensure(frame.width, frame.height, shared_depth=frame.channels["depth"])
        prog, vao = frame.gpu.vao("geometry.vert", "forward.frag")
        env = frame.environment
        cube, lut = frame.gpu.environment_maps(env)
        with frame.profiler.gpu(ctx, "forward_lighting"):
            t.fbo.depth_mask = False  # the pre-pass depth stays; equal depths pass "<="
            t.fbo.use()
            t.fbo.viewport = (0, 0, frame.width, frame.height)
            t.fbo.clear(0.0, 0.0, 0.0, 0.0)
            self._background(frame, env)
            ctx.enable(ctx.DEPTH_TEST)
            ctx.depth_func = "<="
            unit = frame.gpu.bind_materials(prog)
            self.ubo.write(pack(lights))
            if "Lights" in prog:
                prog["Lights"].binding = 0
            self.ubo.bind_to_uniform_block(0)
            set_uniform(prog, "light_count", len(lights))
            set_uniform(prog, "view_proj", frame.view_proj().T.astype(np.float32))
            set_uniform(prog, "prev_view_proj", frame.view_proj(frame.prev_camera).T.astype(np.float32))
            set_uniform(prog, "eye", tuple(map(float, frame.camera.eye)))
            set_uniform(prog, "viewport", (float(frame.width), float(frame.height)))
            set_uniform(prog, "env_kind", ENV_KIND[env.kind])
            set_uniform(prog, "env_color", tuple(map(float, env.color)))
            set_uniform(prog, "env_strength", float(env.strength))
            set_uniform(prog, "ambient_radiance", tuple(map(float, frame.scene.ambient)))
            set_uniform(prog, "ambient_scale", float(opts.ambient))
            _, irradiance = frame.gpu.environment_map(env)
            set_uniform(prog, "use_irradiance_cube", int(irradiance is not None))
            ggx = frame.scene.uses_ggx(frame.options.get("brdf"))
            specular, brdf_lut = frame.gpu.specular_light(env) if ggx else (None, None)
            set_uniform(prog, "use_split_sum", int(specular is not None and "rt_indirect" not in rt_inputs))
            textures = {"ambient_lut": lut, "env_cube": cube, "irradiance_cube": irradiance or cube,
                        "specular_maps": specular or self.dummy_layers, "brdf_lut": brdf_lut or self.dummy_ao,
                        "ssao": frame.channels.get("ssao", self.dummy_ao) if use_ssao else self.dummy_ao,
                        "sun_shadow": frame.channels["sun_shadow"], "point_shadow": frame.channels["point_shadow"]}
            for name, tex in textures.items():
                tex.use(unit)
                set_uniform(prog, name, unit)
                unit += 1
            for name in ("rt_direct", "rt_ao", "rt_reflection", "rt_indirect"):
                tex = rt_inputs.get(name, self.dummy_ao)
                tex.use(unit)
                set_uniform(prog, name, unit)
                set_uniform(prog, "use_" + name, int(name in rt_inputs))
                unit += 1
            set_uniform(prog, "use_ssao", int(use_ssao))
            set_uniform(prog, "use_env_reflections", int(opts.env_reflections))
            set_uniform(prog, "roughness_threshold", float(opts.roughness_threshold))
            set_uniform(prog, "use_shadows", int(opts.shadow_maps))
            set_uniform(prog, "use_ggx", int(ggx))
            set_uniform(prog, "sun_view_proj", shadow_info["sun_view_proj"].T.astype(np.float32))
            set_uniform(prog, "sun_slot", int(shadow_info["sun_slot"]))
            set_uniform(prog, "sun_texel", float(shadow_info["sun_texel"]))
            set_uniform(prog, "point_shadow_rows", int(shadow_info["rows"]))
            set_uniform(prog, "pcf_radius", int(opts.pcf_radius))
            vao.render()
            ctx.depth_func = "<"
            ctx.disable(ctx.DEPTH_TEST)
        frame.channels["radiance"] = t["radiance"]

    def _background(self, frame, env) -> None:
        prog, vao = fullscreen(self.ctx, "background.frag")
        set_uniform(prog, "inv_view_proj", np.linalg.inv(frame.view_proj()).T.astype(np.float32))
        set_uniform(prog, "eye", tuple(map(float, frame.camera.eye)))
        set_uniform(prog, "env_kind", ENV_KIND[env.kind])
        set_uniform(prog, "env_color", tuple(map(float, env.color)))
        set_uniform(prog, "env_strength", float(env.strength))
        texels, _ = frame.gpu.environment_map(env)
        if texels is not None:
            texels.use(0)
            set_uniform(prog, "env_map", 0)
            set_uniform(prog, "env_shift", env.rotation_u)
        vao.render(vertices=3)

    def release(self) -> None:
        self.targets.release()
        self.ubo.release()
        self.dummy_ao.release()
        self.dummy_layers.release()
