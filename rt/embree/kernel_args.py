"""What the whole-frame kernels read, as named structures (numba StructRefs, which unlike
tuples of arrays may be read inside a parallel loop's body):

- SceneArgs, built once per scene (shading.SceneData.kernel_scene): the mesh that hits are
  shaded with, the lights (shading.LightSet.kernel_args) and the far distance;
- FrameArgs, one per pass per frame (frame.RtFrame.kernel_frame): the covered pixels' points
  (layout.py rows) and G-buffer, the environment, the tracing target (rtcore.target) and the
  images the kernel writes."""
from __future__ import annotations

from numba import njit, types
from numba.experimental import structref


@structref.register
class SceneArgsType(types.StructRef):
    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(t)) for name, t in fields)


class SceneArgs(structref.StructRefProxy):
    def __new__(cls, mesh, lights, far):
        return _scene_args(mesh, lights, far)


structref.define_proxy(SceneArgs, SceneArgsType, [
    "mesh",  # SceneData.mesh_args: corners, face normals, material constants, texture layers
    "lights",  # (analytic, emitters, guide, count): light_sampling.direct_all's and direct_one's
    "far",  # the length of rays to a sun or the sky
])


@structref.register
class FrameArgsType(types.StructRef):
    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(t)) for name, t in fields)


class FrameArgs(structref.StructRefProxy):
    def __new__(cls, points, pix, view_dir, surface, env, env_dist, target, out, aux, spec):
        """surface: the covered pixels' G-buffer, as Surface.arrays (p, n, ng, albedo,
        roughness, metallic, emissive): the fields of the same names."""
        return _frame_args(points, pix, view_dir, surface, env, env_dist, target, out, aux, spec)


structref.define_proxy(FrameArgs, FrameArgsType, [
    "points",  # (9, M) the covered pixels' points as rows (layout.py)
    "pix",  # (M,) their pixel ids
    "view_dir",  # (N, 3) unit directions from the eye, every pixel
    "p", "n", "ng", "albedo", "roughness", "metallic", "emissive",  # (M, ...) the G-buffer's surfaces
    "env",  # the environment (gather.env_args)
    "env_dist",  # a map's sampling distribution: (cdf, cells u, cells v), cells 0 for the others (env_light.py)
    "target",  # the tracing target (rtcore.target)
    "out",  # (N, 3) radiance, every pixel
    "aux",  # (N, C) the pass's other image, or (0, C): not asked for
    "spec",  # (N, 3) the first hit's specular radiance (rt_specular, glTF's BRDF), or (0, 3): not asked for
])


# The constructors, compiled once and cached on disk: StructRefProxy.__new__'s own is compiled
# again in every process (~1 s each here for these nested types, in every first frame)
@njit(cache=True)
def _scene_args(mesh, lights, far):
    return SceneArgs(mesh, lights, far)


@njit(cache=True)
def _frame_args(points, pix, view_dir, surface, env, env_dist, target, out, aux, spec):
    p, n, ng, albedo, roughness, metallic, emissive = surface
    return FrameArgs(points, pix, view_dir, p, n, ng, albedo, roughness, metallic, emissive, env, env_dist, target,
                     out, aux, spec)
