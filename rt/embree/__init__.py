"""The Embree backend: ray tracing on the CPU through Embree 4, with numba kernels.

One module per effect (ao.py, shadows.py, gi.py, reflections.py, reference.py), each with its
whole-frame kernel; shared ray generation (raygen.py), hit shading (shading.py, kernels.py),
writing pixels (gather.py), the Embree C API (rtcore.py) and the tracer (tracer.py).
`backend.py` puts them behind rt.backend.Backend. Call process.init() before importing them."""
