"""`rtlab bench|study --cluster ADDRESS`: the sweep's units (app/sweep_work.py) as Ray tasks over a
cluster (`pip install 'rtlab[cluster]'`; ADDRESS is `auto`, `HOST:PORT` or `ray://HOST:PORT`).

Every node needs rtlab installed, and scene files at the same path (a shared file system);
built-in scenes need nothing. Each task asks for one GPU where the cluster has GPUs and the
tracer is not Embree; otherwise CPUs for Embree: a timing task the CPUs of the smallest node, so
that nothing else runs beside it while it is timed, and every other task --task-cpus (default 1),
whose Embree and numba threads it then uses. A task whose worker dies (a lost node, a killed
process) runs again elsewhere (Ray's retries); its result comes back once."""
from __future__ import annotations

import os

from core.errors import UserError

RETRIES = 3  # a unit runs again this often where its worker or node is lost
_WORKER = None  # this worker process's Worker (renderers kept between its tasks)


def _ray():
    try:
        import ray
    except ImportError:
        raise UserError("--cluster needs Ray: pip install 'rtlab[cluster]' (or pip install ray)") from None
    return ray


def _reachable(address: str, timeout: float = 5.0) -> None:
    """HOST:PORT or ray://HOST:PORT answers (Ray itself waits minutes for an address that does not)."""
    import socket

    if address == "auto":
        return
    host, sep, port = address.removeprefix("ray://").rpartition(":")
    if not sep or not port.isdigit() or not host:
        raise UserError(f"--cluster {address}: give auto, HOST:PORT or ray://HOST:PORT")
    try:
        socket.create_connection((host, int(port)), timeout=timeout).close()
    except OSError as e:
        raise UserError(f"--cluster {address}: no Ray cluster answers there ({e.strerror or e})") from None


def run_unit(settings: dict, unit: dict, threads: int | None, adapter: bool):
    """A unit on this Ray worker process (the body of every task)."""
    global _WORKER
    import ray

    from app.sweep_work import Worker

    if adapter:  # several GPUs on the node: the Vulkan adapter of the one Ray gave this task (by its
        ids = ray.get_gpu_ids()  # index, where Ray numbers them; not where they are UUIDs)
        if ids and str(ids[0]).isdigit():
            os.environ["RTLAB_ADAPTER"] = str(ids[0])
    if _WORKER is None or _WORKER.settings != settings:
        if _WORKER is not None:
            _WORKER.release()
        _WORKER = Worker(settings, node=ray.get_runtime_context().get_node_id())
    out = _WORKER.run(unit, threads)
    out["worker"]["gpus"] = [str(g) for g in ray.get_gpu_ids()]  # the GPUs Ray gave this task
    return out


class RayExecutor:
    def __init__(self, address: str, settings: dict, tracer: str = "auto", task_cpus: int | None = None):
        ray = self.ray = _ray()
        _reachable(address)
        try:
            if not ray.is_initialized():
                ray.init(address=address, logging_level="ERROR", log_to_driver=False)
        except (ConnectionError, RuntimeError, ValueError) as e:
            raise UserError(f"--cluster {address}: cannot connect to a Ray cluster "
                            f"({str(e).splitlines()[0]})") from None
        nodes = [n for n in ray.nodes() if n.get("Alive")]
        self.nodes = nodes
        gpus = sum(n["Resources"].get("GPU", 0) for n in nodes)
        self.gpu = gpus > 0 and tracer != "embree"
        if task_cpus is not None and task_cpus < 1:
            raise UserError("--task-cpus must be at least 1")
        node_cpus = [int(n["Resources"].get("CPU", 0)) for n in nodes if n["Resources"].get("CPU", 0) >= 1]
        if not node_cpus:
            raise UserError(f"--cluster {address}: the cluster has no node with a CPU to run on")
        self.timing_cpus = min(node_cpus)
        self.task_cpus = min(task_cpus or 1, self.timing_cpus)
        self.several_gpus = any(n["Resources"].get("GPU", 0) > 1 for n in nodes)
        self.parallelism = int(gpus) if self.gpu else max(1, sum(node_cpus) // self.task_cpus)
        self.settings = ray.put(settings)
        # max_calls=0: a worker process serves unit after unit (Ray's default for a GPU task is a new
        # process each, which would import slangpy, open the device and build the scene every time);
        # Ray keeps a reused worker on the GPU it first gave it
        self.task = ray.remote(max_calls=0)(run_unit)
        self.waiting: dict = {}  # object ref -> key

    def submit(self, key, unit: dict, node: str | None = None) -> None:
        if self.gpu:
            resources, threads = {"num_gpus": 1, "num_cpus": 1}, None
        else:
            cpus = self.timing_cpus if unit["kind"] == "time" else self.task_cpus
            resources, threads = {"num_cpus": cpus}, cpus
        opts = dict(resources, max_retries=RETRIES)
        if node is not None:  # the kind of machine a row came from: where its forward baseline is timed
            from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

            opts["scheduling_strategy"] = NodeAffinitySchedulingStrategy(node_id=node, soft=True)
        ref = self.task.options(**opts).remote(self.settings, unit, threads, self.gpu and self.several_gpus)
        self.waiting[ref] = key

    def pending(self) -> int:
        return len(self.waiting)

    def next(self):
        ray = self.ray
        done, _ = ray.wait(list(self.waiting), num_returns=1)
        key = self.waiting.pop(done[0])
        try:
            return key, ray.get(done[0])
        except ray.exceptions.RayTaskError as e:  # the unit failed on its worker: say how, in one line
            cause = e.cause if getattr(e, "cause", None) is not None else e
            raise UserError(f"--cluster: {key[1]['kind']} of {key[1]['scene']} failed on a worker: "
                            f"{str(cause).splitlines()[-1][:300]}") from None
        except ray.exceptions.RayError as e:  # lost more often than RETRIES
            raise UserError(f"--cluster: {key[1]['kind']} of {key[1]['scene']} was lost "
                            f"{RETRIES + 1} times: {str(e).splitlines()[0][:200]}") from None

    def describe(self) -> dict:
        return {"nodes": len(self.nodes), "gpus": int(sum(n["Resources"].get("GPU", 0) for n in self.nodes)),
                "cpus": int(sum(n["Resources"].get("CPU", 0) for n in self.nodes)),
                "tasks": "one GPU each" if self.gpu else f"{self.timing_cpus} CPUs a timing, {self.task_cpus} "
                                                           "CPU(s) each other unit"}

    def close(self) -> None:
        for ref in list(self.waiting):
            self.ray.cancel(ref, force=True)
        self.waiting.clear()
