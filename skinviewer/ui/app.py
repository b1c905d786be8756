"""The interactive viewer: a moderngl-window WindowConfig rendering through ``Renderer`` with the
window's GL context, plus the imgui-bundle UI (``skinviewer/ui``). Entry point: ``run_viewer(args)``.

Tests (and scripts) build it in-process with ``create_app(settings, size=(320, 240))`` and drive it
with ``app.step()``, the ``on_mouse_*`` / ``on_key_event`` handlers, and ``app.apply({...})``."""
from __future__ import annotations

import os
import sys
import time
import traceback
from collections import deque
from pathlib import Path
from typing import Any

import moderngl_window as mglw
from moderngl_window.timers.clock import Timer

from skinviewer import techniques
from skinviewer.core.files import save_npy, save_png
from skinviewer.core.renderer import Renderer
from skinviewer.core.settings import Settings, SettingsError, with_values
from skinviewer.core.shaders import ShaderLibrary
from skinviewer.scene.scenes import scene_overrides
from skinviewer.ui import widgets
from skinviewer.ui.camera_control import OrbitController
from skinviewer.ui.compare import CompareState
from skinviewer.ui.display import Display
from skinviewer.ui.hot_reload import ShaderWatcher
from skinviewer.ui.layout import PANEL_DEFAULT_W, Layout, compute_layout
from skinviewer.ui.presets import PresetState
from skinviewer.ui.scheduler import ChangeCost, RenderScheduler
from skinviewer.ui.screenshot import ScreenshotOptions, read_screen, timestamped_path

PREFERRED_TECHNIQUES = ("deon", "gosselin", "phong")
DEFAULT_WINDOW = (1280, 800)
FALLBACK_SCENE = "backlit-ear"
TECHNIQUE_KEYS = ("phong", "gosselin", "deon")  # keys 1 / 2 / 3


def best_technique(preferred: str | None = None) -> str:
    have = techniques.names()
    if preferred and preferred in have:
        return preferred
    return next((t for t in PREFERRED_TECHNIQUES if t in have), have[0])


class ViewerApp(mglw.WindowConfig):
    title = "skinviewer"
    gl_version = (3, 3)
    aspect_ratio = None
    resizable = True
    clear_color = None
    vsync = True

    def __init__(self, settings: Settings | None = None, preset_path: str | None = None,
                 shaders_root: str | Path | None = None, notices: list[str] | None = None, **kwargs):
        super().__init__(**kwargs)
        from imgui_bundle import imgui, implot

        from skinviewer.ui.imgui_backend import ImguiRenderer
        self.imgui_ctx = imgui.create_context()
        imgui.set_current_context(self.imgui_ctx)
        self.implot_ctx = implot.create_context()
        implot.set_current_context(self.implot_ctx)
        io = imgui.get_io()
        io.set_ini_filename("")
        _style()
        self.imgui = ImguiRenderer(self.wnd)

        self.shaders = ShaderLibrary(self.ctx, root=Path(shaders_root) if shaders_root else None)
        self.renderer = Renderer(self.ctx, self.shaders)
        self.display = Display(self.ctx)
        self.orbit = OrbitController()
        self.watcher = ShaderWatcher(self.shaders)
        self.compare = CompareState()
        self.shot_options = ScreenshotOptions()
        self.notices: list[str] = list(notices or [])
        self.errors: list[tuple[str, str]] = []  # last refused edit
        self.error_title = ""
        self.render_error = ""
        self.report = None
        self.inspect: str | None = None  # resource shown full-window
        self.inspect_channel = "RGB"
        self.inspect_exposure = 1.0
        self.frame_ms: deque[float] = deque(maxlen=240)
        self.show_ui = True
        self.vsync_on = bool(getattr(self.wnd, "vsync", True))
        self.frames = 0
        self.screenshots_written: list[Path] = []
        self._pending_shots: list[tuple[Path | None, bool]] = []
        self._buttons: set[int] = set()
        self._drag_owner: str | None = None
        self._drag_moved = False  # the current view drag has moved the camera / light (not a mere click)
        self._shift = False
        self._last_frame_t: float | None = None
        self.ui_rects: list[tuple[float, float, float, float]] = []
        self.last_ms: dict[str, float] = {}  # pass -> ms of its last run (cached passes show it dimmed)
        self._title = ""
        # layout: docked settings column + status bar; the 3D view gets the rest (ui/layout.py)
        self.panel_width = PANEL_DEFAULT_W
        # while the camera is dragged, render the view-dependent passes at a lower resolution when a
        # full-size frame would stutter ("auto"), or at a fixed scale; full size again on release
        self.drag_resolution: str = "auto"
        # a frame whose passes take longer than this is spread over several displayed frames (the UI
        # stays responsive; the image on screen changes once, complete); None: one frame, however long
        self.frame_budget_ms: float | None = 100.0
        self._drag_scaled = False  # the last frame was rendered at the reduced orbit resolution
        self._partial_ran: list = []  # passes that ran in the frames of an unfinished spread frame
        self._rendered: tuple[str, int, int] | None = None  # technique and size of the last main render
        self._pools_trimmed_for: tuple[str, int, int] | None = None
        self.drag_budget_ms = 60.0
        self.panel_side = "left"
        self.layout: Layout = self._compute_layout()
        # render scheduling and cost accounting (ui/scheduler.py)
        self.scheduler = RenderScheduler()
        self.last_change: ChangeCost | None = None
        self._shown: Settings | None = None  # the settings of the image on screen
        self._change_source = "first frame"  # what caused the pending change (settings path, "orbit", ...)
        self._ui_active = False  # an imgui widget is held this frame (slider drag, text edit)
        self._mouse = (0.0, 0.0)
        self.message = ("", False)  # status bar: (text, is_error)

        s = settings or Settings()
        if s.technique not in techniques.names():
            s = with_values(s, {"technique": best_technique(s.technique)})
        vw, vh = self.layout.view_fb[2:]
        s = with_values(s, {"render.width": vw, "render.height": vh})
        s = self._load_initial_scene(s)
        self.settings = s
        self.home_camera = s.camera.model_dump(mode="json")
        self.presets = PresetState(s, preset_path)

        from skinviewer.ui.panel import Panel
        from skinviewer.ui.passes_window import PassesWindow
        from skinviewer.ui.status_bar import StatusBar
        self.panel = Panel(self)
        self.passes_window = PassesWindow(self)
        self.status_bar = StatusBar(self)

    # -- settings ----------------------------------------------------------------------------
    def _load_initial_scene(self, s: Settings) -> Settings:
        try:
            scene = self.renderer.ensure_scene(s)
        except Exception as exc:
            if s.scene.mesh or s.scene.name == FALLBACK_SCENE:
                raise
            self.notices.append(f"scene '{s.scene.name}' is not available ({type(exc).__name__}: {exc}); "
                                f"showing '{FALLBACK_SCENE}' instead")
            s = with_values(s, {"scene.name": FALLBACK_SCENE, **scene_overrides(FALLBACK_SCENE)})
            scene = self.renderer.ensure_scene(s)
        self.notices += scene.notes
        self.orbit.set_scene_bounds(scene.gpu.center, scene.gpu.radius)
        return s

    def apply(self, assignments: dict[str, Any], source: str = "") -> bool:
        """Validate and apply dotted-path assignments. Refused edits leave the state untouched and
        put their (path, message) list in ``self.errors``."""
        if not assignments:
            return True
        try:
            new = with_values(self.settings, assignments)
        except SettingsError as exc:
            self._refuse(exc.errors, source or "invalid setting")
            return False
        return self.set_settings(new, source or ", ".join(assignments))

    def set_settings(self, new: Settings, source: str = "") -> bool:
        if new.technique not in techniques.names():
            self._refuse([("technique", f"'{new.technique}' is not available (have: {', '.join(techniques.names())})")],
                         source or "technique")
            return False
        if Renderer.scene_key(new) != Renderer.scene_key(self.settings) or self.renderer.scene is None:
            try:
                scene = self.renderer.ensure_scene(new)
            except Exception as exc:
                self._refuse([("scene", f"{type(exc).__name__}: {exc}")], source or "scene")
                return False
            self.orbit.set_scene_bounds(scene.gpu.center, scene.gpu.radius)
            self.notices = list(scene.notes)
        if new != self.settings:
            self._change_source = source or "settings"
            self.scheduler.note_change()
        self.settings = new
        self.errors = []
        self.error_title = ""
        return True

    def _refuse(self, errors: list[tuple[str, str]], title: str) -> None:
        self.errors = list(errors)
        self.error_title = title
        if errors:
            path, msg = errors[0]
            self.say(f"refused {title}: {path}: {msg}", error=True)

    def say(self, text: str, error: bool = False) -> None:
        """The status bar's message (errors in red)."""
        self.message = (text, bool(error))

    def select_scene(self, name: str) -> bool:
        ok = self.apply({"scene.name": name, "scene.mesh": None, **scene_overrides(name)}, f"scene {name}")
        if ok:
            self.home_camera = self.settings.camera.model_dump(mode="json")
        return ok

    def load_mesh(self, path: str) -> bool:
        ok = self.apply({"scene.mesh": path or None}, f"mesh {path}")
        if ok:
            self.home_camera = self.settings.camera.model_dump(mode="json")
        return ok

    def set_technique(self, name: str) -> bool:
        self.inspect = None
        ok = self.apply({"technique": name}, "technique")
        if ok:
            self.say(f"technique: {name}")
        return ok

    def save_preset(self, path: str | None = None) -> bool:
        """Save to ``path`` (or the current preset file; none yet: a new timestamped file in presets/)."""
        p = self.presets
        target = path or p.path
        if not target:
            from skinviewer.core import paths
            try:
                target = str(timestamped_path(paths.presets_dir(), prefix="preset", ext=".json"))
            except FileNotFoundError:
                target = str(timestamped_path("presets", prefix="preset", ext=".json"))
        ok = p.save(self.settings, target)
        self.say(p.message, error=not ok)
        return ok

    def reset_camera(self) -> None:
        self.apply({"camera": dict(self.home_camera)}, "camera reset")

    def load_preset(self, path: str) -> bool:
        s = self.presets.load(path, self.settings)
        if s is None:
            errs = self.presets.errors
            self.say(f"refused preset {path}" + (f": {errs[0][0]}: {errs[0][1]}" if errs else ""), error=True)
            return False
        if not self.set_settings(s, f"preset {path}"):
            # refused after loading: the current preset file and its saved baseline stay (Ctrl+S
            # must not write this state over the file that was refused)
            self.presets.refused(path, self.errors)
            return False
        self.presets.accepted(self.settings, path)
        self.home_camera = self.settings.camera.model_dump(mode="json")
        self.say(f"loaded preset {path}")
        return True

    def set_vsync(self, on: bool) -> None:
        self.vsync_on = bool(on)
        try:
            self.wnd._set_vsync(self.vsync_on)
        except Exception:
            pass

    # -- frame -------------------------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        """Render ``n`` complete frames (render, UI, swap): for tests and --frames."""
        for _ in range(n):
            self.wnd.use()
            self.on_render(time.perf_counter(), 1 / 60)
            self.wnd.swap_buffers()

    def _compute_layout(self) -> Layout:
        return compute_layout(self.wnd.size, self.wnd.buffer_size, self.show_ui, self.panel_width, self.panel_side)

    def _sync_size(self) -> None:
        """The render size follows the 3D view region (framebuffer pixels), not the whole window."""
        self.layout = self._compute_layout()
        vw, vh = self.layout.view_fb[2:]
        scale = self.drag_scale()
        if scale < 1.0:
            vw, vh = max(16, int(vw * scale)), max(16, int(vh * scale))
        if (vw, vh) != (self.settings.render.width, self.settings.render.height):
            try:
                self.settings = with_values(self.settings, {"render.width": vw, "render.height": vh})
                if not self._change_source:
                    self._change_source = ("camera (orbit at reduced resolution)" if scale < 1.0 else
                                           "camera (orbit done: full resolution)" if self._drag_scaled else
                                           "render size")
            except SettingsError:
                pass
        self._drag_scaled = scale < 1.0

    def drag_scale(self) -> float:
        """Resolution scale of the view while the camera is dragged (1 when not dragging)."""
        if self._drag_owner != "view" or not self._drag_moved or not self._buttons or self.drag_resolution == "full":
            return 1.0
        if self.drag_resolution != "auto":
            return float(self.drag_resolution)
        g = self.renderer.graphs.get(self.settings.technique)
        if g is None or g.last_report is None:
            return 1.0
        full = self.layout.view_fb[2] * self.layout.view_fb[3]
        now = max(self.settings.render.width * self.settings.render.height, 1)
        # the view-dependent cost at full size, scaled from the size it was last measured at
        ms = g.predicted_ms(g.affected([], camera=True)) * full / now
        if ms <= self.drag_budget_ms:
            return 1.0
        return max(0.25, min(1.0, (self.drag_budget_ms / ms) ** 0.5))  # cost ~ pixels

    def on_render(self, t: float, frametime: float) -> None:
        now = time.perf_counter()
        if self._last_frame_t is not None:
            self.frame_ms.append((now - self._last_frame_t) * 1000.0)
        self._last_frame_t = now
        self.frames += 1
        self.watcher.poll()
        # the UI is built first: this frame's edits (and panel resizes) are rendered this frame;
        # the panel shows the previous frame's report (identical on idle frames)
        ui_built = False
        if self.show_ui:
            ui_built = self._build_ui(frametime)
        self._sync_size()

        self.report = self._render_main()
        if self.report is not None and self.report.complete and not self.report.ran:
            self.renderer.warm(self.settings.technique, budget_ms=30.0)  # idle: likely shader variants
        self._draw_view(self.layout.view_fb)
        self.watcher.refresh_errors()
        self._trim_texture_pools()

        self._take_shots(include_ui=False)
        if ui_built:
            self._present_ui()
        self._take_shots(include_ui=True)
        self._update_title()

    def _update_title(self) -> None:
        name = Path(self.presets.path).name if self.presets.path else "untitled"
        title = f"skinviewer - {name}{' *' if self.presets.dirty(self.settings) else ''} - {self.settings.technique}"
        if title != self._title:
            self._title = title
            try:
                self.wnd.title = title
            except Exception:
                pass

    @property
    def render_deferred(self) -> bool:
        """The image on screen is older than the settings (an expensive slider drag is in progress)."""
        return self.scheduler.deferred

    def _render_main(self):
        pending = self._shown is None or (self._shown is not self.settings and self._shown != self.settings)
        last_cost = self.last_change.total_ms if self.last_change else None
        # a spread frame in progress is finished first, whatever the scheduler says
        defer = not self._partial_ran and self._shown is not None \
            and self.scheduler.should_defer(pending, self._ui_active, last_cost) \
            and not self._scene_changed(self._shown)
        self.scheduler.deferred = defer
        target = self._shown if defer else self.settings
        try:
            report = self.renderer.render(target, budget_ms=self.frame_budget_ms)
            self.render_error = ""
            self._rendered = (target.technique, target.render.width, target.render.height)
        except Exception as exc:
            self.render_error = f"{type(exc).__name__}: {exc}"
            self.say(f"render: {self.render_error.splitlines()[0]}", error=True)
            if "--debug" in sys.argv:
                traceback.print_exc()
            self._shown = self.settings  # do not retry a failing state every frame while deferring
            self._partial_ran = []  # a spread frame that failed is not resumed (nor merged into the next)
            return None
        if defer:
            return report
        if not report.complete:
            self._partial_ran += [p for p in report.passes if p.status == "ran"]
            return report
        if self._partial_ran:
            report = self._merge_partial(report)
        for p in report.passes:
            if p.status == "ran" and p.ms is not None:
                self.last_ms[p.name] = p.ms
        if report.ran or self._change_source == "technique":  # a cached technique switch costs 0 ms: say so
            self._record_change(report)
        self._shown = self.settings
        self._change_source = ""
        return report

    def _scene_changed(self, s: Settings) -> bool:
        """The loaded scene is not the one of ``s``: set_settings has already loaded the new one, and
        rendering ``s`` (the image on screen, while a deferred edit waits) would load it back."""
        scene = self.renderer.scene
        return scene is None or scene.key != Renderer.scene_key(s)

    def _trim_texture_pools(self) -> None:
        """Give the free textures of the render pools back to GL when the render size (or the
        technique) changed: a pool keeps every texture handed back to it, keyed by size, so each
        window or panel resize and each orbit resolution used to leave a full set of view-sized
        textures behind for the rest of the session. Textures in use (every graph's cache) stay."""
        if self._rendered == self._pools_trimmed_for:
            return
        if self._pools_trimmed_for is not None:
            for r in (self.renderer, self.compare.a.renderer, self.compare.b.renderer):
                if r is not None:
                    r.trim()
        self._pools_trimmed_for = self._rendered

    def _merge_partial(self, report):
        """One report for a frame spread over several: the passes that ran in any of them."""
        from skinviewer.core.graph import FrameReport
        ran = {p.name: p for p in self._partial_ran}
        self._partial_ran = []
        passes = [p if p.status == "ran" else ran.get(p.name, p) for p in report.passes]
        return FrameReport(report.frame, report.timing_mode, passes)

    def view_passes(self, technique: str | None = None) -> set[str]:
        """Names of the view-dependent passes of a technique and everything downstream of them."""
        from skinviewer.ui.scheduler import view_side
        tech = technique or self.settings.technique
        g = self.renderer.graph(tech)
        vd = {p.name for p in g.passes if p.view_dependent}
        rep = self.report
        if rep is None:
            return vd
        return view_side(rep, vd)

    def _record_change(self, report) -> None:
        from skinviewer.ui.scheduler import split_ms, view_side
        g = self.renderer.graph(self.settings.technique)
        vset = view_side(report, {p.name for p in g.passes if p.view_dependent})
        tex, view = split_ms(report, vset, lambda p: p.ms if p.status == "ran" else None)
        ran = sorted(((p.name, p.ms or 0.0) for p in report.passes if p.status == "ran"), key=lambda x: -x[1])
        self.last_change = ChangeCost(self._change_source or "frame", report.total_ms, tex, view, ran,
                                      report.timing_mode, time.time())

    def _render_slot(self, slot):
        if slot.renderer is None:
            slot.renderer = Renderer(self.ctx, self.shaders)
        try:
            s = self.compare.frame_settings(slot, self.settings)
            slot.renderer.render(s)
            slot.error = ""
            return slot.renderer.graph(s.technique).texture("image")
        except Exception as exc:
            slot.error = f"{type(exc).__name__}: {exc}"
            return None

    def _draw_view(self, viewport) -> None:
        ctx = self.ctx
        ctx.screen.use()
        ctx.viewport = (0, 0, *self.layout.framebuffer)
        bg = self.settings.render.background
        ctx.clear(*bg, 1.0)
        ctx.viewport = viewport
        cmp = self.compare
        if cmp.mode != "off" and cmp.ready():
            if cmp.mode == "toggle":
                tex = self._render_slot(cmp.b if cmp.show_b else cmp.a)
                if tex is not None:
                    self.display.show(tex, viewport)
                return
            ta, tb = self._render_slot(cmp.a), self._render_slot(cmp.b)
            if ta is not None and tb is not None:
                if cmp.mode == "split":
                    self.display.split(ta, tb, viewport, cmp.divider)
                else:
                    self.display.difference(ta, tb, viewport, cmp.diff_gain)
            return
        g = self.renderer.graph(self.settings.technique) if self.settings.technique in techniques.names() else None
        if g is None:
            return
        if self.inspect is not None:
            spec = g.resources().get(self.inspect)
            if spec is not None:
                self.display.inspect(g.texture(self.inspect), viewport, self.inspect_channel,
                                     self.inspect_exposure, spec.components)
                return
        if "image" in g.resources():
            self.display.show(g.texture("image"), viewport)

    def _cost_hint(self, path: str) -> str:
        """What editing ``path`` re-runs in the current technique and what that cost last time."""
        g = self.renderer.graphs.get(self.settings.technique)
        if g is None or g.last_report is None:
            return ""
        passes = g.affected([path])
        if not passes:
            return "editing it re-runs no pass of this technique"
        return (f"editing it re-runs {len(passes)} pass(es), ~{g.predicted_ms(passes):.0f} ms last measured "
                f"({g.last_report.timing_mode} timing): {', '.join(passes)}")

    def _build_ui(self, frametime: float) -> bool:
        """Run the imgui frame (widgets apply their edits to the settings); drawn by _present_ui."""
        from imgui_bundle import imgui
        imgui.set_current_context(self.imgui_ctx)
        io = imgui.get_io()
        io.delta_time = max(float(frametime), 1e-4)
        ww, wh = self.wnd.size
        fw, fh = self.wnd.buffer_size
        io.display_size = imgui.ImVec2(float(ww), float(wh))
        io.display_framebuffer_scale = imgui.ImVec2(fw / max(ww, 1), fh / max(wh, 1))
        self.layout = self._compute_layout()
        imgui.new_frame()
        self.ui_rects = []
        state = imgui.internal.ErrorRecoveryState()
        imgui.internal.error_recovery_store_state(state)
        widgets.cost_hint = self._cost_hint
        try:
            self.panel.draw()
            self.status_bar.draw()
            self.passes_window.draw()
        except Exception as exc:  # a UI bug must not take the session down
            self.render_error = f"UI: {type(exc).__name__}: {exc}"
            self.say(self.render_error, error=True)
            traceback.print_exc()
            imgui.internal.error_recovery_try_to_recover_state(state)
        self._ui_active = bool(imgui.is_any_item_active())
        imgui.render()
        return True

    def _present_ui(self) -> None:
        from imgui_bundle import imgui
        imgui.set_current_context(self.imgui_ctx)
        self.ctx.screen.use()
        self.imgui.render(imgui.get_draw_data())

    # -- screenshots -------------------------------------------------------------------------
    def request_screenshot(self, path: str | Path | None = None, include_ui: bool | None = None) -> Path:
        """Queue a screenshot of the next frame; returns its path (timestamped when not given)."""
        p = Path(path) if path else timestamped_path(self.shot_options.folder)
        inc = self.shot_options.include_ui if include_ui is None else include_ui
        self._pending_shots.append((p, bool(inc and self.show_ui)))
        return p

    def _take_shots(self, include_ui: bool) -> None:
        todo = [x for x in self._pending_shots if x[1] == include_ui]
        if not todo:
            return
        self._pending_shots = [x for x in self._pending_shots if x[1] != include_ui]
        # without UI: the 3D view region only; with UI: the whole framebuffer
        if include_ui:
            img = read_screen(self.ctx, self.layout.framebuffer)
        else:
            img = read_screen(self.ctx, self.layout.view_fb[2:], origin=self.layout.view_fb[:2])
        for path, _ in todo:
            try:
                save_png(path, img)
                self.screenshots_written.append(path)
                self.say(f"screenshot: {path} ({img.shape[1]}x{img.shape[0]}{', with UI' if include_ui else ''})")
                if self.shot_options.save_linear_npy:
                    g = self.renderer.graph(self.settings.technique)
                    res = "lit" if "lit" in g.resources() else "image"
                    save_npy(path.with_suffix(".npy"), g.read(res)[::-1])
            except Exception as exc:
                self._refuse([("screenshot", f"{type(exc).__name__}: {exc}")], f"screenshot {path}")

    # -- input -------------------------------------------------------------------------------
    def _over_ui(self, x: float, y: float) -> bool:
        """True over the docked panel / status bar (outside the 3D view) or a floating UI window."""
        if not self.show_ui:
            return False
        if not self.layout.in_view(x, y):
            return True
        for (rx, ry, rw, rh) in self.ui_rects:
            if rx <= x <= rx + rw and ry <= y <= ry + rh:
                return True
        try:
            from imgui_bundle import imgui
            return bool(imgui.get_io().want_capture_mouse) and self._drag_owner == "ui"
        except Exception:
            return False

    def _view_fraction(self, x: float) -> float:
        vx, _, vw, _ = self.layout.view
        return float(min(1.0, max(0.0, (x - vx) / max(vw, 1.0))))

    def _near_divider(self, x: float) -> bool:
        cmp = self.compare
        vx, _, vw, _ = self.layout.view
        return cmp.mode == "split" and cmp.ready() and abs(x - (vx + cmp.divider * vw)) < 8

    def on_mouse_position_event(self, x, y, dx, dy):
        self._mouse = (float(x), float(y))
        self.imgui.mouse_position_event(x, y, dx, dy)

    def on_mouse_press_event(self, x, y, button):
        self._mouse = (float(x), float(y))
        self.imgui.mouse_press_event(x, y, button)
        self._buttons.add(button)
        if self._drag_owner is None:
            if self._over_ui(x, y):
                self._drag_owner = "ui"
            elif button == self.wnd.mouse.left and self._near_divider(x):
                self._drag_owner = "divider"
            else:
                self._drag_owner = "view"
                self._drag_moved = False

    def on_mouse_release_event(self, x, y, button):
        self.imgui.mouse_release_event(x, y, button)
        self._buttons.discard(button)
        if not self._buttons:
            self._drag_owner = None

    def on_mouse_drag_event(self, x, y, dx, dy):
        self._mouse = (float(x), float(y))
        self.imgui.mouse_drag_event(x, y, dx, dy)
        if self._drag_owner == "divider":
            self.compare.divider = self._view_fraction(x)
            return
        if self._drag_owner != "view":
            return
        self._drag_moved = True
        m = self.wnd.mouse
        shift = self._shift or bool(getattr(self.wnd.modifiers, "shift", False))
        s = self.settings
        if m.middle in self._buttons or (m.left in self._buttons and shift):
            self.apply(self.orbit.pan(s, dx, dy, self.layout.view[3]), "camera (pan)")
        elif m.left in self._buttons:
            self.apply(self.orbit.orbit(s, dx, dy), "camera (orbit)")
        elif m.right in self._buttons:
            self.apply(self.orbit.move_light(s, 0, dx, dy), "lights.0 (key light drag)")

    def on_mouse_scroll_event(self, x_offset, y_offset):
        self.imgui.mouse_scroll_event(x_offset, y_offset)
        if self._over_ui(*self._mouse):
            return
        from imgui_bundle import imgui
        if self.show_ui and imgui.get_io().want_capture_mouse:
            return
        self.apply(self.orbit.zoom(self.settings, y_offset), "camera (zoom)")

    def on_key_event(self, key, action, modifiers):
        self.imgui.key_event(key, action, modifiers)
        keys = self.wnd.keys
        self._shift = bool(getattr(modifiers, "shift", False))
        if key in _shift_keys(keys) and action in (keys.ACTION_PRESS, keys.ACTION_RELEASE):
            # X11 reports the modifiers from before the event: a Shift release still says "shift",
            # which left shift+left-drag panning stuck on after Shift was let go
            self._shift = action == keys.ACTION_PRESS
        if action != keys.ACTION_PRESS:
            return
        ctrl = bool(getattr(modifiers, "ctrl", False))
        # function keys and Ctrl+S work even while a text field has the keyboard
        if key == keys.F12:
            self.request_screenshot()
            return
        if key == keys.F1:
            self.show_ui = not self.show_ui
            return
        if ctrl and key == keys.S:
            self.save_preset()
            return
        from imgui_bundle import imgui
        if self.show_ui and imgui.get_io().want_capture_keyboard:
            return
        tech_keys = {keys.NUMBER_1: 0, keys.NUMBER_2: 1, keys.NUMBER_3: 2,
                     getattr(keys, "NUMPAD_1", -1): 0, getattr(keys, "NUMPAD_2", -1): 1, getattr(keys, "NUMPAD_3", -1): 2}
        if key == keys.R:
            self.reset_camera()
            self.say("camera reset (R)")
        elif key in tech_keys and not ctrl:
            self.set_technique(TECHNIQUE_KEYS[tech_keys[key]])
        elif key == keys.SPACE and self.compare.mode != "off":
            if self.compare.mode != "toggle":
                self.compare.mode = "toggle"
            else:
                self.compare.show_b = not self.compare.show_b
            self.say(f"A/B: showing {'B' if self.compare.show_b else 'A'}")
        elif key == keys.ESCAPE and self.inspect is not None:
            self.inspect = None

    def on_unicode_char_entered(self, char):
        self.imgui.unicode_char_entered(char)

    def on_resize(self, width, height):
        self.imgui.resize(width, height)

    # -- teardown ----------------------------------------------------------------------------
    def close(self) -> None:
        from imgui_bundle import imgui, implot
        self.compare.release()
        self.renderer.release()
        self.shaders.release()
        self.display.release()
        try:
            self.imgui.shutdown()
        except Exception:
            pass
        implot.destroy_context(self.implot_ctx)
        imgui.destroy_context(self.imgui_ctx)


def _shift_keys(keys) -> set:
    codes = {getattr(keys, n, None) for n in ("LEFT_SHIFT", "RIGHT_SHIFT")}
    try:
        import glfw
        if keys.__module__.startswith("moderngl_window.context.glfw"):
            codes |= {glfw.KEY_LEFT_SHIFT, glfw.KEY_RIGHT_SHIFT}
    except Exception:
        pass
    codes.discard(None)
    return codes


def _style() -> None:
    from imgui_bundle import imgui
    imgui.style_colors_dark()
    st = imgui.get_style()
    st.window_rounding = 4.0
    st.frame_rounding = 3.0
    st.grab_rounding = 3.0
    st.item_spacing = imgui.ImVec2(6, 4)
    st.set_color_(imgui.Col_.window_bg.value, imgui.ImVec4(0.08, 0.08, 0.09, 0.92))


class WindowUnavailableError(RuntimeError):
    """No window could be opened (no display, no OpenGL 3.3 driver)."""


def create_window(size: tuple[int, int] = DEFAULT_WINDOW, visible: bool = True, vsync: bool = True,
                  backend: str = "glfw"):
    """A moderngl-window window (glfw by default; pyglet as a fallback) with a GL 3.3 core context."""
    import warnings
    errors = []
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")) and sys.platform.startswith("linux"):
        errors.append("no DISPLAY or WAYLAND_DISPLAY")
    else:
        for name in ([backend] + [b for b in ("glfw", "pyglet") if b != backend]):
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")  # glfw reports its init failure as a warning too
                    cls = mglw.get_local_window_cls(name)
                    wnd = cls(title="skinviewer", size=tuple(size), resizable=True, visible=visible,
                              gl_version=(3, 3), aspect_ratio=None, vsync=vsync, samples=0, cursor=True)
                mglw.activate_context(window=wnd)
                # moderngl-window closes the window on Escape by default: that quit the session (unsaved
                # edits and all) when Escape was meant for a text field or for leaving the pass inspector
                wnd.exit_key = None
                return wnd
            except Exception as exc:
                errors.append(f"{name}: {exc}")
    raise WindowUnavailableError(
        "cannot open a window (" + "; ".join(errors) + "). Without a display run it under Xvfb: "
        "xvfb-run -a -s '-screen 0 1280x800x24' skinviewer ...; headless renders: skinviewer render --out FILE.png")


def create_app(settings: Settings | None = None, size: tuple[int, int] = DEFAULT_WINDOW, visible: bool = True,
               vsync: bool = True, preset_path: str | None = None, shaders_root=None,
               notices: list[str] | None = None) -> ViewerApp:
    wnd = create_window(size, visible=visible, vsync=vsync)
    app = ViewerApp(settings=settings, preset_path=preset_path, shaders_root=shaders_root, notices=notices,
                    ctx=wnd.ctx, wnd=wnd, timer=Timer())
    wnd.swap_buffers()
    wnd.set_default_viewport()
    return app


def destroy_app(app: ViewerApp) -> None:
    wnd = app.wnd
    app.close()
    try:
        wnd.destroy()
    except Exception:
        pass


def run_viewer(args) -> int:
    """``skinviewer [view]``: open the window; with --frames N render N frames and exit
    (writing --screenshot FILE after the last one)."""
    from skinviewer.cli.args import CliError, settings_from_args
    s = settings_from_args(args)
    if getattr(args, "technique", None) and args.technique not in techniques.names():
        raise CliError(f"technique '{args.technique}' is not available (have: {', '.join(techniques.names())})")
    if not getattr(args, "technique", None):
        preset_tech = s.technique
        s = with_values(s, {"technique": best_technique(preset_tech)})
    if args.screenshot and not args.frames:
        args.frames = 1
    size = tuple(args.size) if args.size else DEFAULT_WINDOW
    app = create_app(s, size=size, preset_path=args.preset)
    if args.frames and args.screenshot:
        app.show_ui = False  # batch screenshot: the 3D view fills the whole --size window
    for n in app.notices:
        print(f"note: {n}", file=sys.stderr)
    wnd = app.wnd
    try:
        app.timer.start()
        while not wnd.is_closing:
            if args.frames and args.screenshot and app.frames == args.frames - 1:
                app.request_screenshot(args.screenshot, include_ui=False)
            app.step()
            if args.frames and app.frames >= args.frames:
                break
        if args.screenshot:
            if not app.screenshots_written:
                print(f"skinviewer: no screenshot written ({app.render_error or 'no frame'})", file=sys.stderr)
                return 2
            print(f"wrote {args.screenshot}")
        if app.render_error and args.frames:
            print(f"skinviewer: {app.render_error}", file=sys.stderr)
            return 2
        return 0
    finally:
        destroy_app(app)
