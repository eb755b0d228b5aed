"""numba's njit for this backend's kernels, with one change: a kernel called from another kernel
compiles for its arguments' plain types, never for the constants a caller happens to pass.

numba compiles a callee once per distinct argument types, and a constant argument (a literal
0, 4 or True) is a type of its own: `direct_one(..., 0, ...)` and `direct_one(..., dim0, ...)`
would be two compilations of the same code (one_light_shadow_rays was compiled four times, 13 s
each on a 2-core machine). Here every caller shares one compilation per plain signature;
branches on such an argument are taken at run time (one comparison), so code that an option
leaves out is still compiled: such options choose another kernel instead (rt/embree/shadows.py)."""
from __future__ import annotations

import numba
from numba.core import types


def _plain_calls(dispatcher):
    compile_for = type(dispatcher).get_call_template

    def get_call_template(args, kws):
        return compile_for(dispatcher, tuple(types.unliteral(a) for a in args),
                           {k: types.unliteral(v) for k, v in kws.items()})

    dispatcher.get_call_template = get_call_template
    return dispatcher


def njit(*args, **options):
    """numba.njit (same arguments), compiling calls from other kernels for plain types."""
    if len(args) == 1 and callable(args[0]) and not options:
        return _plain_calls(numba.njit(args[0]))
    decorate = numba.njit(*args, **options)
    return lambda fn: _plain_calls(decorate(fn))
