"""The status bar along the bottom of the window: scene, triangle count, technique, render size,
timing mode, frame time, unsaved-changes marker and the last message (errors in red)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from imgui_bundle import imgui

from skinviewer.ui.widgets import ERR, WARN, UiContext, begin_docked, tooltip

DIM = imgui.ImVec4(0.62, 0.62, 0.68, 1.0)
TEXT = imgui.ImVec4(0.88, 0.88, 0.9, 1.0)

_FLAGS = (imgui.WindowFlags_.no_title_bar | imgui.WindowFlags_.no_resize | imgui.WindowFlags_.no_move
          | imgui.WindowFlags_.no_scrollbar | imgui.WindowFlags_.no_scroll_with_mouse
          | imgui.WindowFlags_.no_collapse | imgui.WindowFlags_.no_saved_settings
          | imgui.WindowFlags_.no_bring_to_front_on_focus | imgui.WindowFlags_.no_focus_on_appearing
          | imgui.WindowFlags_.no_nav)


def triangle_count(scene) -> int | None:
    if scene is None:
        return None
    return int(np.asarray(scene.gpu.mesh.indices).size // 3)


class StatusBar:
    def __init__(self, state, frame):
        self.state = state
        self.frame = frame

    def fields(self) -> list[tuple[str, imgui.ImVec4]]:
        """(text, colour) items left to right (also used by tests)."""
        st, fr = self.state, self.frame
        s = st.settings
        out: list[tuple[str, imgui.ImVec4]] = []
        name = Path(s.scene.mesh).name if s.scene.mesh else s.scene.name
        tris = triangle_count(st.scene)
        out.append((f"{name}" + (f"  {tris:,} tris" if tris is not None else ""), TEXT))
        shown = st.compare.shown()  # A/B: name what the view shows, not the live state's technique
        out.append((f"A/B {shown}" if shown else s.technique, TEXT))
        out.append((f"{s.render.width}x{s.render.height} px", DIM))
        mode = fr.report.timing_mode if fr.report is not None else s.render.timing
        out.append((f"{mode} timing", DIM))
        ft = list(fr.frame_ms)[-20:]
        out.append((f"frame {np.mean(ft):.1f} ms" if ft else "frame -", TEXT))
        gov = fr.governor_status  # the quality governor: what is shown (issue 27)
        if gov:
            out.append((gov, WARN))
        if fr.render_deferred:
            out.append(("preview paused while dragging", WARN))
        bake = st.scene.gpu.env_bake_status() if st.scene is not None and hasattr(st.scene, "gpu") else ""
        if bake:  # the environment's visibility, baked in the background (issue 32)
            out.append((bake, ERR if "failed" in bake else WARN))
        if fr.report is not None and not fr.report.complete:
            out.append((f"rendering: {len(fr.report.deferred)} passes to go", WARN))
        if st.presets.dirty(s):
            out.append(("* unsaved", WARN))
        text, is_err = st.message
        if fr.render_error and not is_err:
            text, is_err = f"render: {fr.render_error.splitlines()[0]}", True
        if text:
            out.append((text, ERR if is_err else DIM))
        return out

    def draw(self, ui: UiContext) -> None:
        r = ui.layout.status
        if r is None:
            return
        begin_docked("##statusbar", r, _FLAGS, imgui.ImVec4(0.13, 0.13, 0.15, 1.0), padding=(8, 3))
        for i, (text, col) in enumerate(self.fields()):
            if i:
                imgui.same_line()
                imgui.text_colored(DIM, "|")
                imgui.same_line()
            full = text
            avail = imgui.get_content_region_avail().x
            if imgui.calc_text_size(text).x > avail > 0:  # cut at the window's edge: say so ("..."), in full in the tooltip
                while len(text) > 4 and imgui.calc_text_size(text + "...").x > avail:
                    text = text[:max(4, int(len(text) * 0.9))]
                text += "..."
            imgui.text_colored(col, text)
            if i == 0:
                sc = self.state.scene
                tooltip(sc.description if sc else "no scene")
            elif full != text or (full == self.state.message[0] and len(full) > 40):
                tooltip(full)  # a long field is cut at the window edge: in full here
        imgui.end()
        ui.claim(r)
