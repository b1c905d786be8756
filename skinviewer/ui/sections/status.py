"""The top of the panel (scene, preset, messages, errors) and the Quality & cost section."""
from __future__ import annotations

from pathlib import Path

from imgui_bundle import imgui

from skinviewer.ui.frame import DRAG_RESOLUTIONS, FrameController
from skinviewer.ui.scheduler import MODES as RENDER_MODES
from skinviewer.ui.scheduler import split_ms
from skinviewer.ui.sections.common import TEX_COL, VIEW_COL, change_line, shader_errors
from skinviewer.ui.sections.look import QualitySection
from skinviewer.ui.state import ViewerState
from skinviewer.ui.widgets import (
    DIM,
    ERR,
    WARN,
    UiContext,
    error_list,
    tooltip,
    wrapped,
)


class StatusSection:
    """Scene description, current preset (unsaved marker), the last change's cost, refused edits, render and shader errors, notes."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame

    def draw(self, ui: UiContext) -> None:
        st, fr = self.state, self.frame
        s = st.settings
        wrapped(st.scene.description if st.scene else "the scene is loading (the panel comes first)", DIM)
        p = st.presets
        marker = " (unsaved changes, Ctrl+S)" if p.dirty(s) else ""
        ro = " (shipped, read-only)" if p.read_only else ""
        imgui.text_colored(WARN if marker else DIM, f"preset: {Path(p.path).name if p.path else '(none)'}{ro}{marker}")
        if p.path:
            tooltip(p.path)
        change_line(self.frame, None)
        if st.errors:
            imgui.text_colored(ERR, f"refused: {st.error_title}")
            error_list(st.errors, 8)
            if imgui.small_button("dismiss##err"):
                st.dismiss_errors()
        if fr.render_error:
            wrapped(f"render: {fr.render_error}", ERR)
        errs = fr.watcher.errors
        if errs:
            n = sum(len(v) for v in errs.values())
            imgui.text_colored(ERR, f"shader errors ({n}) - last good programs still running:")
            shader_errors(self.frame.watcher, limit=4)
        for note in st.notices[-4:]:
            wrapped(note, DIM)
        imgui.separator()


class TechniqueSection:
    """Quality & cost: the active technique's resolutions and samples, the frame cost split into texture-space and view-dependent work, render scheduling and the time budget."""

    def __init__(self, state: ViewerState, frame: FrameController):
        self.state = state
        self.frame = frame
        self.quality = QualitySection(state, frame)

    def draw(self, ui: UiContext) -> None:
        fr = self.frame
        if not ui.header("Quality & cost", True):
            return
        self.quality.draw(ui)  # the technique (in Look) and its resolutions / samples
        self._cost_split()
        sch = fr.scheduler
        imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.5)
        ch, i = imgui.combo("while dragging", RENDER_MODES.index(sch.mode), list(RENDER_MODES))
        if ch:
            fr.set_schedule(mode=RENDER_MODES[i])
        tooltip("adaptive: render every frame while a slider is dragged unless the last change cost more than "
                "the budget; then render when it is released or held still.\n"
                "live: always render (the UI may freeze on slow GL).\n"
                "on release: render only on release / when held still.")
        if sch.mode == "adaptive":
            imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.5)
            ch, v = imgui.slider_float("budget (ms)", sch.budget_ms, 10.0, 2000.0, "%.0f ms",
                                       imgui.SliderFlags_.logarithmic.value)
            if ch:
                fr.set_schedule(budget_ms=v)
        spread = fr.frame_budget_ms is not None
        ch, spread = imgui.checkbox("spread long frames", spread)
        if ch:
            fr.set_frame_budget(100.0 if spread else None)
        tooltip("a change whose passes take longer than the budget is rendered over several frames: the UI "
                "stays responsive and the image changes once, complete")
        if fr.frame_budget_ms is not None:
            imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.5)
            ch, v = imgui.slider_float("frame budget", fr.frame_budget_ms, 16.0, 1000.0, "%.0f ms",
                                       imgui.SliderFlags_.logarithmic.value)
            if ch:
                fr.set_frame_budget(v)
        modes = list(DRAG_RESOLUTIONS)
        imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.5)
        ch, i = imgui.combo("orbit resolution", modes.index(fr.drag_resolution), modes)
        if ch:
            fr.set_drag_resolution(modes[i])
        tooltip("resolution of the view while the camera is dragged; full size again on release.\n"
                "auto: lower it just enough that the view-dependent passes fit "
                f"{fr.drag_budget_ms:.0f} ms (texture-space passes stay cached either way)")

    def _cost_split(self) -> None:
        """The technique's frame cost: this frame, and a full frame at the passes' last-run costs,
        split into texture-space (cached while orbiting) and view-dependent work."""
        fr = self.frame
        rep = fr.report
        if rep is None:
            imgui.text_disabled("no frame yet")
            return
        vset = fr.view_passes()
        live = [p for p in rep.passes if p.status != "pruned"]
        now_tex, now_view = split_ms(rep, vset, lambda p: p.ms if p.status == "ran" else None)
        full_tex, full_view = split_ms(rep, vset, lambda p: fr.last_ms.get(p.name) if p.status != "pruned" else None)
        imgui.text(f"this frame: {now_tex + now_view:.1f} ms")
        imgui.same_line()
        imgui.text_disabled(f"({len(rep.ran)} of {len(live)} passes ran, {rep.timing_mode} timing)")
        from skinviewer.kernel.graph import TIMING_NOTES
        tooltip(TIMING_NOTES.get(rep.timing_mode, ""))
        total = full_tex + full_view
        imgui.text("full frame:")
        imgui.same_line()
        imgui.text_colored(TEX_COL, f"texture-space {full_tex:.0f} ms")
        imgui.same_line()
        imgui.text("+")
        imgui.same_line()
        imgui.text_colored(VIEW_COL, f"view {full_view:.0f} ms")
        tooltip("at each live pass's last measured cost.\n"
                "texture-space: re-run only when their settings / lights / mesh change;\n"
                "view-dependent: re-run on every camera move (orbit cost).")
        # a two-colour bar: the share of each
        w = imgui.get_content_region_avail().x
        p0 = imgui.get_cursor_screen_pos()
        hbar = 6.0
        dl = imgui.get_window_draw_list()
        dl.add_rect_filled(p0, imgui.ImVec2(p0.x + w, p0.y + hbar), imgui.get_color_u32(imgui.ImVec4(0.2, 0.2, 0.24, 1)))
        if total > 0:
            xt = p0.x + w * full_tex / total
            dl.add_rect_filled(p0, imgui.ImVec2(xt, p0.y + hbar), imgui.get_color_u32(TEX_COL))
            dl.add_rect_filled(imgui.ImVec2(xt, p0.y), imgui.ImVec2(p0.x + w, p0.y + hbar), imgui.get_color_u32(VIEW_COL))
        imgui.dummy(imgui.ImVec2(w, hbar + 2))
