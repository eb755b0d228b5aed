"""What machine a measurement came from: every benchmark figure is labelled with it."""
from __future__ import annotations

import os
import platform
from importlib import metadata


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def usable_cores() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def machine_info(ctx=None) -> dict:
    versions = {}
    for pkg in ("numpy", "moderngl", "embreex", "glcontext", "flip-evaluator", "matplotlib"):
        try:
            versions[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            versions[pkg] = None
    info = {"cpu": cpu_model(), "cores": usable_cores(), "python": platform.python_version(),
            "platform": platform.platform(), "packages": versions}
    if ctx is not None:
        info["gl_renderer"] = ctx.info.get("GL_RENDERER")
        info["gl_version"] = ctx.info.get("GL_VERSION")
    return info


def machine_label(info: dict, tracer: dict | None = None) -> str:
    """The machine in one line; with the ray-tracing backend a bench ran on (Embree on the CPU
    when a results file predates the option)."""
    gl = info.get("gl_renderer") or "?"
    rt = f", ray tracing: {tracer['name']} ({tracer['device']})" if tracer else ""
    return f"{info.get('cpu', '?')}, {info.get('cores', '?')} cores, GL: {gl}{rt}"


def source_commit() -> str | None:
    """The commit of this rtlab checkout ('+' where its tracked files differ from it), or None
    outside a git checkout: results name the code that made them."""
    import subprocess

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    try:
        head = subprocess.run(["git", "-C", root, "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              timeout=10)
        if head.returncode != 0:
            return None
        dirty = subprocess.run(["git", "-C", root, "diff", "--quiet", "HEAD", "--"], capture_output=True, timeout=10)
        return head.stdout.strip() + ("+" if dirty.returncode == 1 else "")
    except (OSError, subprocess.SubprocessError):
        return None
