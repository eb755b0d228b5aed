"""Ray-traced passes, one module per effect (shadows, reflections, gi, ao, reference, hybrid's
inputs), behind a backend-neutral interface (backend.py). Backends live in their own folders
(embree/); backends.py makes one. Importing this package does nothing else."""
