"""The frame controller: what to render this frame and how it gets on screen.

Each frame (``run``): poll shader hot reload, build the UI (the windows' edits reach the state
this frame), make the render size follow the 3D view (lower while the camera is dragged on slow
GL), render the state's settings through the pass graph — unless the scheduler defers an expensive
edit while a widget is held, or a frame longer than the time budget is spread over several
displayed frames — then put the image (or the inspected pass output, or the A/B compare) in the
view, give unused pool textures back, take queued screenshots and draw the UI on top.

It owns the renderer's frame products (report, per-pass costs, the last change's cost) and the
time-budget options; the state owns what the user chose."""
from __future__ import annotations

import time
import traceback
from collections import deque
from pathlib import Path
from typing import Any, Protocol

from skinviewer import techniques
from skinviewer.engine.renderer import Renderer
from skinviewer.ground.files import save_exr, save_image, save_npy
from skinviewer.ground.settings import Settings
from skinviewer.kernel.graph import FrameReport
from skinviewer.kernel.shaders import ShaderLibrary
from skinviewer.techniques.preview import FINAL, Rung
from skinviewer.ui.collector import Collector
from skinviewer.ui.governor import BackgroundCalibration, Governor
from skinviewer.ui.hot_reload import ShaderWatcher
from skinviewer.ui.layout import Layout, compute_layout
from skinviewer.ui.scheduler import MODES as SCHEDULE_MODES
from skinviewer.ui.scheduler import ChangeCost, RenderScheduler, RunningCost, split_ms, view_side
from skinviewer.ui.screenshot import read_screen, timestamped_path
from skinviewer.ui.state import ViewerState
from skinviewer.ui.view import ViewPresenter
from skinviewer.ui.warm import Primer, preview_variant

DRAG_RESOLUTIONS = ("auto", "full", "0.5", "0.25")
# the render graph's share of what is left of a frame's budget before the whole frame was measured
# (frames driven without ViewerApp.step, which reports each frame's end): the rest of the frame (UI,
# presenting) is then a running mean of the interval less the render, off by several ms a frame here
GRAPH_SHARE = 0.9
# False: the budgeting before the whole frame was (bench_interaction.py --whole-frame both, an A/B): the
# graph's share GRAPH_SHARE of the budget less the rest of a frame's running mean, a render-only frame
# GRAPH_SHARE of the budget, and a still view's refinement re-presenting the screen every REFRESH_S
WHOLE_FRAME = True
REFRESH_S = 0.5
# the governor fits a rung to the budget at the render graph's p99 margin (Governor.set_margin) when True;
# False (the default): at its own FIT_MARGIN only. In the lead's quiet A/B (notes/governor.md, session 10) the
# margin made the cheap techniques drag a preview they did not need (Phong at view 1/2: release -> final 0.17 ->
# 1.58x, Penner 1.24 -> 2.48x) for no longest-frame gain (3 / 6 rows within 100 ms either way)
GOVERNOR_MARGIN = False
# issue 27, session 11: the render pools are trimmed when the *view's* size (or the technique) changes, not the
# rendered size: a drag's smaller view (a governor rung's scale, the orbit resolution) keeps the full size's
# free textures for the release. Trimmed at every rendered size, the release frame allocated the full-size set
# again (16 textures for ssss: 96-236 ms of the graph's own time in one frame, the longest frames and 10-25 %
# of release -> final here). False: trimmed at every rendered size (the rule before; A/B)
KEEP_VIEW_POOLS = True
# issue 27, session 12: the frame of a release (a drag or a held widget let go, a governed preview on screen) only
# renders: nothing on screen changes until the refinement's image is complete, so it gets the render-only budget
# (the budget less the event poll: ~97 ms, not ~75 less the UI and the swap) and presents with the UI only when it
# completes it (a final that fits one frame -- Phong's ~65 ms -- is then on screen in that frame, not in the next);
# the release's own input events do not make the frames after it present. False: the release frame presents
# (the rule before; bench_interaction.py --frame-rules both)
RELEASE_RENDERS_FIRST = True


# the orbit resolutions the automatic drag scale takes (half-octaves of pixels): a continuous scale made each drag
# a new render size, and with KEEP_VIEW_POOLS each size's free textures would stay pooled until the view resized
DRAG_STEPS = (1.0, 0.5 ** 0.5, 0.5, 0.5 ** 1.5, 0.25)


def drag_step(scale: float) -> float:
    """The largest of DRAG_STEPS not above ``scale`` (a drag is never dearer than its budget asked)."""
    return next((s for s in DRAG_STEPS if s <= scale + 1e-9), DRAG_STEPS[-1])


class UiLayer(Protocol):
    """What the frame needs of the UI (``ui.windows.UiHost``)."""

    def build(self, frametime: float, layout: Layout) -> bool: ...

    def present(self) -> None: ...

    def view_hooks(self) -> list: ...


def calibration_note(why: str, have: bool, cached: bool, auto: bool, governor_on: bool, machine: str) -> str:
    """The status line about the governor's calibration (issue 34), true in every case: the engine's
    reason (``why``: "... measuring ...", "... rebuilding it") holds only when a measurement will run,
    i.e. with ``auto`` (not SKINVIEWER_CALIBRATE=0, not a scripted --frames run) and the governor on
    (a technique is measured when the governor first shows it). ``have``: a calibration was loaded;
    ``cached``: it is this machine's own (else the table shipped for this GL renderer)."""
    if auto:  # the governor off: nothing is measured until it is turned on (then "calibrating k/n")
        return why if governor_on else ""
    if have:
        source = "this machine's measurements" if cached else "the table shipped for this GL renderer"
        stale = "; techniques made for other preview ladders are not measured again" if why else ""
        return f"calibration off: the governor's budget from {source}{stale}"
    # what it means first (a 960x600 status bar cuts the rest, shown in full in its tooltip)
    return (f"calibration off: no preview budget, edits show your settings (no calibration for {machine}, "
            "none will be measured; skinviewer calibrate measures one)")


class FrameController:
    def __init__(self, ctx, state: ViewerState, renderer: Renderer, shaders: ShaderLibrary,
                 window_size: tuple[int, int], buffer_size: tuple[int, int]):
        self.ctx = ctx
        self.state = state
        self.renderer = renderer
        self.shaders = shaders
        self.view = ViewPresenter(ctx, state, shaders)
        self.watcher = ShaderWatcher(shaders)
        self.scheduler = RenderScheduler()
        self.report: FrameReport | None = None
        self.last_change: ChangeCost | None = None
        self.last_ms: dict[str, float] = {}  # pass -> ms of its last run (cached passes show it dimmed)
        self.frame_ms: deque[float] = deque(maxlen=240)
        self.frames = 0
        self.render_error = ""
        self.screenshots_written: list[Path] = []
        # a frame whose passes take longer than this is spread over several displayed frames (the UI
        # stays responsive; the image on screen changes once, complete); None: one frame, however long
        self.frame_budget_ms: float | None = 100.0
        # while the camera is dragged, render the view-dependent passes at a lower resolution when a
        # full-size frame would stutter ("auto"), or at a fixed scale; full size again on release
        self.drag_resolution = "auto"
        self.drag_budget_ms = 60.0
        self._pending_shots: list[tuple[Path, bool]] = []
        self._dragging = False  # the camera is being dragged in the view (input controller)
        self._drag_scaled = False  # the last frame was rendered at the reduced orbit resolution
        self._widget_active = False  # an imgui widget is held this frame (slider drag, text edit)
        self._partial_ran: list = []  # passes that ran in the frames of an unfinished spread frame
        self._rendered: tuple[str, int, int] | None = None  # technique and size of the last main render
        self._pools_trimmed_for: tuple[str, int, int] | None = None
        self._pool_key: tuple[str, int, int] | None = None  # what the pools are trimmed by (_trim_texture_pools)
        self._shown: Settings | None = None  # the settings of the image on screen
        self._change_source = "first frame"  # what caused the pending change (settings path, "orbit", ...)
        self._last_frame_t: float | None = None
        # what a frame costs besides the render graph (the UI, the view, presenting it; llvmpipe
        # under Xvfb: tens of ms): the graph gets the frame budget less this, so a whole frame fits
        self._render_ms: float | None = None  # the last frame's graph time (wall clock)
        self.overhead_ms: float | None = None  # running mean of the rest of the frame
        # the render graph's own time in a governed preview frame (reflect, scene rules, cache keys:
        # RenderGraph.own_ms), a running mean: the governor's pick leaves room for it beside the
        # passes' cost it observes (issue 27: 25-60 ms of a d'Eon preview frame was this)
        self.graph_own_ms: float | None = None
        self.last_own_ms = 0.0  # the graph's own time in the last frame's render (any frame)
        self.last_graph: Any = None  # the graph the last frame rendered in
        self.last_budget_ms: float | None = None  # the budget the last frame's render was given
        self.quiet_frames = True  # a refinement in progress renders without presenting (can_skip_present)
        self._presented_at = 0.0
        # the whole frame kept to the budget (issue 27): what a frame spends before its render (the UI
        # built, the governor), measured in the frame itself; what it spends after (the view, the UI
        # drawn, the buffer swap -- presenting under Xvfb is 7-40 ms here -- or, for a frame that only
        # renders, the event poll), a running estimate of each from ViewerApp.step's frame_end; and the
        # renderer's own work around the graph (the frame's view, the mesh level)
        self._frame_t0: float | None = None  # when this frame began (None: outside a frame)
        self._render_end: float | None = None  # when this frame's render returned
        self._after_extra = 0.0  # ms this frame spent after its render on idle work (priming, warm-up)
        self.before = RunningCost(cap=1000.0)
        self.after_present = RunningCost(cap=1000.0)
        self.after_quiet = RunningCost(cap=1000.0)
        self.render_extra = RunningCost(cap=1000.0)
        self._last_presented = True
        self._window: tuple[tuple[int, int], tuple[int, int]] = (
            (window_size[0], window_size[1]), (buffer_size[0], buffer_size[1]))
        # the quality governor (issue 27): what each frame renders while the user drags, and the
        # refinement to the user's settings after; its calibration is loaded or measured on start
        r = state.settings.render
        self.governor = Governor(r.governor, r.governor_budget_ms)
        self.calibrating: BackgroundCalibration | None = None
        self._auto_calibrate = False  # measure techniques the calibration lacks (run_viewer turns it on)
        self._calibration_tried: set[str] = set()
        self._rung: Rung = FINAL
        self._governing = False  # the governor picks this frame (on, and this technique calibrated)
        self._variant = ""  # the renderer graph of the frame: "" the user's settings, else a preview's
        self._camera_input = False  # the last user change moved only the camera
        self._released = False  # a drag or held widget was let go since the last change: input has stopped
        # RELEASE_RENDERS_FIRST: a drag or held widget was let go since the last frame (the next frame only renders),
        # and the input events up to that release (None: none held back; a frame that presents clears it)
        self._let_go = False
        self._release_events: int | None = None
        self._interacting = False  # this frame renders the governor's interaction pick
        # a governed frame started during a drag or edit and part-way through (spread over frames):
        # (settings, variant, rung); it is finished before newer input is taken, so a drag always
        # gets complete images (a refinement frame, started while still, is abandoned instead)
        self._inflight: tuple[Settings, str, Rung] | None = None
        self._partial_variant = ""  # the graph of the unfinished frame whose passes _partial_ran lists
        self._partial_rung: Rung = FINAL  # and its rung (two rungs may share a graph: a smaller view of yours)
        # Python's garbage collector: young generations only while busy, frozen start-up objects
        # (ui/collector.py; a full collection took 33 ms of a drag's frame)
        self.collector = Collector()
        # the idle frames' priming of the next drag's preview variants (ui/warm.py)
        self.primer = Primer(renderer)
        self._gov_note = ""
        # issue 34, the cold start: the technique whose first image is the ladder's declared cheapest
        # rung even without a calibration (start_with_preview), and that rung once picked
        self._cold_start: str | None = None
        self._cold_rung: Rung | None = None
        self.layout: Layout = self._compute_layout()
        state.set_render_size(*self.layout.view_fb[2:])
        state.subscribe(self._on_change)

    # -- options (the panel edits them through these) ---------------------------------------
    def set_frame_budget(self, ms: float | None) -> None:
        self.frame_budget_ms = None if ms is None else max(float(ms), 1e-6)

    def graph_budget_ms(self, present: bool = True) -> float | None:
        """The render graph's share of the frame budget, so that the *whole* frame keeps to it (issue
        27): the budget less what this frame spent before its render (measured now, inside a frame;
        else its running mean), less what the rest of a frame costs here after it -- the view, the UI
        drawn and the buffer swap for a frame that presents (``present``), the event poll for one that
        only renders -- and the renderer's own work around the graph, each at its running estimate's
        upper bound (RunningCost.upper: mean + 2 deviations or the largest of the last 20, so a swap
        that spikes is budgeted, not averaged). At least 30 %
        of the budget. Before any frame was measured whole: GRAPH_SHARE of the budget less the rest of
        a frame's running mean. None: no budget (one frame, however long)."""
        fb = self.frame_budget_ms
        if fb is None:
            return None
        after = (self.after_present if present else self.after_quiet).upper() if WHOLE_FRAME else None
        if after is None:
            rest = (self.overhead_ms or 0.0) if present else 0.0
            return max(0.3 * fb, GRAPH_SHARE * (fb - rest))
        if self._frame_t0 is not None:
            before = (time.perf_counter() - self._frame_t0) * 1000.0
        elif not present:
            before = 0.0  # a frame that only renders builds no UI
        else:
            before = self.before.mean or 0.0
        return max(0.3 * fb, fb - before - after - (self.render_extra.upper() or 0.0))

    def frame_rest_ms(self) -> float:
        """What a presenting frame costs here besides its render graph's passes' own budget: before
        its render (mean), after it (upper bound) and the renderer's work around the graph (upper
        bound); the running mean of the interval less the render until a frame was measured whole."""
        after = self.after_present.upper() if WHOLE_FRAME else None
        if after is None:
            return self.overhead_ms or 0.0
        return (self.before.mean or 0.0) + after + (self.render_extra.upper() or 0.0)

    def frame_end(self) -> None:
        """ViewerApp.step, once the frame is on screen (after the buffer swap) or, for a frame that
        only rendered, after the event poll: what this frame cost after its render, a sample of the
        running estimate its kind of frame budgets for (graph_budget_ms)."""
        end, self._render_end = self._render_end, None
        self._frame_t0 = None
        if end is None:
            return
        after = (time.perf_counter() - end) * 1000.0 - self._after_extra
        (self.after_present if self._last_presented else self.after_quiet).add(after)
        if WHOLE_FRAME:
            self.overhead_ms = self.frame_rest_ms()

    def set_drag_resolution(self, mode: str) -> None:
        if mode in DRAG_RESOLUTIONS:
            self.drag_resolution = mode

    def set_drag_budget(self, ms: float) -> None:
        self.drag_budget_ms = float(ms)

    def set_schedule(self, mode: str | None = None, budget_ms: float | None = None) -> None:
        self.scheduler.configure(mode if mode in SCHEDULE_MODES else None, budget_ms)

    def set_dragging(self, on: bool) -> None:
        """The input controller: the camera is being dragged in the view (a move, not a mere click)."""
        if self._dragging and not on:
            self._released = True  # the refinement starts now, not after the scheduler's rest
            self._let_go = True
        self._dragging = bool(on)

    def set_widget_active(self, on: bool) -> None:
        """The UI: a widget is held this frame (an expensive edit may wait for its release)."""
        if self._widget_active and not on:
            self._released = True
            self._let_go = True
        self._widget_active = bool(on)

    def ui_failed(self, text: str) -> None:
        self.render_error = text
        self.state.say(text, error=True)

    def _on_change(self, source: str) -> None:
        self._change_source = source
        self._camera_input = source.startswith("camera")
        self._released = False
        self.scheduler.note_change()

    # -- the quality governor (ui/governor.py) --------------------------------------------------
    def load_calibration(self, auto: bool = True) -> str:
        """The cached calibration for this GL renderer and mesh class; with ``auto`` the techniques
        it lacks are measured in the background when first governed (missing, stale or unreadable:
        rebuilt, never trusted). Returns the one-line message, if any."""
        from skinviewer.engine import calibration
        scene = self.renderer.scene
        tris = int(len(scene.gpu.mesh.indices)) if scene is not None else 0
        renderer, mclass = calibration.renderer_name(self.ctx), calibration.mesh_class(tris)
        cal, why = calibration.load(renderer, mclass)
        self.governor.set_calibration(cal)
        self._auto_calibrate = auto
        cached = calibration.calibration_path(renderer, mclass).is_file()
        why = calibration_note(why, cal is not None, cached, auto, self.state.settings.render.governor != "off",
                               f"{renderer} ({mclass} meshes)")
        old = calibration.stale_truth(cal)  # figures of an older ground truth: said, and marked in the status
        why = "; ".join(w for w in (why, old) if w)
        if why:
            self.state.say(why)
        return why

    def _calibrate_missing(self, technique: str) -> None:
        cal = self.governor.calibration
        if not self._auto_calibrate or self.calibrating is not None or technique in self._calibration_tried \
                or (cal is not None and technique in cal.entries):
            return
        self._calibration_tried.add(technique)
        self.calibrating = BackgroundCalibration(self.state.settings, [technique], into=cal).start()

    def _poll_calibration(self) -> None:
        c = self.calibrating
        if c is None or c.running:
            return
        self.calibrating = None
        if c.result is not None:
            self.governor.set_calibration(c.result)
            self.state.say(f"calibrated {sum(len(v) for v in c.result.entries.values())} configurations on "
                           f"{c.result.renderer}: the governor uses them")
        elif c.error:
            self.state.say(c.error, error=True)

    def _govern(self) -> Rung:
        """This frame's rung: the governor's pick while the user interacts, its refinement after."""
        s = self.state.settings
        g = self.governor
        self._governing = False
        try:
            g.configure(s.render.governor, s.render.governor_budget_ms)
        except ValueError:
            return FINAL
        self._poll_calibration()
        if not g.active:
            g.rung_for(s, False, False, True)  # forgets any preview
            return FINAL
        if self._cold_start is None:  # a cold start's calibration waits for its first image (issue 34)
            self._calibrate_missing(s.technique)
        if g.calibration is None or s.technique not in g.calibration.entries:
            if self._cold_start == s.technique:
                return self._govern_cold(s)
            return FINAL  # not measured here yet: today's behaviour (orbit resolution, deferred edits)
        self._governing = True
        interacting = not self.input_stopped
        self._interacting = interacting
        complete = self.report is None or self.report.complete
        g.set_overhead(self.frame_rest_ms() + (self.graph_own_ms or 0.0))
        g.set_margin(self._graph_margin(s.technique))
        rung = g.rung_for(s, interacting, self._camera_input, complete)
        if g.message and g.message != self._gov_note:
            self.state.say(g.message)
        self._gov_note = g.message
        return rung

    def _graph_margin(self, technique: str) -> float | None:
        """The margin the render graph's look-ahead puts on its predicted costs (kernel/margin.py: the p99
        of every pass's recent actual / predicted ratios) in the graph of the image on screen (a
        preview's), else the user's graph of ``technique``; None: none known, or the margin off
        (graph.QUANTILE_MARGIN)."""
        from skinviewer.kernel import graph as graph_mod
        if not graph_mod.QUANTILE_MARGIN or not GOVERNOR_MARGIN:
            return None
        for key in (f"{technique}|{self._variant}" if self._variant else technique, technique):
            g = self.renderer.graphs.get(key)
            f = g.margins.factor("") if g is not None else None
            if f is not None:
                return min(float(f), graph_mod.MARGIN_MAX)
        return None

    def start_with_preview(self) -> None:
        """Issue 34, the cold start: the first image is the technique's cheapest preview rung
        (``techniques.preview.cheapest``, as declared: no calibration is needed), then the user's
        settings, as the governor refines after an edit. With a calibration the governor's own
        pick comes first instead (the start counts as an edit: ``scheduler.note_change``)."""
        self._cold_start, self._cold_rung = self.state.settings.technique, None

    def _govern_cold(self, s: Settings) -> Rung:
        """The cold start's rung, uncalibrated: the cheapest rung on the first frame, the user's
        settings once its frame is complete; then the usual path (a technique switch ends it too)."""
        from skinviewer.techniques.preview import cheapest
        g = self.governor
        self._governing, self._interacting = True, False
        if self._cold_rung is None:
            self._cold_rung = cheapest(s)
            g.start_at(self._cold_rung)
            rung = g.shown
        else:
            rung = g.rung_for(s, False, False, self.report is None or self.report.complete)
        if rung.final:
            self._cold_start = None
        return rung

    @property
    def input_stopped(self) -> bool:
        """The user is not interacting: nothing is dragged or held, and a drag or a held widget was
        let go after the last change, or the last change (a key, a typed value) is older than the
        scheduler's rest."""
        if self._dragging or self._widget_active:
            return False
        return self._released or time.perf_counter() - self.scheduler.changed_at >= self.scheduler.rest_s

    @property
    def governor_status(self) -> str:
        """The status bar's words for what is shown (preview, error, refining k/n, calibrating)."""
        c = self.calibrating
        if c is not None and c.running:
            what, i, n = c.progress
            return f"calibrating {i + 1}/{n}: {what}"
        return self.governor.status(self.state.settings) if self._governing else ""

    # -- reading -----------------------------------------------------------------------------
    @property
    def render_deferred(self) -> bool:
        """The image on screen is older than the settings (an expensive slider drag is in progress)."""
        return self.scheduler.deferred

    def graph(self):
        """The graph of the image on screen: the current technique's (its governor preview's while
        one is shown); None when the technique is not available."""
        t = self.state.settings.technique
        return self.renderer.graph(t, self._variant) if t in techniques.names() else None

    def cost_hint(self, path: str) -> str:
        """What editing ``path`` re-runs in the current technique and what that cost last time."""
        g = self.renderer.graphs.get(self.state.settings.technique)
        if g is None or g.last_report is None:
            return ""
        passes = g.affected([path])
        if not passes:
            return "editing it re-runs no pass of this technique"
        return (f"editing it re-runs {len(passes)} pass(es), ~{g.predicted_ms(passes):.0f} ms last measured "
                f"({g.last_report.timing_mode} timing): {', '.join(passes)}")

    def view_passes(self, technique: str | None = None) -> set[str]:
        """Names of the view-dependent passes of a technique and everything downstream of them."""
        g = self.renderer.graph(technique or self.state.settings.technique)
        vd = {p.name for p in g.passes if p.view_dependent}
        return vd if self.report is None else view_side(self.report, vd)

    def drag_scale(self) -> float:
        """Resolution scale of the view while the camera is dragged (1 when not dragging)."""
        if not self._dragging or self.drag_resolution == "full":
            return 1.0
        if self.drag_resolution != "auto":
            return float(self.drag_resolution)
        s = self.state.settings
        g = self.renderer.graphs.get(s.technique)
        if g is None or g.last_report is None:
            return 1.0
        full = self.layout.view_fb[2] * self.layout.view_fb[3]
        now = max(s.render.width * s.render.height, 1)
        # the view-dependent cost at full size, scaled from the size it was last measured at
        ms = g.predicted_ms(g.affected([], camera=True)) * full / now
        if ms <= self.drag_budget_ms:
            return 1.0
        return drag_step(max(0.25, min(1.0, (self.drag_budget_ms / ms) ** 0.5)))  # cost ~ pixels

    # -- the frame ---------------------------------------------------------------------------
    def _compute_layout(self) -> Layout:
        v = self.state.view
        return compute_layout(self._window[0], self._window[1], v.show_ui, v.panel_width, v.panel_side)

    @property
    def presented(self) -> bool:
        """The last frame drew the screen (its image, complete or the last complete one, is shown)."""
        return self._last_presented

    def can_skip_present(self, input_events: int) -> bool:
        """This frame may only render (no UI, no view, no buffer swap): a frame spread over several
        is in progress, no input arrived since the last presented frame, no widget is held and no
        screenshot waits. Presenting costs tens of ms a frame under Xvfb on llvmpipe: a still view's
        refinement gets that time. Nothing would change on screen meanwhile -- the view keeps the
        last complete image until this one is complete, and the frame that completes it presents
        -- so there is no periodic refresh (it re-presented the same image every 0.5 s: 2-3 frames of
        UI and swap in a d'Eon release -> final, issue 27)."""
        r = self.report
        if RELEASE_RENDERS_FIRST and self.quiet_frames and r is not None and not self._widget_active \
                and not self._dragging and not self._pending_shots:
            if self._let_go and self._governing and not self._rung.final and self._released:
                # the release's frame, a preview on screen: it shows the same image until the refinement's is
                # complete, and the frame that completes it presents (the UI built then sees the release)
                self._release_events = input_events
                return True
            if self._release_events is not None and input_events <= self._release_events:
                input_events = 0  # no input since the release's
        return (self.quiet_frames and input_events == 0 and r is not None and not r.complete
                and not self._widget_active and not self._dragging and not self._pending_shots
                and (WHOLE_FRAME or time.perf_counter() - self._presented_at < REFRESH_S))

    def run(self, frametime: float, window_size, buffer_size, ui: UiLayer | None = None,
            present: bool = True) -> bool:
        """One frame; ``present`` False (``can_skip_present``): render only, unless the frame
        completes (then the view and UI are drawn as usual). Returns whether it drew the screen."""
        drew = self._frame(frametime, window_size, buffer_size, ui, present)
        r = self.report
        # (no report: the render failed and says so; nothing is in progress)
        busy = (not self.input_stopped or (r is not None and not r.complete) or self.governor.refining
                or self.scheduler.deferred)
        scene = self.renderer.scene
        self.collector.frame(busy, scene.key if scene is not None else None)
        return drew

    def _frame(self, frametime: float, window_size, buffer_size, ui: UiLayer | None, present: bool) -> bool:
        now = time.perf_counter()
        if self._last_frame_t is not None:
            interval = (now - self._last_frame_t) * 1000.0
            self.frame_ms.append(interval)
            if self._render_ms is not None and self._last_presented and (self.after_present.mean is None
                                                                         or not WHOLE_FRAME):
                rest = max(interval - self._render_ms, 0.0)  # until frame_end measures the frame whole
                self.overhead_ms = rest if self.overhead_ms is None else 0.8 * self.overhead_ms + 0.2 * rest
        self._last_frame_t = now
        self._frame_t0, self._render_end, self._after_extra = now, None, 0.0
        self._let_go = False  # (can_skip_present read it before this frame)
        self.frames += 1
        self._window = ((window_size[0], window_size[1]), (buffer_size[0], buffer_size[1]))
        self.watcher.poll()
        # the UI is built first: this frame's edits (and panel resizes) are rendered this frame;
        # the panel shows the previous frame's report (identical on idle frames)
        ui_built = False
        if present and ui is not None and self.state.view.show_ui:
            self.layout = self._compute_layout()
            ui_built = ui.build(frametime, self.layout)
        self._rung = self._govern()
        self._sync_size()
        self.report = self._render_main(present=present)
        g = self.graph()
        if g is not None and self.report is not None and self.report.complete:
            self.view.keep(g, bool(self.report.ran))  # the view shows the last complete image
        if not present:
            if self.report is None or not self.report.complete:
                self._last_presented = False
                return False
            spent = (time.perf_counter() - now) * 1000.0
            # presenting it now adds the UI built and what a presenting frame costs after its render
            after = self.after_present.upper() if WHOLE_FRAME else None
            rest = (self.overhead_ms or 0.0) if after is None else (self.before.upper() or 0.0) + after
            if self.frame_budget_ms is not None and spent + rest > self.frame_budget_ms:
                # complete, but the UI and presenting on top would take this frame past the budget:
                # it is shown next frame (can_skip_present is False once the frame is complete)
                self._last_presented = False
                return False
            if ui is not None and self.state.view.show_ui:  # complete: shown now, with the UI
                self.layout = self._compute_layout()
                ui_built = ui.build(frametime, self.layout)
        self._last_presented = True
        self._release_events = None
        self._presented_at = time.perf_counter()
        if self.report is not None and self.report.complete and not self.report.ran:
            # idle: a slice of the next drag's preview variants, else likely shader variants compiled;
            # not what a frame costs after its render (frame_end leaves it out)
            t_idle = time.perf_counter()
            # deon.view_cull: the texture-space tiles no view needed yet, so the next orbit finds them made
            if not self._prime() and not self.renderer.complete_view(self.state.settings, self.graph_budget_ms() or 30.0):
                self.renderer.warm(self.state.settings.technique, budget_ms=30.0)
            self._after_extra = (time.perf_counter() - t_idle) * 1000.0
        self.view.draw(self.graph(), self.layout, ui.view_hooks() if ui is not None else ())
        self.watcher.refresh_errors()
        self._trim_texture_pools()
        self._take_shots(include_ui=False)
        if ui_built and ui is not None:
            ui.present()
        self._take_shots(include_ui=True)
        return True

    def _prime(self) -> bool:
        """An idle frame (still, final, nothing ran): draw a slice of the preview variants the next
        drag will render (ui/warm.Primer: their first draw JIT-compiles them). True if it rendered."""
        if not (self._governing and self.input_stopped and not self.governor.refining and not self._partial_ran):
            return False
        budget = self.graph_budget_ms()
        vw, vh = self.layout.view_fb[2:]
        return self.primer.step(self.governor, self.state.settings, (int(vw), int(vh)),
                                self.governor.room() if budget is None else budget)

    def _sync_size(self) -> None:
        """The render size follows the 3D view region (framebuffer pixels), not the whole window."""
        self.layout = self._compute_layout()
        vw, vh = self.layout.view_fb[2:]
        scale = self._rung.scale if self._governing else self.drag_scale()
        if scale < 1.0:
            vw, vh = max(16, int(vw * scale)), max(16, int(vh * scale))
        if self.state.set_render_size(vw, vh) and not self._change_source:
            self._change_source = ("camera (orbit at reduced resolution)" if scale < 1.0 else
                                   "camera (orbit done: full resolution)" if self._drag_scaled else
                                   "render size")
        self._drag_scaled = scale < 1.0

    def _render_main(self, budget_ms: float | None = None, present: bool = True) -> FrameReport | None:
        live = self.state.settings
        pending = self._shown is None or (self._shown is not live and self._shown != live)
        last_cost = self.last_change.total_ms if self.last_change else None
        # a spread frame in progress is finished first, whatever the scheduler says
        defer = not self._partial_ran and self._shown is not None and not self._governing \
            and self.scheduler.should_defer(pending, self._widget_active, last_cost) \
            and not self._scene_changed(self._shown)
        self.scheduler.set_deferred(defer)
        target = self._shown if defer and self._shown is not None else self.governor.settings_for(
            live, self._rung if self._governing else FINAL)
        rung = self._rung if self._governing and not defer else FINAL
        variant = preview_variant(rung)
        inflight = self._inflight
        if inflight is not None and self._governing and self._interacting and not defer \
                and inflight[0].technique == live.technique and not self._scene_changed(inflight[0]):
            # an interaction frame part-way is finished first (newer input waits for the next
            # frame): re-targeting it every frame of a drag would cancel its bands every frame
            target, variant, rung = inflight
            self.governor.hold(rung)
        self._inflight = None
        if self._partial_ran and (variant != self._partial_variant or rung != self._partial_rung):
            self._partial_ran = []  # an unfinished frame of another graph was abandoned (a preview at release)
        try:
            t0 = time.perf_counter()
            if self._frame_t0 is not None and present:  # a presenting frame's UI built before its render
                self.before.add((t0 - self._frame_t0) * 1000.0)
            budget = self.graph_budget_ms(present) if budget_ms is None else budget_ms
            self.last_budget_ms = budget  # what the graph was given (bench_interaction's frame log)
            # a governed preview (not the user's settings): scene rules answer from coarser cached
            # estimates and outputs are checked for NaN/Inf once a frame of the final image finds them
            preview = self._governing and not rung.final
            report = self.renderer.render(target, budget_ms=budget, variant=variant, interactive=preview)
            self._render_end = time.perf_counter()
            self._render_ms = (self._render_end - t0) * 1000.0
            self.last_graph = self.renderer.graph(target.technique, variant)  # the frame log's (bench_interaction)
            self.render_extra.add(self._render_ms - self.last_graph.run_ms)
            own = self.last_own_ms = self.last_graph.own_ms
            if preview and report.ran:
                self.graph_own_ms = own if self.graph_own_ms is None else 0.8 * self.graph_own_ms + 0.2 * own
            if not report.complete and self._governing and self._interacting:
                self._inflight = (target, variant, rung)
            if report.complete:  # until then the view shows the last complete image, in its graph
                if self._governing and variant == self._variant:  # the same graph as the last image
                    self._observe(report if not self._partial_ran else self._merge_partial(report, keep=True),
                                  target.technique, rung)
                self._variant = variant
            self.render_error = ""
            self._rendered = (target.technique, target.render.width, target.render.height)
            vw, vh = self.layout.view_fb[2:]
            self._pool_key = (target.technique, int(vw), int(vh)) if KEEP_VIEW_POOLS else self._rendered
        except Exception as exc:
            self.render_error = f"{type(exc).__name__}: {exc}"
            self.state.say(f"render: {self.render_error.splitlines()[0]}", error=True)
            if self.state.options.debug:
                traceback.print_exc()
            self._shown = live  # do not retry a failing state every frame while deferring
            self._partial_ran = []  # a spread frame that failed is not resumed (nor merged into the next)
            return None
        if defer:
            return report
        if not report.complete:
            self._partial_ran += [p for p in report.passes if p.status == "ran"]
            self._partial_variant, self._partial_rung = variant, rung
            return report
        if self._partial_ran:
            report = self._merge_partial(report)
        for p in report.passes:
            if p.status == "ran" and p.ms is not None:
                self.last_ms[p.name] = p.ms
        # a cached technique switch costs 0 ms: say so; a frame that only refined a still view
        # (burley2.temporal: nothing changed) is not a change
        refining_only = not pending and not self._change_source and self._shown is live
        if (report.ran and not refining_only) or self._change_source == "technique":
            self._record_change(report, live.technique)
        self._shown = live
        self._change_source = ""
        return report

    def _scene_changed(self, s: Settings) -> bool:
        """The loaded scene is not the one of ``s``: the state has already loaded the new one, and
        rendering ``s`` (the image on screen, while a deferred edit waits) would load it back."""
        scene = self.renderer.scene
        return scene is None or scene.key != Renderer.scene_key(s)

    def _observe(self, report: FrameReport, technique: str, rung: Rung) -> None:
        """Tell the governor what this complete frame of ``rung`` cost (the passes it ran, sync
        timing): its picks follow this machine as it is now, not only its calibration."""
        ms = [p.ms for p in report.passes if p.status == "ran" and p.ms is not None]
        if ms and report.timing_mode in ("sync", "gpu"):
            self.governor.observe(technique, rung, self._camera_input, float(sum(ms)))

    def _merge_partial(self, report: FrameReport, keep: bool = False) -> FrameReport:
        """One report for a frame spread over several: the passes that ran in any of them."""
        ran = {p.name: p for p in self._partial_ran}
        if not keep:
            self._partial_ran = []
        passes = [p if p.status == "ran" else ran.get(p.name, p) for p in report.passes]
        return FrameReport(report.frame, report.timing_mode, passes)

    def _record_change(self, report: FrameReport, technique: str) -> None:
        g = self.renderer.graph(technique)
        vset = view_side(report, {p.name for p in g.passes if p.view_dependent})
        tex, view = split_ms(report, vset, lambda p: p.ms if p.status == "ran" else None)
        ran = sorted(((p.name, p.ms or 0.0) for p in report.passes if p.status == "ran"), key=lambda x: -x[1])
        self.last_change = ChangeCost(self._change_source or "frame", report.total_ms, tex, view, ran,
                                      report.timing_mode, time.time())

    def _trim_texture_pools(self) -> None:
        """Give the free textures of the render pools back to GL when the view's size (or the
        technique) changed: a pool keeps every texture handed back to it, keyed by size, so each
        window or panel resize used to leave a full set of view-sized textures behind for the rest
        of the session. Textures in use (every graph's cache) stay. A smaller view while dragging (a
        governor rung's scale, the orbit resolution) is no change (KEEP_VIEW_POOLS): the full size's
        textures wait in the pool for the release, and the drag's smaller ones are taken again by the
        next drag (one set per scale, not one per drag)."""
        if self._pool_key == self._pools_trimmed_for:
            return
        if self._pools_trimmed_for is not None:
            for r in (self.renderer, *self.view.renderers()):
                r.trim()
        self._pools_trimmed_for = self._pool_key

    # -- screenshots -------------------------------------------------------------------------
    def request_screenshot(self, path: str | Path | None = None, include_ui: bool | None = None) -> Path:
        """Queue a screenshot of the next frame; returns its path (timestamped when not given)."""
        o = self.state.shots
        p = Path(path) if path else timestamped_path(o.folder)
        inc = o.include_ui if include_ui is None else include_ui
        self._pending_shots.append((p, bool(inc and self.state.view.show_ui)))
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
                if path.suffix.lower() == ".exr":  # the linear image, as `render --out x.exr`
                    save_exr(path, self._linear())
                else:  # PNG, JPEG, TIFF or BMP as the extension says (OutputPathError for others)
                    save_image(path, img)
                self.screenshots_written.append(path)
                self.state.say(f"screenshot: {path} ({img.shape[1]}x{img.shape[0]}{', with UI' if include_ui else ''})")
                if self.state.shots.save_linear_npy or self.state.shots.save_linear_exr:
                    linear = self._linear()
                    if self.state.shots.save_linear_npy:
                        save_npy(path.with_suffix(".npy"), linear)
                    if self.state.shots.save_linear_exr:  # what compositing tools read
                        save_exr(path.with_suffix(".exr"), linear)
            except Exception as exc:
                self.state.refuse([("screenshot", f"{type(exc).__name__}: {exc}")], f"screenshot {path}")

    def _linear(self):
        """The frame's linear HDR image (before exposure and tone map), top row first."""
        g = self.renderer.graph(self.state.settings.technique)
        return g.read("lit" if "lit" in g.resources() else "image")[::-1]

    def release(self) -> None:
        self.collector.release()
        c = self.calibrating
        if c is not None and c.running:  # stopped between rungs and joined: a thread left running its
            c.cancel()                   # own GL context at exit aborts the process ("terminate called")
            c.thread.join(timeout=60.0)
        self.view.release()
        self.renderer.release()
