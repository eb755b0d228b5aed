"""The one place that creates GL contexts and loads shaders.

Headless (EGL) for shot, bench and tests; the viewer wraps its GLFW window's context.
The rendering code is the same for both.
"""
from __future__ import annotations

import re
from functools import lru_cache
from pathlib import Path

from core.errors import UserError

SHADER_DIR = Path(__file__).resolve().parent.parent / "shaders"
INCLUDE = re.compile(r'^#include "([^"]+)"\s*$', re.MULTILINE)


def create_headless_context():
    import moderngl

    try:
        return moderngl.create_standalone_context(backend="egl", require=430)
    except Exception as e:  # noqa: BLE001 - driver errors come in many types
        raise UserError(f"cannot create a headless OpenGL 4.3 context through EGL ({e}); "
                        "install Mesa's EGL (apt-get install libegl1 libgl1-mesa-dri)") from None


def wrap_current_context():
    """The viewer's window context (created by GLFW and made current)."""
    import moderngl

    return moderngl.create_context(require=430)


# bytes of memory per pixel of a frame, measured (arcade, 2048x2048, peak RSS over a 16x16 run):
# ~140 for the raster passes (GL targets, readback, display), ~350 for the ray-traced ones
# (rays, hits, surfaces, accumulation on the host); these allow some headroom
BYTES_PER_PIXEL = {"raster": 200, "ray-traced": 450}


def check_frame_size(ctx, width: int, height: int, kind: str = "ray-traced") -> None:
    """Refuse a frame size that this GL cannot make a framebuffer of, or that would not fit
    in memory, before anything is allocated (one line naming the limit)."""
    from scenes.loaders.common import available_memory

    limit = min(int(ctx.info.get("GL_MAX_TEXTURE_SIZE", 16384)), int(ctx.info.get("GL_MAX_RENDERBUFFER_SIZE", 16384)),
                *(int(v) for v in (ctx.info.get("GL_MAX_VIEWPORT_DIMS") or (16384,))))
    if width > limit or height > limit:
        raise UserError(f"--size {width}x{height}: this OpenGL ({ctx.info.get('GL_RENDERER', '?')}) makes "
                        f"framebuffers of at most {limit}x{limit}")
    need, have = width * height * BYTES_PER_PIXEL[kind], available_memory()
    if need > have * 0.8:
        raise UserError(f"--size {width}x{height}: a {kind} frame this large needs about {need / 2**30:.1f} GiB; "
                        f"{have / 2**30:.1f} GiB is available")


def software_gl(ctx) -> bool:
    """True on a CPU rasteriser (Mesa's llvmpipe, softpipe, swrast)."""
    renderer = str(ctx.info.get("GL_RENDERER", "")).lower()
    return any(name in renderer for name in ("llvmpipe", "softpipe", "swrast"))


@lru_cache(maxsize=None)
def shader_source(name: str) -> str:
    path = SHADER_DIR / name
    text = path.read_text()
    return INCLUDE.sub(lambda m: shader_source(m.group(1)), text)


def with_defines(source: str, defines: tuple[str, ...]) -> str:
    """The source with `#define NAME` lines after its #version line."""
    if not defines:
        return source
    head, newline, rest = source.partition("\n")
    return head + newline + "".join(f"#define {d}\n" for d in defines) + rest


def program(ctx, vertex: str, fragment: str | None = None, defines: tuple[str, ...] = ()):
    """Compile a program from files in shaders/ (with #include and the given #defines), cached
    per context."""
    cache = ctx.extra if isinstance(ctx.extra, dict) else {}
    ctx.extra = cache
    key = ("program", vertex, fragment, defines)
    if key not in cache:
        cache[key] = ctx.program(vertex_shader=with_defines(shader_source(vertex), defines),
                                 fragment_shader=with_defines(shader_source(fragment), defines) if fragment else None)
    return cache[key]


def fullscreen(ctx, fragment: str):
    """A program + empty vertex array drawing one screen-covering triangle."""
    cache = ctx.extra if isinstance(ctx.extra, dict) else {}
    ctx.extra = cache
    key = ("fullscreen", fragment)
    if key not in cache:
        prog = program(ctx, "fullscreen.vert", fragment)
        cache[key] = (prog, ctx.vertex_array(prog, []))
    return cache[key]


def bind_channels(prog, frame, names) -> None:
    """Bind the frame's textures `names` to units 0, 1, … and their samplers of the same names."""
    for unit, name in enumerate(names):
        frame.channels[name].use(unit)
        set_uniform(prog, name, unit)


def set_uniform(prog, name: str, value) -> None:
    """Set a uniform if the compiler kept it (unused uniforms are optimised away)."""
    if name in prog:
        member = prog[name]
        if hasattr(value, "tobytes") and not isinstance(value, (int, float)):
            member.write(value.astype("f4").tobytes() if value.dtype.kind == "f" else value.tobytes())
        else:
            member.value = value
