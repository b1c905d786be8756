"""The UI layer: the imgui (and implot) contexts, the registered windows, and one imgui frame.

Each window draws itself. A window is made once per session by ``factory(state, frame)`` --
``state`` the ``ui.state.ViewerState`` (read its fields, change it only through its methods),
``frame`` the ``ui.frame.FrameController`` (the renderer, the frame report, costs, screenshots) --
and drawn every frame by ``window.draw(ui)`` with the frame's ``ui.widgets.UiContext`` (layout,
edits, cost hints, ``ui.header``; call ``ui.claim(rect)`` for the area it covers so mouse input
there goes to the UI and not to the 3D view). Settings edits go through ``ui.edits.set(path,
value)`` (applied and validated once, after every window has drawn) or ``state.apply``.

**Adding a window is one line** in ``WINDOWS`` below (drawn in that order), e.g. for the
accuracy window: ``from skinviewer.ui.accuracy_window import AccuracyWindow`` and ``AccuracyWindow,``
in the tuple. A window that fails to draw is reported in the status bar; the session goes on.

Optional: ``draw_view(viewport) -> bool`` -- the window's own view mode (e.g. an error heat map):
called when the 3D view would show the image (not while comparing A/B or inspecting a pass); return
True when it drew the view region (``viewport``: x, y, w, h in framebuffer pixels; draw with
``frame.view.display``). ``release()`` -- free its GL objects at the end of the session."""
from __future__ import annotations

import traceback
from collections.abc import Callable
from typing import Protocol

from skinviewer.ui.accuracy_window import AccuracyWindow
from skinviewer.ui.compare_overlay import CompareOverlay
from skinviewer.ui.frame import FrameController
from skinviewer.ui.layout import Layout
from skinviewer.ui.panel import Panel
from skinviewer.ui.passes_window import PassesWindow
from skinviewer.ui.state import ViewerState
from skinviewer.ui.status_bar import StatusBar
from skinviewer.ui.widgets import UiContext


class Window(Protocol):
    def draw(self, ui: UiContext) -> None: ...

    # optional: def draw_view(self, viewport) -> bool; def release(self) -> None


WindowFactory = Callable[[ViewerState, FrameController], Window]

# the windows of the viewer, drawn in this order: add a window here (one line)
WINDOWS: tuple[WindowFactory, ...] = (
    Panel,
    StatusBar,
    PassesWindow,
    AccuracyWindow,
    CompareOverlay,
)


def _style() -> None:
    from imgui_bundle import imgui
    imgui.style_colors_dark()
    st = imgui.get_style()
    st.window_rounding = 4.0
    st.frame_rounding = 3.0
    st.grab_rounding = 3.0
    st.item_spacing = imgui.ImVec2(6, 4)
    st.set_color_(imgui.Col_.window_bg.value, imgui.ImVec4(0.08, 0.08, 0.09, 0.92))


class UiHost:
    """imgui for one window: contexts, the input renderer, the windows, build and present."""

    def __init__(self, wnd, state: ViewerState, frame: FrameController,
                 windows: tuple[WindowFactory, ...] = WINDOWS):
        from imgui_bundle import imgui, implot

        from skinviewer.ui.imgui_backend import ImguiRenderer
        self.state, self.frame = state, frame
        self.imgui_ctx = imgui.create_context()
        imgui.set_current_context(self.imgui_ctx)
        self.implot_ctx = implot.create_context()
        implot.set_current_context(self.implot_ctx)
        imgui.get_io().set_ini_filename("")
        _style()
        self.renderer = ImguiRenderer(wnd)
        self.windows: list[Window] = [factory(state, frame) for factory in windows]
        self.rects: list[tuple[float, float, float, float]] = []  # what the UI covered last frame
        self._pending: dict = {}  # typed, not yet applied widget values (kept across frames)

    def add_window(self, factory: WindowFactory) -> Window:
        """Register a window for this session (drawn after the others); ``WINDOWS`` is the place for
        the viewer's own windows."""
        w = factory(self.state, self.frame)
        self.windows.append(w)
        return w

    def window(self, cls):
        """The window of type ``cls`` (tests, scripts)."""
        return next(w for w in self.windows if isinstance(w, cls))

    def build(self, frametime: float, layout: Layout) -> bool:
        """Run the imgui frame: every window draws itself; their settings edits are applied once."""
        from imgui_bundle import imgui
        imgui.set_current_context(self.imgui_ctx)
        io = imgui.get_io()
        io.delta_time = max(float(frametime), 1e-4)
        (ww, wh), (fw, fh) = layout.window, layout.framebuffer
        io.display_size = imgui.ImVec2(float(ww), float(wh))
        io.display_framebuffer_scale = imgui.ImVec2(fw / max(ww, 1), fh / max(wh, 1))
        imgui.new_frame()
        ui = UiContext(layout=layout, cost_hint=self.frame.cost_hint, expand_all=self.state.view.expand_all,
                       pending=self._pending)
        saved = imgui.internal.ErrorRecoveryState()
        imgui.internal.error_recovery_store_state(saved)
        try:
            for w in self.windows:
                w.draw(ui)
        except Exception as exc:  # a UI bug must not take the session down
            self.frame.ui_failed(f"UI: {type(exc).__name__}: {exc}")
            traceback.print_exc()
            imgui.internal.error_recovery_try_to_recover_state(saved)
        if ui.edits:
            self.state.apply(ui.edits.values)
        self.rects = ui.rects
        self.frame.set_widget_active(bool(imgui.is_any_item_active()))
        imgui.render()
        return True

    def present(self) -> None:
        from imgui_bundle import imgui
        imgui.set_current_context(self.imgui_ctx)
        self.frame.ctx.screen.use()
        self.renderer.render(imgui.get_draw_data())

    def view_hooks(self) -> list:
        """The windows' own view modes (``draw_view``), in drawing order."""
        hooks = [getattr(w, "draw_view", None) for w in self.windows]
        return [h for h in hooks if callable(h)]

    def covers(self, x: float, y: float) -> bool:
        """A UI window was drawn at (x, y) last frame."""
        return any(rx <= x <= rx + rw and ry <= y <= ry + rh for rx, ry, rw, rh in self.rects)

    def wants_mouse(self) -> bool:
        from imgui_bundle import imgui
        return bool(imgui.get_io().want_capture_mouse)

    def wants_keyboard(self) -> bool:
        from imgui_bundle import imgui
        return bool(imgui.get_io().want_capture_keyboard)

    def release(self) -> None:
        from imgui_bundle import imgui, implot
        for w in self.windows:
            release = getattr(w, "release", None)
            if callable(release):
                release()
        try:
            self.renderer.shutdown()
        except Exception:
            pass
        implot.destroy_context(self.implot_ctx)
        imgui.destroy_context(self.imgui_ctx)
