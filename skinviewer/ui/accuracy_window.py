"""The Accuracy window: the ground truth of the current view (engine.reference) computed in a worker
thread with a progress bar (cancellable; a view that would take too long says so first), the
current image's error against it (physics.metrics: relative RMS, p99, DSSIM — the bench's code),
an error heat-map view mode (full view, or split image | heat map), and the Pareto chart of a bench
``results.json`` (implot) with the current configuration marked; clicking a point applies it.

A window of ui/windows.py: made as ``AccuracyWindow(state, frame)``, drawn with ``draw(ui)``, and
``draw_view(viewport)`` before showing its image (True: the window drew the view)."""
from __future__ import annotations

import math
import threading
from typing import Any

import numpy as np

from skinviewer.engine.bench import (
    compare_mask,
    heat_rgb,
    last_bench,
    load_results,
    pareto_front,
)
from skinviewer.ground.settings import Settings, value_key, with_values
from skinviewer.physics.metrics import image_error, rel_error_map, with_u
from skinviewer.ui.layout import floating_rects, keep_inside
from skinviewer.ui.widgets import flow_legend, show_tooltip, wrapped

VIEW_MODES = ("image", "heat map", "split image | heat map")
CHART_MIN_H = 160.0  # the Pareto chart's least height (px): below it the window scrolls
FRONT_RGBA = (0.92, 0.92, 0.92, 0.9)
CURRENT_RGBA = (1.0, 0.85, 0.2, 1.0)
RUNG_RGBA = (0.4, 0.6, 1.0, 1.0)
BUDGET_RGBA = (1.0, 0.45, 0.4, 0.9)


def reference_key(s: Settings) -> str:
    """What a reference depends on, to tell whether the one on hand is for this view."""
    return "|".join(value_key(s, k) for k in ("scene", "camera", "render.width", "render.height", "lights",
                                              "specular", "deon.gaussians", "deon.mix", "deon.energy_conservation"))


class _Job:
    """A progressive truth in a worker thread (engine.reference.TruthSession): each finished stage is
    handed over through ``partial`` (one assignment), picked up by the window on the UI thread."""

    def __init__(self, s: Settings, session):
        self.settings = s
        self.key = reference_key(s)
        self.stage = "starting"
        self.fraction = 0.0
        self.partial: Any = None  # the last finished stage (engine.reference.Partial)
        self.result: Any = None  # the final Reference
        self.error = ""
        self.cancel = threading.Event()
        self.thread = threading.Thread(target=self._run, args=(session,), daemon=True)
        self.thread.start()

    def _run(self, session) -> None:
        try:
            for part in session.progressive(self.settings, progress=self._progress, cancelled=self.cancel.is_set):
                self.partial = part
                if part.final:
                    self.result = part.reference
        except InterruptedError:
            self.error = "cancelled"
        except Exception as exc:  # shown in the window, the viewer goes on
            self.error = f"{type(exc).__name__}: {exc}"

    def _progress(self, stage: str, f: float) -> None:
        self.stage, self.fraction = stage, float(f)

    @property
    def done(self) -> bool:
        return not self.thread.is_alive()


def uncertainty_words(meta: dict) -> str:
    """What the session truth's +- covers (engine.reference: LATTICE_ and ENV_UNCERTAINTY_NOTE)."""
    if "environment" in str(meta.get("uncertainty", "")):
        return ("(+- the surface lattices' interpolation error and the environment's Monte Carlo error at the "
                "pixels and interpolated at the source elements; not the element size's "
                "part: skinviewer reference)")
    return "(+- the surface lattices' interpolation error; the element size's part: skinviewer reference)"


class AccuracyWindow:
    def __init__(self, state, frame):
        self.state, self.frame = state, frame  # ui.state.ViewerState, ui.frame.FrameController
        self.open = True
        self.job: _Job | None = None
        self.reference: Any = None
        self.ref_key = ""
        self.max_seconds = 180.0  # bench / CLI references; the window's truth is progressive (no limit)
        self._session: Any = None  # engine.reference.TruthSession, made on first use (scipy: not at start)
        self.follow = False  # once asked, a truth follows the view (restarts on a change, reusing sources)
        self.partial = None  # the stage shown (engine.reference.Partial)
        self.rms_se = None  # (rms (3,), standard error (3,)) of the figures while the truth refines
        self.view_mode = 0
        self.tab = "Truth"       # the page shown (Truth, Pareto, Governor)
        self.tab_request = ""    # a page to show next frame (scripts, tests)
        self.rect = None         # the window's last (x, y, w, h)
        self.chart_rect = None   # the Pareto chart's last (x, y, w, h) on screen (tests)
        self.legend_extent: list[float] = []  # (rightmost x of its legend, the right edge it may use)
        self.pareto_hidden: set[str] = set()  # series a click on the Pareto chart's legend hid
        self.error = None        # ImageError of the image on screen
        self.error_for = None    # (settings object, report id) the figures are for
        self.status = ""
        self.heat_tex = None
        self.results_path = last_bench()
        self.results = []        # bench Result list
        self.results_meta: dict = {}
        self.results_msg = ""
        if self.results_path:
            self.load_results(self.results_path, quiet=True)

    @property
    def session(self):
        """The truth session (sources kept across camera and profile changes, recent truths); made
        when a truth is first asked for: importing engine.reference loads scipy, ~1 s of the start."""
        if self._session is None:
            from skinviewer.engine.reference import TruthSession
            self._session = TruthSession()
        return self._session

    # -- ground truth ---------------------------------------------------------------------------
    def start(self) -> None:
        if self.job is not None and not self.job.done:
            return
        self.job = _Job(self.state.settings, self.session)
        self.follow = True
        self.status = ""

    def cancel(self) -> None:
        self.follow = False
        if self.job is not None:
            self.job.cancel.set()

    def _poll(self) -> None:
        job = self.job
        if job is not None:
            part = job.partial
            if part is not None and part is not self.partial:  # a new stage: the figures and heat map refine
                self.partial = part
                self.reference, self.ref_key = part.reference, job.key
                self.error_for = None
                self.status = (f"ground truth: {part.stage}, {100 * part.fraction:.0f} % of the pixels, "
                               f"{part.seconds:.1f} s" + ("" if part.final else " - refining"))
            if not job.done:
                if self.follow and job.key != reference_key(self.state.settings):
                    job.cancel.set()  # the view changed: start again (the session keeps the sources)
                return
            if job.result is None and job.error:
                self.status = job.error
            self.job = None
        if self.follow and not self.current and not self.frame._dragging:
            self.job = _Job(self.state.settings, self.session)

    @property
    def current(self) -> bool:
        return self.reference is not None and self.ref_key == reference_key(self.state.settings)

    def _update_error(self) -> None:
        """Figures of the image on screen against the reference (recomputed when the frame changes)."""
        st, fr = self.state, self.frame
        if not self.current or fr.report is None:
            return
        tag = (id(st.settings), id(fr.report))
        if self.error_for == tag:
            return
        self.error_for = tag
        try:
            lit = fr.renderer.read(st.settings, "lit")[::-1]
        except Exception as exc:
            self.status = f"no image to compare: {exc}"
            return
        img = np.asarray(lit[..., :3], np.float64)
        if img.shape != self.reference.lit.shape:
            return
        ref = self.reference
        visible = ref.meta.get("visible_mask")
        if visible is None:
            visible = ref.mask
        # the rim of the whole visible region, then the pixels the (progressive) truth has so far
        m = compare_mask(visible, lit[..., 3] > 0.5) & ref.mask
        self.error = image_error(img, ref.lit, m, exposure=st.settings.render.exposure,
                                 uncertainty=getattr(ref, "uncertainty", None))
        from skinviewer.engine.reference import sampled_rms
        self.rms_se = sampled_rms(img, ref, m)
        self._upload_heat(rel_error_map(img, ref.lit, m))

    def _upload_heat(self, emap: np.ndarray) -> None:
        rgb = np.ascontiguousarray(heat_rgb(emap)[::-1])  # GL rows bottom-up
        h, w = rgb.shape[:2]
        ctx = self.frame.ctx
        if self.heat_tex is None or self.heat_tex.size != (w, h):
            if self.heat_tex is not None:
                self.heat_tex.release()
            self.heat_tex = ctx.texture((w, h), 3, rgb.tobytes(), alignment=1)
        else:
            self.heat_tex.write(rgb.tobytes(), alignment=1)

    def draw_view(self, viewport) -> bool:
        """Heat-map view modes; False leaves the view to the app."""
        if self.view_mode == 0 or self.heat_tex is None or not self.current:
            return False
        display = self.frame.view.display
        if self.view_mode == 1:
            display.show(self.heat_tex, viewport)
        else:
            g = self.frame.renderer.graph(self.state.settings.technique)
            if "image" not in g.resources():
                return False
            display.split(g.texture("image"), self.heat_tex, viewport, self.state.compare.divider)
        return True

    # -- bench results --------------------------------------------------------------------------
    def load_results(self, path: str, quiet: bool = False) -> bool:
        try:
            self.results_meta, self.results = load_results(path)
            pareto_front(self.results)
            self.results_path = path
            self.results_msg = f"{len(self.results)} configurations ({self.results_meta.get('scene')})"
            return True
        except (OSError, ValueError, KeyError, TypeError) as exc:
            if not quiet:
                self.results_msg = f"cannot read {path}: {exc}"
            return False

    def matches(self, r) -> bool:
        """Is bench configuration ``r`` the current settings?"""
        s = self.state.settings
        if r.technique != s.technique:
            return False
        try:
            probe = with_values(s, r.changes)
        except Exception:
            return False
        return all(value_key(probe, k) == value_key(s, k) for k in r.changes)

    def apply(self, r) -> None:
        self.state.apply({"technique": r.technique, **r.changes}, source=f"Pareto: {r.name}")

    # -- UI ---------------------------------------------------------------------------------------
    def draw(self, ui) -> None:
        from imgui_bundle import imgui
        self._poll()
        self._update_error()
        # issue 34: the top-left of the 3D view, half its width at most (the Passes window has the
        # other half), as tall as the view allows so the Pareto chart fits without scrolling at
        # 960x600; starts collapsed (a bar above the subject); a window moved or left outside the
        # view (a resize, the panel moved) is brought back inside it, never over the panel
        x, y, w, h = floating_rects(ui.layout.view)["accuracy"]
        imgui.set_next_window_pos(imgui.ImVec2(x, y), imgui.Cond_.first_use_ever.value)
        imgui.set_next_window_size(imgui.ImVec2(w, h), imgui.Cond_.first_use_ever.value)
        imgui.set_next_window_collapsed(True, imgui.Cond_.first_use_ever.value)
        if self.rect is not None:
            nx, ny = keep_inside(self.rect, ui.layout.view)
            if (nx, ny) != self.rect[:2]:
                imgui.set_next_window_pos(imgui.ImVec2(nx, ny), imgui.Cond_.always.value)
        expanded = imgui.begin("Accuracy###accuracy")[0]
        if expanded and imgui.begin_tab_bar("##accuracy_tabs"):
            # one page at a time (issue 34): the truth's figures, the bench's Pareto chart (the
            # window's height is the chart's), the governor's front on this machine
            for name, body in (("Truth", self._truth_ui), ("Pareto", self._chart_ui), ("Governor", self._governor_ui)):
                flags = imgui.TabItemFlags_.set_selected.value if self.tab_request == name else 0
                if imgui.begin_tab_item(name, None, flags)[0]:
                    self.tab = name
                    body(imgui)
                    imgui.end_tab_item()
            self.tab_request = ""
            imgui.end_tab_bar()
        pos, size = imgui.get_window_pos(), imgui.get_window_size()
        self.rect = (pos.x, pos.y, size.x, size.y)
        ui.claim(self.rect)
        imgui.end()

    def _truth_ui(self, imgui) -> None:
        job = self.job
        if job is not None:
            imgui.progress_bar(job.fraction, imgui.ImVec2(-90, 0), f"{job.stage} {100 * job.fraction:.0f}%")
            imgui.same_line()
            if imgui.button("Cancel"):
                self.cancel()
        else:
            if imgui.button("Ground truth for this view"):
                self.start()
            _, self.follow = imgui.checkbox("follow the view", self.follow)
        if self.status:
            imgui.text_wrapped(self.status)
        if self.reference is not None and not self.current and self.job is None:
            imgui.text_disabled("the view or lighting changed: the ground truth is for another view")
        if self.current and self.error is not None:
            e = self.error
            shown = self.state.compare.shown()
            wrapped(f"image: the live state ({self.state.settings.technique})" + (f"; view: {shown}" if shown else ""))
            frac = float(self.reference.meta.get("fraction", 1.0))
            if frac < 1.0 and self.rms_se is not None:
                rms, se = self.rms_se
                imgui.text(f"RMS  {' / '.join(f'{100 * c:.2f}+-{100 * d:.2f}' for c, d in zip(rms, se))} %")
                wrapped(f"(from {100 * frac:.0f} % of the pixels, +- one standard error)")
            else:
                imgui.text(f"RMS  {with_u(e.rms, e.rms_u, 2)} %")  # ± the ground truth's own uncertainty
                if self.reference.meta.get("session") and e.rms_u is not None:
                    wrapped(uncertainty_words(self.reference.meta))
            imgui.text(f"p99  {with_u(e.p99, e.p99_u)} %")
            if frac >= 1.0:
                imgui.text(f"DSSIM {e.dssim:.4f}" + (f" ± {e.dssim_u:.4f}" if e.dssim_u is not None else ""))
            imgui.set_next_item_width(200)
            _, self.view_mode = imgui.combo("view", self.view_mode, list(VIEW_MODES))
            if self.view_mode:
                wrapped("heat map: relative error 0 (black) .. 50 % (white)")

    def _chart_ui(self, imgui) -> None:
        from imgui_bundle import implot
        imgui.set_next_item_width(-60)
        _, self.results_path = imgui.input_text("##results", self.results_path)
        imgui.same_line()
        if imgui.button("Load"):
            self.load_results(self.results_path)
        if self.results_msg:
            imgui.text_disabled(self.results_msg)
        ok = [r for r in self.results if r.error is None and r.full_ms and r.rms]
        if not ok:
            return
        techs = list(dict.fromkeys(r.technique for r in ok))
        cols = [implot.get_colormap_color(k, implot.Colormap_.deep.value) for k in range(len(techs))]
        front = sorted((r for r in ok if r.pareto), key=lambda r: r.full_ms)
        cur = [r for r in ok if self.matches(r)]
        # the legend above the chart, wrapped to the window's width (never over the points, never cut)
        items = [(tech, (c.x, c.y, c.z, c.w)) for tech, c in zip(techs, cols)]
        items += [("Pareto front", FRONT_RGBA)] if len(front) > 1 else []
        items += [("current", CURRENT_RGBA)] if cur else []
        self.legend_extent[:] = flow_legend(items, {"current": "the configuration of the live settings",
                                                    "Pareto front": "no configuration is both faster and closer to the truth"},
                                            hidden=self.pareto_hidden)
        shown = self.pareto_hidden.isdisjoint
        h = max(CHART_MIN_H, imgui.get_content_region_avail().y - 4)
        p = imgui.get_cursor_screen_pos()
        self.chart_rect = (p.x, p.y, imgui.get_content_region_avail().x, h)
        if implot.begin_plot("##pareto", imgui.ImVec2(-1, h), implot.Flags_.no_legend.value):
            implot.setup_axes("full frame ms", "RMS %")
            implot.setup_axis_scale(implot.ImAxis_.x1.value, implot.Scale_.log10.value)
            # the RMS axis clipped at the bulk of the points (an outlier of several hundred % would
            # flatten the rest)
            ys = np.array([100 * r.rms_mean for r in ok])
            top = float(min(ys.max(), 1.5 * np.percentile(ys, 90, method="lower"))) * 1.08
            implot.setup_axis_limits(implot.ImAxis_.y1.value, 0.0, max(top, 1e-3), implot.Cond_.once.value)
            xs = np.array([r.full_ms for r in ok])  # a quarter of a decade beyond the points: none on the frame
            implot.setup_axis_limits(implot.ImAxis_.x1.value, float(xs.min()) / 1.25, float(xs.max()) * 1.25,
                                     implot.Cond_.once.value)
            for tech, col in zip(techs, cols):
                if not shown((tech,)):
                    continue
                pts = [r for r in ok if r.technique == tech]
                implot.set_next_marker_style(implot.Marker_.circle.value, 4.0, col)  # distinct per technique
                implot.plot_scatter(tech, np.array([r.full_ms for r in pts], np.float64),
                                    np.array([100 * r.rms_mean for r in pts], np.float64))
            if len(front) > 1 and shown(("Pareto front",)):
                implot.set_next_line_style(imgui.ImVec4(*FRONT_RGBA), 1.0)
                implot.plot_line("Pareto front", np.array([r.full_ms for r in front], np.float64),
                                 np.array([100 * r.rms_mean for r in front], np.float64))
            if cur and shown(("current",)):
                implot.set_next_marker_style(implot.Marker_.square.value, 6.0, imgui.ImVec4(*CURRENT_RGBA))
                implot.plot_scatter("current", np.array([cur[0].full_ms], np.float64),
                                    np.array([100 * cur[0].rms_mean], np.float64))
            hovered = self._nearest(implot, [r for r in ok if shown((r.technique,))])
            if hovered is not None:
                show_tooltip(f"{hovered.name}\n{hovered.full_ms:.0f} ms, RMS {100 * hovered.rms_mean:.2f} %, "
                             f"DSSIM {hovered.dssim:.4f}\nclick: apply")
                if imgui.is_mouse_clicked(0):
                    self.apply(hovered)
            implot.end_plot()

    def governor_points(self) -> list[tuple[str, float, float | None, bool]]:
        """The governor's front for the technique on screen, as calibrated on this machine:
        (label, light-move ms, error vs the truth or None, whether it is the governor's current pick)."""
        g = self.frame.governor
        t = self.state.settings.technique
        if g.calibration is None or t not in g.calibration.entries:
            return []
        pick = g.shown.label if g.active else None
        return [(e.label, e.light_ms, e.error, e.label == pick) for e in g.calibration.entries[t]]

    def _governor_ui(self, imgui) -> None:
        """Issue 27: what the calibration measured for this technique, the governor's pick marked."""
        from imgui_bundle import implot
        pts = self.governor_points()
        if not pts:
            imgui.text_disabled("governor: no calibration for this technique yet (skinviewer calibrate)")
            return
        imgui.text(f"governor's front on this machine ({self.frame.governor.budget_ms:g} ms budget)")
        timed = [(label, ms, err, pick) for label, ms, err, pick in pts if err is not None]
        picked = [x for x in timed if x[3]]
        if timed:  # its legend above it, wrapped (never over the points)
            flow_legend([("rungs", RUNG_RGBA)] + ([("governor's pick", CURRENT_RGBA)] if picked else [])
                        + [("budget", BUDGET_RGBA)])
        if timed and implot.begin_plot("##governor", imgui.ImVec2(-1, 160), implot.Flags_.no_legend.value):
            implot.setup_axes("light-move frame ms", "RMS %")
            implot.setup_axis_scale(implot.ImAxis_.x1.value, implot.Scale_.log10.value)
            implot.set_next_marker_style(implot.Marker_.circle.value, 4.0, imgui.ImVec4(*RUNG_RGBA))
            implot.plot_scatter("rungs", np.array([x[1] for x in timed], np.float64),
                                np.array([100 * x[2] for x in timed], np.float64))
            if picked:
                implot.set_next_marker_style(implot.Marker_.square.value, 6.0, imgui.ImVec4(*CURRENT_RGBA))
                implot.plot_scatter("governor's pick", np.array([picked[0][1]], np.float64),
                                    np.array([100 * picked[0][2]], np.float64))
            implot.set_next_line_style(imgui.ImVec4(*BUDGET_RGBA), 1.0)
            implot.plot_inf_lines("budget", np.array([self.frame.governor.budget_ms], np.float64))
            implot.end_plot()
        for label, ms, err, is_pick in pts:
            line = f"{'>' if is_pick else ' '} {label}: {ms:.0f} ms" + ("" if err is None else f", {err:.1%}")
            (imgui.text if is_pick else imgui.text_disabled)(line)

    @staticmethod
    def _nearest(implot, pts, radius_px: float = 10.0):
        if not implot.is_plot_hovered():
            return None
        from imgui_bundle import imgui
        mouse = imgui.get_mouse_pos()
        best, bd = None, radius_px
        for r in pts:
            p = implot.plot_to_pixels(r.full_ms, 100 * r.rms_mean)
            d = math.hypot(p.x - mouse.x, p.y - mouse.y)
            if d < bd:
                best, bd = r, d
        return best

    def release(self) -> None:
        self.cancel()
        if self.heat_tex is not None:
            self.heat_tex.release()
            self.heat_tex = None


__all__ = ["AccuracyWindow", "reference_key"]
