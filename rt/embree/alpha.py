"""Alpha-masked surfaces in Embree: a filter function (Embree's any-hit) that rejects a
candidate hit where its material's alpha is below the cutoff (textures.passes_alpha), for
closest-hit and occlusion rays alike. It is installed only on scenes that have masked
materials, so others trace at full speed.

The filter is a numba cfunc that Embree calls with RTCFilterFunctionNArguments (embree4/
rtcore_geometry.h): valid*, geometryUserPtr, context, ray, hit, N. The user pointer is an int64
array of the addresses and sizes of the mesh arrays it reads (AlphaData keeps them alive)."""
from __future__ import annotations

import numpy as np
from numba import carray, cfunc, types
from numba.core import cgutils
from numba.extending import intrinsic

from rt.embree.textures import passes_alpha

# AlphaData.words: addresses, then row counts
CORNERS, TEX_OFFSET, TEX_W, TEX_H, WRAP, TEX_DATA, CUTOFF, BASE_ALPHA = range(8)
TRIANGLES, COLUMNS, MATERIALS, TEXELS = range(8, 12)
WORDS = 12


@intrinsic
def _pointer(typingctx, address):
    """An integer address as a void pointer (for carray)."""
    if not isinstance(address, types.Integer):
        return None

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], cgutils.voidptr_t)

    return types.voidptr(address), codegen


@cfunc(types.void(types.voidptr), cache=True, error_model="numpy")
def alpha_filter(args):
    fields = carray(args, 6, np.int64)  # valid, user pointer, context, ray, hit, N (padded)
    count = fields[5] & 0xFFFFFFFF
    data = carray(_pointer(fields[1]), WORDS, np.int64)
    corners = carray(_pointer(data[CORNERS]), (data[TRIANGLES], data[COLUMNS]), np.float32)
    nm, nt = data[MATERIALS], data[TEXELS]
    tex_offset = carray(_pointer(data[TEX_OFFSET]), (nm, 4), np.int64)
    tex_w = carray(_pointer(data[TEX_W]), (nm, 4), np.int64)
    tex_h = carray(_pointer(data[TEX_H]), (nm, 4), np.int64)
    wrap = carray(_pointer(data[WRAP]), (nm, 3), np.int64)
    tex_data = carray(_pointer(data[TEX_DATA]), (nt, 4), np.float32)
    cutoff = carray(_pointer(data[CUTOFF]), nm, np.float32)
    base_alpha = carray(_pointer(data[BASE_ALPHA]), nm, np.float32)
    valid = carray(_pointer(fields[0]), count, np.int32)
    hit_f = carray(_pointer(fields[4]), 8 * count, np.float32)  # RTCHitN: Ng x/y/z, u, v, primID, ... (N each)
    hit_i = carray(_pointer(fields[4]), 8 * count, np.uint32)
    for k in range(count):
        if valid[k] == 0:
            continue
        u, v, prim = hit_f[3 * count + k], hit_f[4 * count + k], hit_i[5 * count + k]
        if prim < corners.shape[0] and not passes_alpha(corners, tex_offset, tex_w, tex_h, wrap, tex_data, cutoff,
                                                        base_alpha, prim, u, v):
            valid[k] = 0


class AlphaData:
    """What alpha_filter reads, for one scene's mesh arrays (rt/mesh.py MeshArrays); keeps
    them alive as long as the Embree scene that points at them."""

    def __init__(self, mesh):
        self.arrays = [np.ascontiguousarray(a) for a in (mesh.corners, mesh.tex_offset, mesh.tex_w, mesh.tex_h,
                                                          mesh.wrap, mesh.tex_data, mesh.alpha_cutoff,
                                                          mesh.base_alpha)]
        self.words = np.zeros(WORDS, np.int64)
        for k, a in enumerate(self.arrays):
            self.words[k] = a.ctypes.data
        self.words[TRIANGLES], self.words[COLUMNS] = self.arrays[0].shape
        self.words[MATERIALS] = self.arrays[1].shape[0]
        self.words[TEXELS] = self.arrays[5].shape[0]

    @property
    def pointer(self) -> int:
        return int(self.words.ctypes.data)

    @property
    def function(self) -> int:
        return int(alpha_filter.address)
