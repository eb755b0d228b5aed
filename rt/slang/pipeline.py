"""A ray-tracing pipeline of one shader file (shaders/rt/), dispatched over the image."""
from __future__ import annotations


class Pipeline:
    def __init__(self, device, file: str, raygen: str, misses: tuple[str, ...], closest_hit: str | None = None):
        import slangpy as spy

        entry_points = [raygen, *misses] + ([closest_hit] if closest_hit else [])
        self.device = device
        # entry points live in the effect's file or in trace.slang (the misses and the closest hit)
        modules = [device.load_module(file)] + ([device.load_module("trace.slang")] if file != "trace.slang" else [])

        def entry(name: str):
            for module in modules:
                if name in [e.name for e in module.entry_points]:
                    return module.entry_point(name)
            raise RuntimeError(f"no entry point {name} in {file} or trace.slang")

        self.program = device.link_program(modules=modules, entry_points=[entry(e) for e in entry_points])
        groups = [spy.HitGroupDesc(hit_group_name="hit", closest_hit_entry_point=closest_hit)] if closest_hit else []
        self.pipeline = device.create_ray_tracing_pipeline(program=self.program, hit_groups=groups, max_recursion=1,
                                                           max_ray_payload_size=32, max_attribute_size=8)
        self.timer = device.create_query_pool(type=spy.QueryType.timestamp, count=2)
        self.table = device.create_shader_table(program=self.program, ray_gen_entry_points=[raygen],
                                                miss_entry_points=list(misses),
                                                hit_group_names=["hit"] if closest_hit else [])

    def dispatch(self, encoder, width: int, height: int, bind):
        """bind(cursor) sets the shader's globals; then one ray generation per pixel, recorded in
        encoder (the backend submits it). Returns a function that gives the dispatch's GPU time
        in ms, to be called once the device has done the work (the backend's wait)."""
        import slangpy as spy

        self.timer.reset()
        encoder.write_timestamp(self.timer, 0)
        with encoder.begin_ray_tracing_pass() as rt_pass:
            bind(spy.ShaderCursor(rt_pass.bind_pipeline(self.pipeline, self.table)))
            rt_pass.dispatch_rays(0, [width, height, 1])
        encoder.write_timestamp(self.timer, 1)
        return self.elapsed

    def elapsed(self) -> float:
        """The last dispatch's GPU time in ms, once its work is done (Vulkan does not wait for
        the timestamps themselves)."""
        t0, t1 = self.timer.get_timestamp_results(0, 2)
        return (t1 - t0) * 1e3
