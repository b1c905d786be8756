"""OpenGL contexts. The render core takes a moderngl context from its caller (the window's, or
the headless one made here)."""
from __future__ import annotations

import os
import threading
from typing import Any

import moderngl

MIN_GL = 330
COMPUTE_GL = 430  # compute shaders and image load/store (render.compute_blur)


class GLUnavailableError(RuntimeError):
    pass


_HELP = (
    "skinviewer needs OpenGL 3.3 or newer. Headless rendering uses EGL: on Debian/Ubuntu install "
    "'libegl1 libgl1 libgl1-mesa-dri' (Mesa's llvmpipe renders on the CPU when there is no GPU); "
    "in a window, a desktop with an OpenGL 3.3 driver (or 'xvfb-run' with Mesa)."
)


def headless_context(require: int = MIN_GL, backend: str | None = None, prefer: int = COMPUTE_GL) -> moderngl.Context:
    """A standalone context: through EGL (no window, no X) unless ``backend`` or the environment
    variable SKINVIEWER_GL_BACKEND names another glcontext backend ("x11" for GLX); falls back to
    the platform default. A process that also opens a GLX window should use "x11" here: Mesa
    refuses to make a GLX context current on a thread that had an EGL one.

    OpenGL ``prefer`` (4.3: compute shaders) is asked first, then ``require``: a driver may give
    exactly the version asked (NVIDIA's EGL gave 3.3 for 3.3); the fallback is kept for ``describe``."""
    errors = []
    backend = backend or os.environ.get("SKINVIEWER_GL_BACKEND") or "egl"
    attempts: tuple[dict[str, Any], ...] = ({"backend": backend}, {})
    wanted = [v for v in dict.fromkeys((max(prefer, require), require))]
    for kwargs in attempts:
        for want in wanted:
            try:
                ctx = moderngl.create_standalone_context(require=want, **kwargs)
            except Exception as exc:  # glcontext raises plain Exceptions
                errors.append(f"{kwargs.get('backend', 'default')} {_ver(want)}: {exc}")
                continue
            if ctx.version_code < want:
                errors.append(f"got OpenGL {_ver(ctx.version_code)}, asked {_ver(want)}")
                ctx.release()
                continue
            if want < wanted[0]:
                set_fallback(ctx, f"OpenGL {_ver(wanted[0])} unavailable, running {_ver(ctx.version_code)}"
                             + (": no compute shaders" if ctx.version_code < COMPUTE_GL else ""))
            return ctx
    raise GLUnavailableError(f"no OpenGL {_ver(require)} context could be created "
                             f"({'; '.join(errors)}). {_HELP}")


def _ver(code: int) -> str:
    return f"{code // 100}.{code % 100 // 10}"


_FALLBACKS: dict[int, str] = {}  # id(context) -> what it fell back from (describe)


def set_fallback(ctx: moderngl.Context, text: str) -> None:
    """Remember that ``ctx`` is an older OpenGL than asked (said in ``describe``)."""
    _FALLBACKS[id(ctx)] = text


SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swiftshader", "swrast", "software rasterizer")


def gl_info(ctx: moderngl.Context) -> dict[str, Any]:
    """ctx.info, never queried off the GL thread: moderngl caches it at its first read, and a read from
    a worker (the viewer's start-up warm-up reflects passes there) caches zeros and empty names for the
    whole context. Not read yet, off the main thread: {} (callers take their defaults)."""
    info = getattr(ctx, "_info", None)
    if info is None and threading.current_thread() is threading.main_thread():
        info = ctx.info
    return dict(info or {})


def software_renderer(ctx: moderngl.Context) -> bool:
    """A rasterizer on the CPU (Mesa llvmpipe and the like): lazy, its timer queries untrustworthy."""
    name = str(gl_info(ctx).get("GL_RENDERER", "")).lower()
    return any(s in name for s in SOFTWARE_RENDERERS)


def describe(ctx: moderngl.Context) -> str:
    info = ctx.info
    fallback = _FALLBACKS.get(id(ctx))
    return f"{info.get('GL_RENDERER', '?')} / OpenGL {info.get('GL_VERSION', '?')}" + (f" ({fallback})" if fallback else "")


def compute_policy(mode: str, version_code: int, renderer: str) -> tuple[bool, str]:
    """render.compute_blur (issue 27): whether a pass with a compute twin dispatches it, and what to say.
    auto: a GL >= 4.3 context on a hardware GPU (a software rasterizer ran compute 2-6x slower than its
    fragment draws, benchmarks/bench_compute_blur.py); on: any GL >= 4.3 context, else the fragment
    draws with one line saying why; off: the fragment draws."""
    has = version_code >= COMPUTE_GL
    if mode == "off":
        return False, ""
    if mode == "on":
        if has:
            return True, ""
        return False, (f"render.compute_blur = on: this OpenGL {version_code // 100}.{version_code % 100 // 10} "
                       f"context has no compute shaders (needs 4.3): the blurs run as fragment draws")
    soft = any(s in renderer.lower() for s in SOFTWARE_RENDERERS)
    return has and not soft, ""


def compute_choice(mode: str, ctx: moderngl.Context) -> tuple[bool, str]:
    """compute_policy for a context (off the GL thread before the renderer's name is known: as a
    software rasterizer, the fragment draws; gl_info)."""
    return compute_policy(mode, int(ctx.version_code), str(gl_info(ctx).get("GL_RENDERER", "software rasterizer")))


# image formats of the textures a dispatch may store into: (components, dtype) -> GLSL layout qualifier
_IMAGE_FORMATS = {(4, "f4"): "rgba32f", (2, "f4"): "rg32f", (1, "f4"): "r32f",
                  (4, "f2"): "rgba16f", (2, "f2"): "rg16f", (1, "f2"): "r16f", (4, "f1"): "rgba8"}


def image_format(components: int, dtype: str) -> str | None:
    """The GLSL image format (IMAGE_FORMAT of lib/compute_target.glsl) of a texture; None: none."""
    return _IMAGE_FORMATS.get((components, dtype))
