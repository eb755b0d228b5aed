"""rt/embree/jit.py: a kernel called from other kernels compiles once per plain signature, as code
for them to link (rt/embree/inner_code.py), and every kernel gives the same results as Python and
stays callable from Python; the kernel cache keeps both kinds across processes."""
import json
import os
import subprocess
import sys
import textwrap

import numba
import numpy as np

from rt.embree import inner_code
from rt.embree.jit import inner_of, njit


def _tree():
    @njit(error_model="numpy")
    def leaf(x, k):
        return x * k + 1.0

    @njit(error_model="numpy", fastmath=True)
    def middle(a, k):
        s = 0.0
        for v in a:
            s += leaf(v, k)
        return s

    @njit(error_model="numpy")
    def top(a, flag):
        return middle(a, 2) + middle(a, 3) + leaf(a[0], 0) + (1.0 if flag else 0.0)

    return leaf, middle, top


def test_results_as_in_python_and_every_kernel_callable_from_python():
    leaf, middle, top = _tree()
    a = np.arange(5.0)
    expect = sum(v * 2 + 1 for v in a) + sum(v * 3 + 1 for v in a) + 1.0 + 1.0
    assert top(a, True) == expect
    assert middle(a, 2) == sum(v * 2 + 1 for v in a)  # its own compile, with Python's wrapper
    assert leaf(4.0, 3) == 13.0
    assert top(a, False) == expect - 1.0


def test_a_callee_compiles_once_for_its_arguments_plain_types():
    leaf, middle, top = _tree()
    top(np.ones(3), True)  # leaf called with literals 2, 3 (through middle) and 0
    assert [tuple(map(str, s)) for s in inner_of(leaf).overloads] == [("float64", "int64")]
    assert len(inner_of(middle).overloads) == 1
    assert not leaf.overloads and not middle.overloads  # Python has not called them
    assert inner_of(top) is None


def test_callees_are_linked_code_only():
    if numba.version_info[:2] == (0, 68):
        assert inner_code.SUPPORTED  # the numba version this was written against
    if not inner_code.SUPPORTED:
        return
    leaf, middle, top = _tree()
    top(np.ones(3), True)
    for callee in (leaf, middle):
        (cres,) = inner_of(callee).overloads.values()
        assert isinstance(cres.library, inner_code.InnerLibrary)
        # no machine code of its own: the JIT engine never saw it (its callers inlined it)
        assert not cres.library.codegen._engine.is_symbol_defined(cres.fndesc.llvm_func_name)
    (cres,) = top.overloads.values()
    assert not isinstance(cres.library, inner_code.InnerLibrary)


KERNELS = textwrap.dedent('''
    import numpy as np
    from rt.embree.jit import njit

    @njit(cache=True, error_model="numpy")
    def leaf(x, k):
        return x * k + 1.0

    @njit(cache=True, error_model="numpy")
    def top(a):
        s = 0.0
        for v in a:
            s += leaf(v, 2)
        return s
''')

RUN = textwrap.dedent('''
    import json, sys
    import numpy as np
    from numba.core import event
    compiled = []

    class Listen(event.Listener):
        def on_start(self, ev):
            compiled.append(ev.data["dispatcher"].py_func.__qualname__)

        def on_end(self, ev):
            pass

    event.register("numba:compile", Listen())
    import probe_kernels
    print(json.dumps({"value": probe_kernels.top(np.arange(4.0)), "compiled": compiled}))
''')


def _probe(tmp_path):
    """A runner of scripts in a fresh process that imports KERNELS as probe_kernels, with a kernel
    cache of its own in tmp_path: run(script) -> the script's last line of output, as JSON."""
    (tmp_path / "probe_kernels.py").write_text(KERNELS)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"),
               PYTHONPATH=os.pathsep.join([str(tmp_path), os.getcwd(), os.environ.get("PYTHONPATH", "")]))

    def run(script):
        r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=300)
        assert r.returncode == 0, r.stderr
        return json.loads(r.stdout.strip().splitlines()[-1])

    return run


def _forget_top(tmp_path):
    """The caller's cache entries gone: the next process compiles top again, leaf from the cache."""
    for f in (tmp_path / "cache").rglob("*top*"):
        f.unlink()


def test_the_kernel_cache_keeps_callers_and_their_linked_callees(tmp_path):
    """A second process loads the kernel; one whose caller's entry is gone compiles the caller
    alone, linking the callee's code from the cache (bitcode), with the same result."""
    run = _probe(tmp_path)
    first = run(RUN)
    assert first["value"] == 16.0 and {"top", "leaf__inner"} <= set(first["compiled"])
    assert run(RUN) == {"value": 16.0, "compiled": []}
    _forget_top(tmp_path)
    third = run(RUN)
    assert third["value"] == 16.0 and third["compiled"] == ["top"]


LOADED = textwrap.dedent('''
    import json
    import numpy as np
    from rt.embree import inner_code
    from rt.embree.jit import inner_of
    import probe_kernels
    value = probe_kernels.top(np.arange(4.0))
    (cres,) = inner_of(probe_kernels.leaf).overloads.values()
    (top,) = probe_kernels.top.overloads.values()
    leaf_name, top_name = cres.fndesc.llvm_func_name, top.fndesc.llvm_func_name
    alone = 0  # modules of the JIT engine that hold leaf's code but not top's
    for module in cres.library.codegen._engine._ee._modules:
        defined = {f.name for f in module.functions if not f.is_declaration}
        alone += leaf_name in defined and top_name not in defined
    print(json.dumps({"value": value, "inner": isinstance(cres.library, inner_code.InnerLibrary), "alone": alone}))
''')


def test_a_callee_loaded_from_the_cache_stays_code_to_link(tmp_path):
    """A caller compiled in a process that loads its callee from the cache links the callee's
    code and runs its own optimised copy: the callee's library is not made into machine code of
    its own (numba's cache loading would, and the caller's call, to a weak symbol, then bound to
    that copy, optimised function by function only: AO's ray generation ran 20x slower)."""
    if not inner_code.SUPPORTED:
        return
    run = _probe(tmp_path)
    run(LOADED)
    _forget_top(tmp_path)
    assert run(LOADED) == {"value": 16.0, "inner": True, "alone": 0}


def test_a_parallel_kernel_writes_into_arrays_of_a_record():
    """The parallel kernels take records (tuples of arrays: kernels.shade_hits, unpack_gbuffer)
    and hand them whole to a serial function per item: in numba 0.68 arrays unpacked from such a
    tuple before a prange loop lose the loop's writes; the callee's writes arrive."""
    from numba import prange

    @numba.njit
    def one(k, out, src):
        a, b = out
        (s,) = src
        a[k] = s[k] * 2
        _, b[k, 1] = s[k], s[k] + 1

    @numba.njit(parallel=True)
    def fill(out, src):
        for k in prange(out[0].shape[0]):
            one(k, out, src)

    s = np.arange(5000, dtype=np.float32)
    a, b = np.full(5000, np.nan, np.float32), np.full((5000, 3), np.nan, np.float32)
    fill((a, b), (s,))
    assert np.array_equal(a, s * 2) and np.array_equal(b[:, 1], s + 1)
