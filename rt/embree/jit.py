"""numba's njit for this backend's kernels, with two changes to how a kernel called from another
kernel compiles (calls from Python compile as numba's always do):

- For its arguments' plain types, never for the constants a caller happens to pass. numba
  compiles a callee once per distinct argument types, and a constant argument (a literal 0, 4 or
  True) is a type of its own: `direct_one(..., 0, ...)` and `direct_one(..., dim0, ...)` would be
  two compilations of the same code (one_light_shadow_rays was compiled four times, 13 s each on
  a 2-core machine). Here every caller shares one compilation per plain signature; branches on
  such an argument are taken at run time (one comparison), so code that an option leaves out is
  still compiled: such options choose another kernel instead (rt/embree/shadows.py).
- As code for callers to link and nothing more: a twin dispatcher of the same function (its own
  entries in the kernel cache, `<name>__inner`) compiles it without the wrappers that let Python
  call it (numba's no_cpython_wrapper, no_cfunc_wrapper: they unbox every array and record
  argument) and without optimising it as a whole module or making machine code of its own
  (inner_code.py), which its callers do with its code inlined: a cold pass compiles in about 60 %
  of the time (report/HISTORY.md, issue 44)."""
from __future__ import annotations

import types as pytypes

import numba
from numba.core import types

from rt.embree import inner_code


def _plain(args, kws):
    return tuple(types.unliteral(a) for a in args), {k: types.unliteral(v) for k, v in kws.items()}


def _inner_twin(fn, options: dict):
    """A dispatcher of fn's code named `<qualname>__inner`, compiled for callers to link."""
    twin = pytypes.FunctionType(fn.__code__, fn.__globals__, fn.__name__, fn.__defaults__, fn.__closure__)
    twin.__qualname__ = f"{fn.__qualname__}__inner"  # its own cache entries
    twin.__module__, twin.__doc__ = fn.__module__, fn.__doc__
    if inner_code.SUPPORTED:
        options = dict(options, pipeline_class=inner_code.InnerCompiler)
    inner = numba.njit(**dict(options, no_cpython_wrapper=True, no_cfunc_wrapper=True))(twin)
    compile_for = type(inner).get_call_template
    inner.get_call_template = lambda args, kws: compile_for(inner, *_plain(args, kws))
    return inner


def _kernel(fn, options: dict):
    # Python calls through its own wrapper; the C one serves numba's first-class functions only
    dispatcher = numba.njit(**dict(options, no_cfunc_wrapper=True))(fn)
    own_overload = type(dispatcher).get_overload
    twin = []

    def get_call_template(args, kws):  # typing a call from another kernel: the twin compiles it
        if not twin:
            twin.append(_inner_twin(fn, options))
        return twin[0].get_call_template(args, kws)

    def get_overload(sig):  # what that caller's lowering links: the twin's code
        if twin and tuple(sig) in twin[0].overloads:
            return twin[0].get_overload(sig)
        return own_overload(dispatcher, sig)

    dispatcher.get_call_template = get_call_template
    dispatcher.get_overload = get_overload
    dispatcher.inner = lambda: twin[0] if twin else None
    return dispatcher


def inner_of(kernel):
    """The twin that compiles `kernel` for calls from other kernels (None until one is typed)."""
    return kernel.inner()


def njit(*args, **options):
    """numba.njit (same arguments; options by keyword), with calls from other kernels compiled
    for plain types, as code to be linked (the module's docstring)."""
    if len(args) == 1 and callable(args[0]) and not options:
        return _kernel(args[0], {})
    if args:
        raise TypeError("njit: options go by keyword")
    return lambda fn: _kernel(fn, options)
