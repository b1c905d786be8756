"""Window layout: a docked settings column (left or right, user-resizable), a status bar along the
bottom and the 3D view in the rest. Rectangles are in window coordinates (what mouse events and
imgui use); ``view_fb`` is the 3D view in framebuffer pixels with a bottom-left origin (what GL's
viewport and the render size use), so HiDPI windows (framebuffer larger than the window) render
at full framebuffer resolution. Pure logic: testable without a window."""
from __future__ import annotations

from dataclasses import dataclass

PANEL_DEFAULT_W = 400.0
PANEL_MIN_W = 260.0
PANEL_MAX_FRAC = 0.5  # the panel never takes more than half the window
STATUS_H = 24.0

Rect = tuple[float, float, float, float]  # x, y, w, h (window coordinates, top-left origin)


@dataclass(frozen=True)
class Layout:
    window: tuple[int, int]
    framebuffer: tuple[int, int]
    panel: Rect | None  # None: UI hidden
    status: Rect | None
    view: Rect
    view_fb: tuple[int, int, int, int]  # x, y (bottom-left origin), w, h in framebuffer pixels

    @property
    def scale(self) -> tuple[float, float]:
        return (self.framebuffer[0] / max(self.window[0], 1), self.framebuffer[1] / max(self.window[1], 1))

    def in_view(self, x: float, y: float) -> bool:
        vx, vy, vw, vh = self.view
        return vx <= x < vx + vw and vy <= y < vy + vh


def panel_width(requested: float, window_w: float) -> float:
    """The panel width actually used: the user's width, clamped so the view keeps at least half the window."""
    hi = max(window_w * PANEL_MAX_FRAC, 1.0)
    lo = min(PANEL_MIN_W, window_w * 0.45)
    return float(max(lo, min(hi, requested)))


def compute_layout(window: tuple[int, int], framebuffer: tuple[int, int], show_ui: bool,
                   requested_panel_w: float = PANEL_DEFAULT_W, side: str = "left",
                   status_h: float = STATUS_H) -> Layout:
    ww, wh = max(int(window[0]), 1), max(int(window[1]), 1)
    fw, fh = max(int(framebuffer[0]), 1), max(int(framebuffer[1]), 1)
    if not show_ui:
        return Layout((ww, wh), (fw, fh), None, None, (0.0, 0.0, float(ww), float(wh)), (0, 0, fw, fh))
    pw = panel_width(requested_panel_w, ww)
    sh = min(float(status_h), wh * 0.25)
    body_h = max(wh - sh, 1.0)
    if side == "right":
        panel = (ww - pw, 0.0, pw, body_h)
        view = (0.0, 0.0, ww - pw, body_h)
    else:
        panel = (0.0, 0.0, pw, body_h)
        view = (pw, 0.0, ww - pw, body_h)
    status = (0.0, body_h, float(ww), sh)
    sx, sy = fw / ww, fh / wh
    x0, x1 = round(view[0] * sx), round((view[0] + view[2]) * sx)
    y0, y1 = round(view[1] * sy), round((view[1] + view[3]) * sy)  # top-left origin
    view_fb = (int(x0), int(fh - y1), max(int(x1 - x0), 16), max(int(y1 - y0), 16))
    return Layout((ww, wh), (fw, fh), panel, status, view, view_fb)
