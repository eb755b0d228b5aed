"""The Slang backend: the ray-traced effects as Slang ray-tracing pipelines (raygen, miss,
closest-hit shaders in shaders/rt/) through slangpy, on a Vulkan or CUDA/OptiX device (Mesa's
lavapipe on a machine without a GPU). `backend.py` puts it behind rt.backend.Backend."""
