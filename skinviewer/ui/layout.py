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


# -- the floating windows over the 3D view (issue 34: layouts that fit 960x600) -----------------------
MARGIN = 8.0
ACCURACY_MAX_W, PASSES_MAX_W = 460.0, 380.0
FLOAT_MIN_W = 200.0
FLOAT_MAX_H = 560.0


def floating_rects(view: Rect) -> dict[str, Rect]:
    """The Accuracy and Passes windows' first rectangles (expanded): side by side along the top of
    the 3D view, Accuracy at the left, Passes at the right, each at most half the view less the
    margins, so neither covers the panel, the status bar or the other; as tall as the view allows
    (up to ``FLOAT_MAX_H``) so the Accuracy window's Pareto chart fits without scrolling."""
    vx, vy, vw, vh = view
    half = max((vw - 3 * MARGIN) / 2, 1.0)
    h = max(min(FLOAT_MAX_H, vh - 2 * MARGIN), 1.0)
    aw, pw = min(ACCURACY_MAX_W, half), min(PASSES_MAX_W, half)
    return {"accuracy": (vx + MARGIN, vy + MARGIN, aw, h),
            "passes": (vx + vw - MARGIN - pw, vy + MARGIN, pw, h)}


def keep_inside(rect: Rect, area: Rect) -> tuple[float, float]:
    """The position that keeps ``rect`` (a window the user moved) inside ``area`` (the view, after a
    resize or the panel moved): moved, never resized; the top-left corner wins when it is larger."""
    x, y, w, h = rect
    ax, ay, aw, ah = area
    return max(ax, min(x, ax + aw - w)), max(ay, min(y, ay + ah - h))


def overlaps(a: Rect, b: Rect) -> bool:
    return a[0] < b[0] + b[2] and b[0] < a[0] + a[2] and a[1] < b[1] + b[3] and b[1] < a[1] + a[3]


def flow_rows(widths: list[float], avail: float, gap: float) -> list[list[int]]:
    """Items of these widths laid out left to right, wrapped to a new row when the next one would
    pass ``avail`` (a legend that never runs past its window's edge; an item wider than ``avail``
    has a row of its own)."""
    rows: list[list[int]] = []
    x = 0.0
    for i, w in enumerate(widths):
        if rows and rows[-1] and x + gap + w <= avail:
            rows[-1].append(i)
            x += gap + w
        else:
            rows.append([i])
            x = w
    return rows
