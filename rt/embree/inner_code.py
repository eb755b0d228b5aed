"""Code that only other kernels call, compiled to be linked into them and nothing more.

numba makes every compiled function ready to run on its own: its module is optimised whole and
turned into machine code, although a kernel called only from other kernels never runs on its own
(its callers link its code and optimise and generate their own). In a tree of kernels every level
paid again for the levels below it (report/HISTORY.md, issue 44). InnerCompiler
compiles a function into an InnerLibrary: optimised function by function (numba's own first step)
and linked with its callees, so that a caller gets the same code to inline, and the top-level
kernel, which Python calls, is optimised and made into machine code once, as before. Loading
from numba's cache goes through the same class: JITCodeLibrary._unserialize is wrapped so that an
InnerLibrary comes back as one, kept out of the JIT engine.

This leans on numba's code-library internals (CPUCodeLibrary's linking and finalising; written
against numba 0.68). SUPPORTED is False where they are not as expected; jit.py then compiles callees the
ordinary way (correct, only slower to compile)."""
from __future__ import annotations

CACHE_KIND = "rtlab-inner-bitcode"  # how an InnerLibrary is stored in numba's cache

try:
    import llvmlite.binding as ll
    from numba.core import compiler, compiler_machinery, typed_passes
    from numba.core.codegen import JITCodeLibrary
    from numba.core.compiler_lock import require_global_compiler_lock

    SUPPORTED = all(hasattr(JITCodeLibrary, name) for name in (
        "finalize", "_get_module_for_linking", "_raise_if_finalized", "serialize_using_bitcode",
        "serialize_using_object_code", "get_pointer_to_function", "_unserialize",
        "_finalize_dynamic_globals")) and hasattr(
        typed_passes, "NopythonTypeInference") and hasattr(compiler.DefaultPassBuilder, "define_nopython_pipeline")
except ImportError:  # pragma: no cover - another numba
    SUPPORTED = False


if SUPPORTED:
    class _NoEnvironment:
        """An InnerLibrary's codegen as numba's lowering sees it, less the step that writes the
        function's environment pointer into the JIT engine: the function is never in the engine
        (callers carry its code), and code without Python's wrappers does not read it."""

        def __init__(self, codegen):
            self._codegen = codegen

        def set_env(self, env_name, env):
            pass

        def __getattr__(self, name):
            return getattr(self._codegen, name)

    class InnerLibrary(JITCodeLibrary):
        """A function's code for callers to link: its functions optimised one by one, its callees
        linked in; no whole-module optimisation, no machine code (get_pointer_to_function: 0).
        Cached as LLVM bitcode (numba's cache wants machine code, which there is none of)."""

        @property
        def codegen(self):
            return _NoEnvironment(self._codegen)

        def finalize(self):
            require_global_compiler_lock()
            self._raise_if_finalized()
            seen = set()
            for library in self._linking_libraries:
                if library not in seen:
                    seen.add(library)
                    self._reload_init.update(library._reload_init)
                    self._final_module.link_in(library._get_module_for_linking(), preserve=True)
            self._finalized = True

        def get_pointer_to_function(self, name):
            self._ensure_finalized()
            return 0

        def serialize_using_bitcode(self):
            self._ensure_finalized()
            return self.name, CACHE_KIND, self._final_module.as_bitcode()

        def serialize_using_object_code(self):
            return self.serialize_using_bitcode()

    def _unserialize(cls, codegen, state):
        """numba's cache loading, for an InnerLibrary too: numba would load its bitcode as an
        ordinary library, made into machine code as it is (optimised function by function, its
        callees not inlined) and added to the JIT engine; callers' calls to its functions (weak
        symbols) then bind to that slow copy instead of their own optimised one (AO's ray
        generation ran 20x slower from a warm cache than freshly compiled: report/HISTORY.md)."""
        name, kind, data = state
        if kind != CACHE_KIND:
            return _plain_unserialize(cls, codegen, state)
        library = InnerLibrary(codegen, name)
        library._final_module = ll.parse_bitcode(data)
        library._finalize_dynamic_globals()
        library._finalized = True
        return library

    _plain_unserialize = JITCodeLibrary._unserialize.__func__
    JITCodeLibrary._unserialize = classmethod(_unserialize)

    @compiler_machinery.register_pass(mutates_CFG=False, analysis_only=True)
    class _UseInnerLibrary(compiler_machinery.AnalysisPass):
        """Before lowering: the function's code goes into an InnerLibrary."""
        _name = "rtlab_inner_library"

        def __init__(self):
            compiler_machinery.AnalysisPass.__init__(self)

        def run_pass(self, state):
            if state.library is None:
                state.library = InnerLibrary(state.targetctx.codegen(), state.func_id.func_qualname)
            return False

    class InnerCompiler(compiler.CompilerBase):
        """numba's nopython pipeline, lowering into an InnerLibrary (njit's pipeline_class)."""

        def define_pipelines(self):
            pm = compiler.DefaultPassBuilder.define_nopython_pipeline(self.state)
            pm.add_pass_after(_UseInnerLibrary, typed_passes.NopythonTypeInference)
            pm.finalize()
            return [pm]
else:  # pragma: no cover
    InnerLibrary = InnerCompiler = None
