"""Pipelines of shaders/rt/: a ray-tracing pipeline of one shader file, or one compute kernel,
dispatched over the image. Each keeps its root shader object from frame to frame: what a
dispatch binds that stays the same between frames (the scene, the G-buffer, the output buffers)
is written into it only when it changes (dispatch's `static` and `key`): each write is a call
into slangpy, and most of a frame's fields are those."""
from __future__ import annotations

import functools

from rt.slang.flights import SLOTS


class _Root:
    """A program's root shader object, kept between dispatches, its cursor, and the key of what
    its static fields were last written for."""

    def __init__(self, device, program):
        import slangpy as spy

        self.object = device.create_root_shader_object(program)
        self.cursor = spy.ShaderCursor(self.object)
        self.key = None

    def bind(self, bind, static, key) -> None:
        if static is not None and self.key != key:
            static(self.cursor)
            self.key = key
        bind(self.cursor)


# (device, shader file, entry points) -> what linking and creating a pipeline made: a process
# makes each pipeline once, however many backends (renderers) it opens on the device; lavapipe
# takes up to a minute a pipeline, and Mesa's disk cache does not always spare it
_COMPILED: dict[tuple, tuple] = {}


def _ray_tracing(device, file: str, raygen: str, misses: tuple[str, ...], closest_hit: str | None) -> tuple:
    import slangpy as spy

    key = (id(device), file, raygen, misses, closest_hit)
    if key in _COMPILED:
        return _COMPILED[key][1:]
    entry_points = [raygen, *misses] + ([closest_hit] if closest_hit else [])
    # entry points live in the effect's file or in trace.slang (the misses and the closest hit)
    modules = [device.load_module(file)] + ([device.load_module("trace.slang")] if file != "trace.slang" else [])

    def entry(name: str):
        for module in modules:
            if name in [e.name for e in module.entry_points]:
                return module.entry_point(name)
        raise RuntimeError(f"no entry point {name} in {file} or trace.slang")

    program = device.link_program(modules=modules, entry_points=[entry(e) for e in entry_points])
    groups = [spy.HitGroupDesc(hit_group_name="hit", closest_hit_entry_point=closest_hit)] if closest_hit else []
    pipeline = device.create_ray_tracing_pipeline(program=program, hit_groups=groups, max_recursion=1,
                                                  max_ray_payload_size=32, max_attribute_size=8)
    table = device.create_shader_table(program=program, ray_gen_entry_points=[raygen], miss_entry_points=list(misses),
                                       hit_group_names=["hit"] if closest_hit else [])
    _COMPILED[key] = (device, program, pipeline, table)  # the device kept alive with its pipelines
    return program, pipeline, table


def _compute(device, name: str, file: str) -> tuple:
    key = (id(device), file, name)
    if key not in _COMPILED:
        program = device.load_program(file, [name])
        _COMPILED[key] = (device, program, device.create_compute_pipeline(program))
    return _COMPILED[key][1:]


class Pipeline:
    """A ray-tracing pipeline (made once a process: _ray_tracing), with this backend's root
    object and timestamps."""

    def __init__(self, device, file: str, raygen: str, misses: tuple[str, ...], closest_hit: str | None = None):
        import slangpy as spy

        self.device = device
        self.program, self.pipeline, self.table = _ray_tracing(device, file, raygen, tuple(misses), closest_hit)
        # one pool per frame in flight (rt/slang/flights.py): a frame's timestamps are read while
        # the next frame's are written
        self.timers = [device.create_query_pool(type=spy.QueryType.timestamp, count=2) for _ in range(SLOTS)]
        self.root = _Root(device, self.program)

    def dispatch(self, encoder, width: int, height: int, bind, static=None, key=None, slot: int = 0):
        """bind(cursor) sets the shader's globals that change from frame to frame, static(cursor)
        the others, when key (a tuple of what they depend on) differs from the last dispatch's;
        then one ray generation per pixel, recorded in encoder (the backend submits it). Returns a
        function that gives the dispatch's GPU time in ms, to be called once the device has done
        the work (the backend's wait), before the slot's next dispatch."""
        self.root.bind(bind, static, key)
        timer = self.timers[slot]
        timer.reset()
        encoder.write_timestamp(timer, 0)
        with encoder.begin_ray_tracing_pass() as rt_pass:
            rt_pass.bind_pipeline(self.pipeline, self.table, self.root.object)
            rt_pass.dispatch_rays(0, [width, height, 1])
        encoder.write_timestamp(timer, 1)
        return functools.partial(elapsed, timer)


def elapsed(timer) -> float:
    """A dispatch's GPU time in ms, once its work is done (Vulkan does not wait for the
    timestamps themselves)."""
    t0, t1 = timer.get_timestamp_results(0, 2)
    return (t1 - t0) * 1e3


class ComputePipeline:
    """The compute kernel `name` (its entry point) of shaders/rt/<file> (<name>.slang unless given)."""

    def __init__(self, device, name: str, file: str | None = None):
        program, self.pipeline = _compute(device, name, file or f"{name}.slang")
        self.root = _Root(device, program)

    def dispatch(self, encoder, width: int, height: int, values: dict) -> None:
        """values: the kernel's globals by name; one thread per pixel, recorded in encoder."""
        cursor = self.root.cursor
        for name, value in values.items():
            cursor[name] = value
        with encoder.begin_compute_pass() as compute_pass:
            compute_pass.bind_pipeline(self.pipeline, self.root.object)
            compute_pass.dispatch([width, height, 1])
