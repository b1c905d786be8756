"""OpenGL contexts. The render core takes a moderngl context from its caller (the window's, or
the headless one made here)."""
from __future__ import annotations

import os
from typing import Any

import moderngl

MIN_GL = 330


class GLUnavailableError(RuntimeError):
    pass


_HELP = (
    "skinviewer needs OpenGL 3.3 or newer. Headless rendering uses EGL: on Debian/Ubuntu install "
    "'libegl1 libgl1 libgl1-mesa-dri' (Mesa's llvmpipe renders on the CPU when there is no GPU); "
    "in a window, a desktop with an OpenGL 3.3 driver (or 'xvfb-run' with Mesa)."
)


def headless_context(require: int = MIN_GL, backend: str | None = None) -> moderngl.Context:
    """A standalone context: through EGL (no window, no X) unless ``backend`` or the environment
    variable SKINVIEWER_GL_BACKEND names another glcontext backend ("x11" for GLX); falls back to
    the platform default. A process that also opens a GLX window should use "x11" here: Mesa
    refuses to make a GLX context current on a thread that had an EGL one."""
    errors = []
    backend = backend or os.environ.get("SKINVIEWER_GL_BACKEND") or "egl"
    attempts: tuple[dict[str, Any], ...] = ({"backend": backend}, {})
    for kwargs in attempts:
        try:
            ctx = moderngl.create_standalone_context(require=require, **kwargs)
        except Exception as exc:  # glcontext raises plain Exceptions
            errors.append(f"{kwargs.get('backend', 'default')}: {exc}")
            continue
        if ctx.version_code < require:
            errors.append(f"got OpenGL {ctx.version_code}, need {require}")
            ctx.release()
            continue
        return ctx
    raise GLUnavailableError(f"no OpenGL {require // 100}.{require % 100 // 10} context could be created "
                             f"({'; '.join(errors)}). {_HELP}")


SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swiftshader", "swrast", "software rasterizer")


def software_renderer(ctx: moderngl.Context) -> bool:
    """A rasterizer on the CPU (Mesa llvmpipe and the like): lazy, its timer queries untrustworthy."""
    name = str(ctx.info.get("GL_RENDERER", "")).lower()
    return any(s in name for s in SOFTWARE_RENDERERS)


def describe(ctx: moderngl.Context) -> str:
    info = ctx.info
    return f"{info.get('GL_RENDERER', '?')} / OpenGL {info.get('GL_VERSION', '?')}"
