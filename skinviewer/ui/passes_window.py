"""The passes window (floating over the 3D view: movable, collapsible): every pass of the current technique this frame (ran / cached / pruned,
reason, time and the timing mode), frame time / FPS with a history graph, and the output texture
inspector (click a pass: its output full-window; channel, exposure)."""
from __future__ import annotations

import numpy as np
from imgui_bundle import imgui

from skinviewer.kernel.graph import TIMING_NOTES
from skinviewer.ui.display import CHANNELS
from skinviewer.ui.layout import floating_rects, keep_inside
from skinviewer.ui.widgets import ERR, UiContext, tooltip

COLORS = {"ran": imgui.ImVec4(1.0, 0.7, 0.3, 1.0), "cached": imgui.ImVec4(0.5, 0.85, 0.5, 1.0),
          "pruned": imgui.ImVec4(0.55, 0.55, 0.6, 1.0), "deferred": imgui.ImVec4(0.5, 0.7, 1.0, 1.0)}


class PassesWindow:
    def __init__(self, state, frame):
        self.state = state
        self.frame = frame
        self.open = True
        self._rect: tuple[float, float, float, float] | None = None  # last frame's (x, y, w, h)

    def draw(self, ui: UiContext) -> None:
        vx, vy, vw, vh = ui.layout.view
        # first shown at the top-right corner of the 3D view, then wherever the user moves it; half the
        # view at most: the Accuracy window takes the top-left half (ui/layout.floating_rects), so
        # neither covers the other or the panel at 960x600
        x, y, w, h = floating_rects(ui.layout.view)["passes"]
        imgui.set_next_window_pos(imgui.ImVec2(x, y), imgui.Cond_.first_use_ever.value)
        imgui.set_next_window_size(imgui.ImVec2(w, h), imgui.Cond_.first_use_ever.value)
        if vw < 900:  # small views: start collapsed so the image stays visible
            imgui.set_next_window_collapsed(True, imgui.Cond_.first_use_ever.value)
        if self._rect is not None:
            # the window shrank (or the panel moved): keep the passes window inside the view
            nx, ny = keep_inside(self._rect, ui.layout.view)
            if (nx, ny) != self._rect[:2]:
                imgui.set_next_window_pos(imgui.ImVec2(nx, ny), imgui.Cond_.always.value)
        expanded = imgui.begin("Passes###passes")[0]
        if expanded:
            shown = self.state.compare.shown()
            if shown:  # the table is the live state's graph, not necessarily what the view shows
                imgui.push_text_wrap_pos(0)
                imgui.text_colored(imgui.ImVec4(1.0, 0.8, 0.4, 1.0),
                                   f"passes of the live state ({self.state.settings.technique}); view: {shown}")
                imgui.pop_text_wrap_pos()
            self._timing()
            self._inspector()
            self._table()
        pos, size = imgui.get_window_pos(), imgui.get_window_size()
        self._rect = (pos.x, pos.y, size.x, size.y)
        ui.claim(self._rect)
        imgui.end()

    def _timing(self) -> None:
        ft = np.array(self.frame.frame_ms, dtype=np.float32)
        if len(ft):
            avg = float(ft[-30:].mean())
            imgui.text(f"frame {avg:6.1f} ms   {1000.0 / max(avg, 1e-3):5.1f} FPS")
            imgui.plot_lines("##ft", ft, 0, None, 0.0, float(max(ft.max(), 1.0) * 1.1), imgui.ImVec2(-1, 40))
        else:
            imgui.text("frame -")

    def _table(self) -> None:
        fr, st = self.frame, self.state
        rep = fr.report
        if rep is None:
            imgui.text_disabled("no frame report")
            return
        imgui.text(f"{st.settings.technique}: {len(rep.ran)} ran, {len(rep.cached)} cached, {len(rep.pruned)} pruned"
                   + (f", {len(rep.deferred)} deferred to the next frame" if rep.deferred else ""))
        imgui.text_disabled(f"{rep.total_ms:.2f} ms ({rep.timing_mode} timing)")
        tooltip(TIMING_NOTES[rep.timing_mode])
        bad = getattr(rep, "nonfinite", {})
        if bad:  # render.check_finite: a pass wrote NaN/Inf (e.g. a shader edit); the screen stays finite
            imgui.text_colored(ERR, "NaN/Inf in " + ", ".join(f"{n} ({', '.join(o)})" for n, o in bad.items()))
        # scrolls sideways when the window is narrower than the table (a 960x600 window): no column cut off
        flags = (imgui.TableFlags_.borders_inner_h.value | imgui.TableFlags_.row_bg.value
                 | imgui.TableFlags_.sizing_fixed_fit.value | imgui.TableFlags_.scroll_x.value)
        if imgui.begin_table("passes", 4, flags):
            # the name and the time first (a 960x600 window shows these two without scrolling), the
            # name column and the header kept in place while the rest scrolls sideways
            imgui.table_setup_scroll_freeze(1, 1)
            imgui.table_setup_column("pass")
            imgui.table_setup_column("ms")
            imgui.table_setup_column("status")
            imgui.table_setup_column("reason")
            imgui.table_headers_row()
            for p in rep.passes:
                imgui.table_next_row()
                imgui.table_next_column()
                outs = list(p.outputs)
                selected = st.inspect.resource is not None and st.inspect.resource in outs
                if imgui.selectable(p.name, selected, imgui.SelectableFlags_.span_all_columns.value)[0]:
                    if selected:
                        st.set_inspect(None)
                    elif outs:
                        st.set_inspect(outs[0])
                imgui.table_next_column()
                if p.ms is not None:
                    imgui.text(f"{p.ms:.1f}")
                elif p.name in fr.last_ms:
                    imgui.text_disabled(f"({fr.last_ms[p.name]:.1f})")
                    tooltip("cost when it last ran")
                imgui.table_next_column()
                imgui.text_colored(COLORS.get(p.status, COLORS["pruned"]), p.status)
                imgui.table_next_column()
                if getattr(p, "nonfinite", None):
                    imgui.text_colored(ERR, "NaN/Inf")
                    imgui.same_line()
                imgui.text_disabled(p.reason[:60])
                if p.reason:
                    tooltip(p.reason)
                if p.note:  # a figure the pass measured (e.g. the GPU sample count)
                    imgui.text(p.note)
            imgui.end_table()

    def _inspector(self) -> None:
        st = self.state
        ins = st.inspect
        if ins.resource is None:
            imgui.text_disabled("click a pass to view its output full-window")
            return
        g = self.frame.renderer.graph(st.settings.technique)
        res = g.resources()
        imgui.separator_text("output inspector")
        names = sorted(res)
        if ins.resource not in res:
            imgui.text_colored(ERR, f"'{ins.resource}' is not allocated this frame")
        cur = names.index(ins.resource) if ins.resource in names else 0
        if names:
            ch, i = imgui.combo("texture", cur, names)
            if ch:
                st.set_inspect(names[i])
        spec = res.get(ins.resource)
        if spec is not None:
            imgui.text_disabled(f"{spec.size[0]}x{spec.size[1]}  {spec.components}ch  {spec.dtype}")
        ch, i = imgui.combo("channel", CHANNELS.index(ins.channel), list(CHANNELS))
        if ch:
            st.set_inspect_channel(CHANNELS[i])
        ch, v = imgui.slider_float("exposure", ins.exposure, 1e-3, 1e3, "%.3g", imgui.SliderFlags_.logarithmic.value)
        if ch:
            st.set_inspect_exposure(v)
        if imgui.button("back to the image (Esc)"):
            st.set_inspect(None)
        imgui.separator()
