"""The interactive viewer's window: a thin moderngl-window WindowConfig that wires the parts
together and forwards events and frames to them. Entry point: ``run_viewer(settings, ...)`` (the command line parses the arguments).

- ``ui.state.ViewerState`` -- the one state object: settings, scene, presets, messages, A/B
  compare, inspector, screenshot and layout options; changed only through its methods.
- ``ui.frame.FrameController`` -- what to render this frame: render size, scheduling and the
  time budget, the frame report and costs, A/B compare frames, screenshots.
- ``ui.input.InputController`` -- orbit / pan / zoom, the key light, the keyboard shortcuts.
- ``ui.windows.UiHost`` -- imgui and the registered windows (``ui.windows.WINDOWS``), each of which
  draws itself.

Tests (and scripts) build it in-process with ``create_app(settings, size=(320, 240))`` and drive it
with ``app.step()``, the ``on_mouse_*`` / ``on_key_event`` handlers and ``app.state.apply({...})``."""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path
from typing import Any

import moderngl_window as mglw
from moderngl_window.timers.clock import Timer

from skinviewer.engine.renderer import Renderer
from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.shaders import ShaderLibrary
from skinviewer.ui import startup
from skinviewer.ui.frame import FrameController
from skinviewer.ui.input import InputController
from skinviewer.ui.startup import DEFAULT_WINDOW, WindowUnavailableError, create_window  # noqa: F401  (the window is startup's)
from skinviewer.ui.state import ViewerOptions, ViewerState, best_technique
from skinviewer.ui.windows import UiHost


class ViewerApp(mglw.WindowConfig):
    title = "skinviewer"
    gl_version = (4, 3)  # create_window asks 4.3 (compute shaders), then 3.3
    aspect_ratio = None  # type: ignore[assignment]  # moderngl-window accepts None (free aspect); its annotation does not
    resizable = True
    clear_color = None  # type: ignore[assignment]  # None: no clear by the window (the frame draws everything)
    vsync = True

    def __init__(self, settings: Settings | None = None, preset_path: str | None = None,
                 shaders_root: str | Path | None = None, notices: list[str] | None = None,
                 options: ViewerOptions | None = None, defer_scene: bool = False, **kwargs):
        super().__init__(**kwargs)
        self.shaders = ShaderLibrary(self.ctx, root=Path(shaders_root) if shaders_root else None)
        # env_bake_background: the window does not wait for the environment's visibility bake (issue 32)
        self.renderer = Renderer(self.ctx, self.shaders, env_bake_background=True)
        self._vsync = bool(getattr(self.wnd, "vsync", True))
        self.state = ViewerState(settings, self.renderer.ensure_scene, preset_path, notices, options, vsync=self._vsync,
                                 defer_scene=defer_scene)
        self.frame = FrameController(self.ctx, self.state, self.renderer, self.shaders,
                                     self.wnd.size, self.wnd.buffer_size)
        self.ui = UiHost(self.wnd, self.state, self.frame)
        self.input = InputController(self.state, self.frame, self.ui, self.wnd.keys, self.wnd.mouse)
        self._title = ""
        self._events = 0  # input events since the last presented frame (FrameController.can_skip_present)
        self._marked: set[str] = set()
        self._stall_ms = 0.0  # the longest frame between the panel and the first image (_note_stall)
        self._step_t0 = time.perf_counter()
        self.swap_ms = 0.0  # the last step's buffer swap (0: it only rendered)
        self.warm: Any = None  # the start's worker (ui/warm.py), joined before the first render

    # -- frames --------------------------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        """Run ``n`` frames (render, UI, swap -- or, while a still view's frame is spread over
        several and no input came, render only and poll events): the viewer's loop, tests, --frames."""
        if self.warm is not None:  # the start's worker fills the caches the render reads: never both at once
            self.warm.join()
            self.warm = None
        for _ in range(n):
            t0 = self._step_t0 = time.perf_counter()
            self.wnd.use()
            if self.render_frame(1 / 60):
                self._events = 0
                t1 = time.perf_counter()
                self.wnd.swap_buffers()  # presenting, timed apart from the frame's work (Xvfb: it spikes under load)
                self.swap_ms = (time.perf_counter() - t1) * 1000.0
            else:
                self.swap_ms = 0.0
                self._poll_events()
            self.frame.frame_end()  # what the frame cost after its render: the next frames budget it
            self._note_stall(t0)

    def start_warm(self) -> None:
        """The first frame's CPU work on the scene in a worker (ui/warm.py); ``step`` joins it."""
        from skinviewer.ui.warm import start_warm
        self.warm = start_warm(self.renderer, self.state.settings)

    def ui_frame(self) -> None:
        """One frame of the panel and the view's start-up screen without rendering: the start shows
        the panel before the first image (whose shaders and tables take seconds on a first frame)."""
        t0 = time.perf_counter()
        self.wnd.use()
        ctx, layout = self.ctx, self.frame.layout
        built = self.state.view.show_ui and self.ui.build(1 / 60, layout)
        ctx.screen.use()
        ctx.viewport = (0, 0, *layout.framebuffer)
        ctx.clear(*self.state.settings.render.background, 1.0)
        ctx.viewport = layout.view_fb
        for hook in self.ui.view_hooks():
            if hook(layout.view_fb):
                break
        if built:
            self.ui.present()
            if "ui" not in self._marked:
                self._marked.add("ui")
                startup.mark("ui")
        self.wnd.swap_buffers()
        self._note_stall(t0)

    def _note_stall(self, t0: float) -> None:
        """The start's longest frame (input waits that long) from the panel to the first image."""
        if "ui" in self._marked and "image" not in self._marked:
            self._stall_ms = max(self._stall_ms, (time.perf_counter() - t0) * 1000.0)

    def on_render(self, t: float, frametime: float) -> None:
        self.render_frame(frametime)

    def render_frame(self, frametime: float) -> bool:
        """One frame; returns whether it drew the screen (False: rendered only, no swap needed)."""
        self._follow_vsync()
        present = not self.frame.can_skip_present(self._events)
        drew = self.frame.run(frametime, self.wnd.size, self.wnd.buffer_size, self.ui, present=present)
        self._update_title()
        self._mark_startup()
        return drew

    def _poll_events(self) -> None:
        """Input without a buffer swap (a frame that only rendered)."""
        try:
            import glfw
            glfw.poll_events()
        except Exception:  # another window backend: it polls on its next swap
            pass

    def _mark_startup(self) -> None:
        """The start-up timeline (ui/startup.py): the first frame with the panel, the first image."""
        if "ui" not in self._marked and self.state.view.show_ui:
            self._marked.add("ui")
            startup.mark("ui")
        rep = self.frame.report
        if "image" not in self._marked and rep is not None and rep.complete:
            self._note_stall(self._step_t0)  # this frame so far
            self._marked.add("image")
            startup.mark("image", technique=self.state.settings.technique, longest_frame_ms=round(self._stall_ms, 1),
                         preview=bool(self.frame._variant))
        if "final" not in self._marked and rep is not None and rep.complete and not self.frame._variant:
            self._marked.add("final")  # the first complete image at the user's own settings
            startup.mark("final", technique=self.state.settings.technique)

    def _follow_vsync(self) -> None:
        want = self.state.view.vsync
        if want != self._vsync:
            self._vsync = want
            try:
                self.wnd._set_vsync(want)
            except Exception:
                pass

    def _update_title(self) -> None:
        st = self.state
        name = Path(st.presets.path).name if st.presets.path else "untitled"
        title = f"skinviewer - {name}{' *' if st.presets.dirty(st.settings) else ''} - {st.settings.technique}"
        if title != self._title:
            self._title = title
            try:
                self.wnd.title = title
            except Exception:
                pass

    # -- events: to imgui and to the input controller ----------------------------------------
    def on_mouse_position_event(self, x, y, dx, dy):
        self._events += 1
        self.ui.renderer.mouse_position_event(x, y, dx, dy)
        self.input.position(x, y)

    def on_mouse_press_event(self, x, y, button):
        self._events += 1
        self.ui.renderer.mouse_press_event(x, y, button)
        self.input.press(x, y, button)

    def on_mouse_release_event(self, x, y, button):
        self._events += 1
        self.ui.renderer.mouse_release_event(x, y, button)
        self.input.release(x, y, button)

    def on_mouse_drag_event(self, x, y, dx, dy):
        self._events += 1
        self.ui.renderer.mouse_drag_event(x, y, dx, dy)
        self.input.drag(x, y, dx, dy, shift_held=bool(getattr(self.wnd.modifiers, "shift", False)))

    def on_mouse_scroll_event(self, x_offset, y_offset):
        self._events += 1
        self.ui.renderer.mouse_scroll_event(x_offset, y_offset)
        self.input.scroll(x_offset, y_offset)

    def on_key_event(self, key, action, modifiers):
        self._events += 1
        self.ui.renderer.key_event(key, action, modifiers)
        self.input.key(key, action, modifiers)

    def on_unicode_char_entered(self, char):
        self._events += 1
        self.ui.renderer.unicode_char_entered(char)

    def on_resize(self, width, height):
        self._events += 1
        self.ui.renderer.resize(width, height)

    # -- teardown ------------------------------------------------------------------------------
    def close(self) -> None:
        self.ui.release()  # windows free their GL objects first
        self.frame.release()
        self.shaders.release()


def startup_headline(s: Settings) -> str:
    """The start-up screen's headline once the panel works (issue 34: what it says must hold): with the
    governor on, a cheaper preview comes first (the cold start's cheapest rung, or the calibrated pick);
    with it off, the first image is at the user's settings."""
    if s.render.governor == "off":
        return "the panel works; the image at your settings appears here (the governor is off: no preview first)"
    return "the panel works; a first preview appears here where a cheaper one exists, then your settings"


def create_app(settings: Settings | None = None, size: tuple[int, int] = DEFAULT_WINDOW, visible: bool = True,
               vsync: bool = True, preset_path: str | None = None, shaders_root=None,
               notices: list[str] | None = None, options: ViewerOptions | None = None,
               splash: bool = False) -> ViewerApp:
    """The viewer in a new window. ``splash``: the window shows the start-up steps and their times
    (ui/splash.py) until the first frame, instead of staying black."""
    early = startup.take_early(size) if splash else None  # the launcher's window, already showing its screen
    wnd = early[0] if early else create_window(size, visible=visible, vsync=vsync)
    sp = early[1] if early else None
    if splash and sp is None:
        from skinviewer.ui.splash import Splash
        sp = Splash(wnd)
        sp.show("window open")
        startup.mark("window")
    if sp is None:
        return _finish(ViewerApp(settings=settings, preset_path=preset_path, shaders_root=shaders_root,
                                 notices=notices, options=options, ctx=wnd.ctx, wnd=wnd, timer=Timer()), None)
    # issue 34: the panel before the mesh -- the viewer's objects without a scene, its first UI frame,
    # then the scene read in a worker while the panel keeps drawing, uploaded on this (GL) thread
    sp.show("the viewer's objects and the shader library (the scene comes after the panel)")
    app = ViewerApp(settings=settings, preset_path=preset_path, shaders_root=shaders_root, notices=notices,
                    options=options, ctx=wnd.ctx, wnd=wnd, timer=Timer(), defer_scene=True)
    sp.hand_over(f"the panel is up; the scene, then the first image of {app.state.settings.technique}",
                 startup_headline(app.state.settings))
    from skinviewer.ui.splash import StartupView
    app.ui.add_window(lambda state, frame: StartupView(sp, frame))
    app.ui_frame()  # the panel, before the mesh is read (the "ui" mark)
    s0 = app.state.settings
    if app.state.scene is None and not s0.scene.mesh and s0.scene.name == "head":
        import threading

        from skinviewer.kernel.gpu_scene import prepare_gpu_arrays
        from skinviewer.scene.scenes import prefetch_scene

        def read_head():
            try:  # generated once, then read from the cache; the load below reports a failure
                prepare_gpu_arrays(prefetch_scene("head", s0.scene.head_detail).mesh)
            except Exception:
                pass
        th = threading.Thread(target=read_head, name="skinviewer-head", daemon=True)
        th.start()
        while th.is_alive() and not wnd_closing(app):
            app.ui_frame()
            th.join(0.1)  # ~8 panel frames a second: most of the GIL stays with the worker
    app.state.load_initial_scene()  # the upload (GL: this thread), or the fallback scene
    app.start_warm()  # the first frame's CPU work in a worker from now (ui/warm.py; run_viewer joins it)
    return _finish(app, sp)


def _finish(app: ViewerApp, sp) -> ViewerApp:
    if sp is None:
        app.wnd.swap_buffers()
    app.wnd.set_default_viewport()
    return app


def destroy_app(app: ViewerApp) -> None:
    wnd = app.wnd
    app.close()
    try:
        wnd.destroy()
    except Exception:
        pass


def wnd_closing(app: ViewerApp) -> bool:
    return bool(getattr(app.wnd, "is_closing", False))


SETTLE_FRAMES = 600  # a batch screenshot waits at most this many frames more for a complete image


def run_viewer(s: Settings, *, technique_given: bool = False, frames: int = 0, screenshot: str | None = None,
               size: tuple[int, int] | None = None, preset_path: str | None = None, debug: bool = False) -> int:
    """``skinviewer [view]``: open the window on settings ``s`` (the command line parses them); with
    ``frames`` N render N frames and exit (writing ``screenshot`` after the last one)."""
    if not technique_given:
        s = with_values(s, {"technique": best_technique(s.technique)})
    frames = frames or (1 if screenshot else 0)
    win = (int(size[0]), int(size[1])) if size else DEFAULT_WINDOW
    options = ViewerOptions(debug=debug or os.environ.get("SKINVIEWER_DEBUG") == "1")
    app = create_app(s, size=win, preset_path=preset_path, options=options, splash=not frames)
    # the quality governor's calibration (issue 27): loaded, or measured in the background for the
    # techniques it lacks (not for scripted --frames runs; SKINVIEWER_CALIBRATE=0 turns it off)
    app.frame.load_calibration(auto=not frames and os.environ.get("SKINVIEWER_CALIBRATE", "1") != "0")
    if frames and screenshot:
        app.state.set_show_ui(False)  # batch screenshot: the 3D view fills the whole --size window
    for n in app.state.notices:
        print(f"note: {n}", file=sys.stderr)
    if not frames:
        app.ui_frame()  # the panel first (two frames: plots fit their axes on their second), then the image
        app.ui_frame()
        # the first frame's numpy work on the mesh (border edges, rays to the lights, rho_dt table) runs
        # in a worker (create_app) while the panel keeps drawing: the panel is not frozen by it
        warm = app.warm
        while warm is not None and warm.is_alive() and not wnd_closing(app):
            app.ui_frame()
            warm.join(0.1)  # ~8 panel frames a second: most of the GIL stays with the worker
        # the first image is the quality governor's (issue 27): the start counts as an edit, so a
        # calibrated technique shows the most accurate preview that fits the budget, then refines
        # to the user's settings as after any edit (no calibration yet: the settings themselves)
        app.frame.scheduler.note_change()
        # issue 34: without a calibration (a cold first start) the first image is the technique's
        # cheapest preview rung as declared, then the user's settings (ui/frame.start_with_preview)
        app.frame.start_with_preview()
    wnd, frame = app.wnd, app.frame
    try:
        app.timer.start()
        # --frames N: N frames, then (with --screenshot) more until the image is complete — passes
        # split over frames under the time budget (row bands) would otherwise leave it unfinished
        shot_requested, settle = False, 0
        while not wnd.is_closing:
            app.step()
            if not frames or frame.frames < frames:
                continue
            if not screenshot or shot_requested:
                break
            if (frame.report is not None and frame.report.complete) or settle >= SETTLE_FRAMES:
                frame.request_screenshot(screenshot, include_ui=False)  # written by the next frame
                shot_requested = True
            else:
                settle += 1
        if screenshot:
            if not frame.screenshots_written:
                print(f"skinviewer: no screenshot written ({frame.render_error or 'no frame'})", file=sys.stderr)
                return 2
            print(f"wrote {screenshot}")
        if frame.render_error and frames:
            print(f"skinviewer: {frame.render_error}", file=sys.stderr)
            return 2
        return 0
    finally:
        destroy_app(app)
