"""The viewer's start-up timeline: ``mark(event)`` notes when each start-up step finished.

With ``SKINVIEWER_STARTUP_TRACE=FILE`` each mark is appended to FILE as one JSON line
``{"event": ..., "t": <unix time>}`` (``benchmarks/bench_startup.py`` reads them against the time it
started the process). Events: ``window`` (the window shows the start-up screen), ``ui`` (the first
frame with the panel), ``image`` (the first complete image in the view: the governor's preview where
there is one, ``preview`` says which), ``final`` (the first complete image at the user's own settings).
Standard library only: this module is imported before anything heavy."""
from __future__ import annotations

import json
import os
import time

MARKS: list[tuple[str, float]] = []  # (event, unix time) of this process


def mark(event: str, **info) -> None:
    t = time.time()
    MARKS.append((event, t))
    path = os.environ.get("SKINVIEWER_STARTUP_TRACE")
    if not path:
        return
    try:
        with open(path, "a", encoding="utf-8") as f:
            # cpu: this process's CPU seconds so far (all its threads, llvmpipe's included): the
            # start's own work, apart from what a loaded machine adds to the wall clock
            f.write(json.dumps({"event": event, "t": t, "cpu": round(time.process_time(), 3), **info}) + "\n")
    except OSError:
        pass  # a trace is never a reason for the viewer not to start


DEFAULT_WINDOW = (1280, 800)
RETRY_PAUSE_S = 0.25  # before asking a window library for OpenGL 4.3 a second time


class WindowUnavailableError(RuntimeError):
    """No window could be opened (no display, no OpenGL 3.3 driver)."""


def create_window(size: tuple[int, int] = DEFAULT_WINDOW, visible: bool = True, vsync: bool = True,
                  backend: str = "glfw"):
    """A moderngl-window window (glfw by default; pyglet as a fallback) with a GL 4.3 core context, or 3.3.
    Imports moderngl-window and the window library only (a few tenths of a second), nothing of the
    viewer: the launcher (skinviewer/launch.py) opens it before the viewer's own modules load."""
    import sys
    import warnings

    import moderngl_window as mglw
    errors = []
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")) and sys.platform.startswith("linux"):
        errors.append("no DISPLAY or WAYLAND_DISPLAY")
    else:
        # OpenGL 4.3 first (compute shaders: render.compute_blur), asked twice: glfw's init failed once
        # under Xvfb ("Failed to initialize glfw") where the next window opened at 4.3 (a 3.3 window on a
        # GPU loses the compute blurs); then 3.3: a driver may give exactly the version asked. What it
        # got after a failure is said once on stderr and in kernel.gl.describe
        import time
        for name in [backend] + [b for b in ("glfw", "pyglet") if b != backend]:
            failed: list[str] = []  # this library's failures
            for version in ((4, 3), (4, 3), (3, 3)):
                if failed and version == (4, 3):
                    time.sleep(RETRY_PAUSE_S)  # the second 4.3 try, after a pause
                try:
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")  # glfw reports its init failure as a warning too
                        cls = mglw.get_local_window_cls(name)
                        wnd = cls(title="skinviewer", size=(int(size[0]), int(size[1])), resizable=True,
                                  visible=visible, gl_version=version, aspect_ratio=None, vsync=vsync, samples=0,
                                  cursor=True)
                    mglw.activate_context(window=wnd)
                except Exception as exc:
                    failed.append(f"{name} {version[0]}.{version[1]}: {exc}")
                    continue
                # moderngl-window closes the window on Escape by default: that quit the session (unsaved
                # edits and all) when Escape was meant for a text field or for leaving the pass inspector
                wnd.exit_key = None
                if failed:
                    from skinviewer.kernel.gl import set_fallback
                    if version < (4, 3):
                        note = f"OpenGL 4.3 unavailable twice ({failed[-1]}), running 3.3: no compute shaders"
                    else:
                        note = f"OpenGL 4.3 on the second try (the first: {failed[0]})"
                    set_fallback(wnd.ctx, note)
                    print(f"skinviewer: {note}", file=sys.stderr)
                return wnd
            errors.extend(failed)
    raise WindowUnavailableError(
        "cannot open a window (" + "; ".join(errors) + "). Without a display run it under Xvfb: "
        "xvfb-run -a -s '-screen 0 1280x800x24' skinviewer ...; headless renders: skinviewer render --out FILE.png")


# -- the early window: opened by the launcher before the viewer's modules are imported, taken over
# by ui.app.create_app (one window, its start-up screen continued) --------------------------------
_early: dict = {}


def open_early(size: tuple[int, int]):
    """Open the window and its start-up screen now; returns the Splash (None if no window could be
    opened: the viewer's own start reports why, in one line)."""
    try:
        wnd = create_window(size)
    except Exception:
        return None
    from skinviewer.ui.splash import Splash
    sp = Splash(wnd)
    sp.show("window open")
    mark("window")
    _early.update(wnd=wnd, splash=sp, size=(int(size[0]), int(size[1])))
    return sp


def take_early(size: tuple[int, int]):
    """The early (window, splash) for a viewer of this size, handed over once; None if there is none
    or it was closed."""
    if not _early or _early.get("size") != (int(size[0]), int(size[1])):
        return None
    wnd, sp = _early.pop("wnd"), _early.pop("splash")
    _early.clear()
    if getattr(wnd, "is_closing", False):
        sp.release()
        wnd.destroy()
        return None
    return wnd, sp


def close_early() -> None:
    """The launcher, after the command returned: a window nobody took (bad arguments) is closed."""
    if _early:
        wnd, sp = _early.pop("wnd"), _early.pop("splash")
        _early.clear()
        try:
            sp.release()
            wnd.destroy()
        except Exception:
            pass
