"""CPU ray tracing on Embree: tracer, sampling, hit shading and one module per pass."""
