"""A scene on a Slang device: its triangles in a bottom-level acceleration structure under a
one-instance top level, and the shading arrays (rt/mesh.py) in structured buffers."""
from __future__ import annotations

import numpy as np

from core.errors import UserError
from rt.layout import AREA_PDF, GPU_LIGHT_ROW
from rt.lights import LightSet
from rt.mesh import MeshArrays

# triangles from which a scene is kept on the device in the indexed layout (common.slang: Mesh): the
# vertices' normals, uvs and tangents read through the index buffer the BLAS has anyway, instead
# of 64 bytes (112 with tangents) of corner rows and 16 of face normal a triangle, about half
# the device memory and uploads of a big scene (report/HISTORY.md); smaller scenes keep the rows,
# one contiguous read a hit
INDEXED_FROM = 1 << 20
# texels from which a scene's textures are kept as half floats (RGBA16F: 8 bytes a texel instead of
# 16; 11 significant bits, finer than the 8-bit sources' steps), where every value fits
HALF_TEXELS_FROM = 1 << 24
HALF_MAX = 60000.0  # below float16's largest finite value (65504)


def half_texels(texels: np.ndarray) -> np.ndarray | None:
    """The texels as float16 (converted in chunks on threads: numpy's casts leave the GIL), or
    None where some value is not finite or is beyond float16's range."""
    import os
    from concurrent.futures import ThreadPoolExecutor

    out = np.empty(texels.shape, np.float16)
    step = 1 << 20

    def convert(lo: int) -> bool:
        part = out[lo:lo + step]
        with np.errstate(over="ignore", invalid="ignore"):  # beyond float16: inf, found below
            np.copyto(part, texels[lo:lo + step], casting="unsafe")
        return bool(np.abs(part).max(initial=0.0) < HALF_MAX)  # False for inf and NaN too

    with ThreadPoolExecutor(min(os.cpu_count() or 1, 16)) as pool:
        fits = all(pool.map(convert, range(0, len(texels), step)))
    return out if fits else None


class DeviceScene:
    def __init__(self, device, scene):
        import slangpy as spy

        self.device, self.arrays = device, MeshArrays(scene)
        a = self.arrays
        self.lights = LightSet(scene, a)
        if len(a.indices) == 0:
            raise UserError(f"{scene.name}: no triangles to trace")
        self.device_bytes = 0  # what the scene holds on the device: its buffers and acceleration structures
        try:
            self._upload(spy, a)
            self._build(spy, a)
            device.wait()  # built (and any device error raised) before the first frame
        except RuntimeError as e:  # slangpy: out of device memory and the like
            raise UserError(f"{scene.name}: could not build the scene on {device.info.adapter_name}: "
                            f"{str(e).splitlines()[0][:160]}") from None

    def _upload(self, spy, a: MeshArrays) -> None:
        dev = self.device
        build = spy.BufferUsage.shader_resource | spy.BufferUsage.acceleration_structure_build_input

        def buffer(data: np.ndarray, usage=spy.BufferUsage.shader_resource):
            self.device_bytes += data.nbytes
            return dev.create_buffer(usage=usage, data=np.ascontiguousarray(data))

        self.vertices = buffer(a.positions.astype(np.float32), build)
        self.indices = buffer(a.indices.astype(np.uint32), build)
        one4, one = np.zeros((1, 4), np.float32), np.zeros(1, np.uint32)  # a buffer a layout does not use
        scene = a.scene
        colors = getattr(scene, "colors", None)
        if len(a.indices) >= INDEXED_FROM:  # the vertices' own arrays read through the indices (Mesh in common.slang)
            self.corners, self.corner_rows, self.face_normals = buffer(one4), 0, buffer(one4)
            self.normals = buffer(a.normals.reshape(-1))
            self.uvs = buffer(a.uvs.reshape(-1))
            tangents = getattr(scene, "tangents", None)
            self.has_tangents = int(tangents is not None)
            self.tangents = buffer(one4 if tangents is None else np.asarray(tangents, np.float32).reshape(-1, 4))
            self.material_ids = buffer(a.material_ids.astype(np.uint32))
            self.material_sided = buffer(a.single_sided.astype(np.uint32))
            rows = np.ones((1, 3), np.float32) if colors is None else np.asarray(colors, np.float32).reshape(-1, 3)
        else:  # per triangle: corner rows and face normals
            self.corners = buffer(a.corners.reshape(-1, 4))  # 4 (7 with tangents) float4 a triangle (common.slang)
            self.corner_rows = a.corners.shape[1] // 4
            # w: 1 where the triangle's material is single-sided (primary.slang culls its back)
            self.face_normals = buffer(np.c_[a.face_normals, a.single_sided[a.material_ids].astype(np.float32)])
            self.normals = self.uvs = self.material_ids = self.material_sided = buffer(one)
            self.tangents, self.has_tangents = buffer(one4), 0
            rows = a.tri_colors.reshape(-1, 3)  # 3 a triangle (or one white row)
        materials = np.zeros((len(a.base_color), 24), np.float32)  # common.slang: Material
        materials[:, 0:3], materials[:, 3] = a.base_color, a.base_alpha
        materials[:, 4:7], materials[:, 7] = a.emissive, a.roughness
        materials[:, 8], materials[:, 9] = a.metallic, a.alpha_cutoff
        materials[:, 10:12] = a.wrap[:, :2] + 3 * a.wrap[:, 2:]  # wrap modes, + 3 where read at the nearest texel
        materials[:, 12:16], materials[:, 16:20], materials[:, 20:24] = a.tex_offset, a.tex_w, a.tex_h
        self.materials = buffer(materials)
        half = half_texels(a.tex_data) if len(a.tex_data) >= HALF_TEXELS_FROM else None
        self.half_texels = int(half is not None)
        if half is not None:  # RGBA16F, two halves a uint (common.slang: texel)
            self.texels, self.texels_half = buffer(one4), buffer(half.view(np.uint32))
        else:
            self.texels, self.texels_half = buffer(a.tex_data), buffer(np.zeros((1, 2), np.uint32))
        self.colors = buffer(np.c_[rows, np.ones(len(rows), np.float32)])  # float4 each, as Slang reads them
        self.has_colors = int(colors is not None)
        self._upload_lights(buffer)

    def _upload_lights(self, buffer) -> None:
        """The lights as shaders/rt/lights.slang reads them (rt/lights.py's arrays)."""
        li = self.lights

        def rows(x: np.ndarray, width: int) -> np.ndarray:  # at least one row: no empty buffers
            x = np.asarray(x, np.float32).reshape(-1, width)
            return x if len(x) else np.zeros((1, width), np.float32)

        start, emitter_rows, keep, alias = li.emitters
        self.light_buffers = {
            "analytic": buffer(rows(li.analytic_rows()[:, :GPU_LIGHT_ROW], 16).reshape(-1, 4)),
            "emitters": buffer(rows(emitter_rows[:, :GPU_LIGHT_ROW], 16).reshape(-1, 4)),
            "cluster_start": buffer(np.asarray(start, np.int32) if len(start) else np.zeros(1, np.int32)),
            "keep": buffer(keep if len(keep) else np.zeros(1, np.float32)),
            "alias": buffer(np.asarray(alias, np.int32) if len(alias) else np.zeros(1, np.int32)),
            "area_pdf": buffer(rows(emitter_rows[:, AREA_PDF], 1).ravel()),
            # per scene triangle (light_pdf, for rays that hit an emitter): none without emitting triangles
            "tri_light": buffer(np.asarray(li.tri_light if li.cluster_count else [-1], np.int32)),
            "tri_row": buffer(np.asarray(li.tri_row if li.cluster_count else [-1], np.int32)),
        }
        kind, pos, d, _, cos_out, spot_scale, _, lum = li.analytic
        spot = kind == 1
        guide = np.zeros((len(kind), 12), np.float32)  # pos, lum; dir, cone cos; cone scale, sun
        guide[:, 0:3], guide[:, 3], guide[:, 4:7] = pos, lum, d
        guide[:, 7] = np.where(spot, cos_out, -2.0)
        guide[:, 8] = np.where(spot, spot_scale, 1.0)
        guide[:, 9] = kind == 2
        clusters = np.zeros((li.cluster_count, 8), np.float32)  # centre, radius; power
        clusters[:, 0:3], clusters[:, 3], clusters[:, 4] = li.cluster_centre, li.cluster_radius, li.cluster_power
        self.light_buffers["guide_lights"] = buffer(rows(guide, 12).reshape(-1, 4))
        self.light_buffers["guide_clusters"] = buffer(rows(clusters, 8).reshape(-1, 4))

    def _build(self, spy, a: MeshArrays) -> None:
        dev = self.device
        triangles = spy.AccelerationStructureBuildInputTriangles({
            "vertex_buffers": [spy.BufferOffsetPair(self.vertices)], "vertex_format": spy.Format.rgb32_float,
            "vertex_count": len(a.positions), "vertex_stride": 12,
            "index_buffer": spy.BufferOffsetPair(self.indices), "index_format": spy.IndexFormat.uint32,
            "index_count": a.indices.size, "flags": spy.AccelerationStructureGeometryFlags.opaque})
        self.blas = self._structure(spy, spy.AccelerationStructureKind.bottom_level, triangles)
        instances = dev.create_acceleration_structure_instance_list(1)
        instances.write(0, {"transform": spy.float3x4.identity(), "instance_id": 0, "instance_mask": 0xFF,
                            "instance_contribution_to_hit_group_index": 0,
                            "flags": spy.AccelerationStructureInstanceFlags.none,
                            "acceleration_structure": self.blas.handle})
        self.tlas = self._structure(spy, spy.AccelerationStructureKind.top_level, instances.build_input_instances())
        self._instances = instances

    def _structure(self, spy, kind, build_input):
        dev = self.device
        desc = spy.AccelerationStructureBuildDesc({"inputs": [build_input],
                                                   "flags": spy.AccelerationStructureBuildFlags.prefer_fast_trace})
        sizes = dev.get_acceleration_structure_sizes(desc)
        self.device_bytes += sizes.acceleration_structure_size
        structure = dev.create_acceleration_structure(kind=kind, size=sizes.acceleration_structure_size)
        scratch = dev.create_buffer(size=max(sizes.scratch_size, 4), usage=spy.BufferUsage.unordered_access)
        encoder = dev.create_command_encoder()
        encoder.build_acceleration_structure(desc=desc, dst=structure, src=None, scratch_buffer=scratch)
        dev.submit_command_buffer(encoder.finish())
        return structure

    def bind_lights(self, cursor) -> None:
        """Point a shader's Lights (lights.slang) at this scene's lights."""
        for name, buf in self.light_buffers.items():
            cursor[name] = buf
        cursor["analytic_count"] = self.lights.count_analytic
        cursor["cluster_count"] = self.lights.cluster_count

    def bind_mesh(self, cursor) -> None:
        """Point a shader's Mesh (common.slang) at this scene's buffers."""
        for name in ("corners", "face_normals", "materials", "texels", "corner_rows", "colors", "has_colors",
                     "vertices", "indices", "normals", "uvs", "tangents", "material_ids", "material_sided",
                     "has_tangents", "texels_half", "half_texels"):
            cursor[name] = getattr(self, name)

    def bind_trace(self, cursor) -> None:
        """What trace.slang's rays need: the scene, its mesh (masked materials' alpha) and
        whether any material is masked."""
        cursor["g_scene"] = self.tlas
        self.bind_mesh(cursor["g_mesh"])
        cursor["g_alpha"] = int(self.arrays.has_alpha)
