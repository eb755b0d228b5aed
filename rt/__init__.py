"""CPU ray tracing on Embree: tracer, sampling, hit shading and one module per pass.

numba's OpenMP threads would otherwise spin for a while after every parallel kernel, taking
cores from the tracing threads that run next (measured: ~1.5x slower passes on 2 cores).
This must be set before the first parallel kernel loads the OpenMP runtime."""
import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
