"""A/B marks on the image: while comparing, the 3D view carries an "A" and a "B" tag on each side of the
split divider (with the slot's technique), the shown slot's tag in toggle mode, and "|A - B|" on the
difference map -- so no screenshot of a comparison is ambiguous."""
from __future__ import annotations

from imgui_bundle import imgui

from skinviewer.ui.widgets import UiContext

A_COL = (0.35, 0.7, 1.0, 1.0)
B_COL = (1.0, 0.6, 0.25, 1.0)


def _tag(dl, x: float, y: float, text: str, col, right: bool = False) -> tuple[float, float, float, float]:
    size = imgui.calc_text_size(text)
    pad = 5.0
    x0 = x - size.x - 2 * pad if right else x
    dl.add_rect_filled(imgui.ImVec2(x0, y), imgui.ImVec2(x0 + size.x + 2 * pad, y + size.y + 2 * pad),
                       imgui.get_color_u32(imgui.ImVec4(0.0, 0.0, 0.0, 0.65)), 3.0)
    dl.add_rect(imgui.ImVec2(x0, y), imgui.ImVec2(x0 + size.x + 2 * pad, y + size.y + 2 * pad),
                imgui.get_color_u32(imgui.ImVec4(*col)), 3.0, 0, 1.5)
    dl.add_text(imgui.ImVec2(x0 + pad, y + pad), imgui.get_color_u32(imgui.ImVec4(*col)), text)
    return (x0, y, size.x + 2 * pad, size.y + 2 * pad)


class CompareOverlay:
    """Draws the A/B tags over the 3D view (no window, no input)."""

    def __init__(self, state, frame):
        self.state = state
        self.frame = frame
        self.tags: list[tuple[str, tuple[float, float, float, float]]] = []  # last frame's (text, rect): tests

    def draw(self, ui: UiContext) -> None:
        self.tags = []
        cmp = self.state.compare
        if not cmp.active or ui.layout is None or ui.layout.view is None:
            return
        vx, vy, vw, vh = ui.layout.view
        dl = imgui.get_foreground_draw_list()
        y = vy + vh - 34.0  # bottom of the view: the passes / accuracy windows sit at the top
        if cmp.mode == "split":
            xd = vx + cmp.divider * vw
            ta, tb = cmp.slot_name(cmp.a), cmp.slot_name(cmp.b)
            self.tags.append((ta, _tag(dl, xd - 6.0, y, ta, A_COL, right=True)))
            self.tags.append((tb, _tag(dl, xd + 6.0, y, tb, B_COL)))
        elif cmp.mode == "toggle":
            slot = cmp.b if cmp.show_b else cmp.a
            t = cmp.slot_name(slot) + "   (Space: flip)"
            self.tags.append((t, _tag(dl, vx + 10.0, y, t, B_COL if cmp.show_b else A_COL)))
        else:
            t = f"|A - B| x {cmp.diff_gain:g}   {cmp.slot_name(cmp.a)}  vs  {cmp.slot_name(cmp.b)}"
            self.tags.append((t, _tag(dl, vx + 10.0, y, t, (0.9, 0.9, 0.9, 1.0))))
