"""The radial diffusion-profile plot of the d'Eon section and the profile lab.

GPU Gems 3 §14.4.6 (seed 002) recommends plotting r·R(r) against r: each radius is weighted by the
circle it is applied to, so the area under the curve is the total diffuse response. The radius range
follows the profile (up to the radius that holds all but 0.5 % of the widest Gaussian's response)
instead of a fixed 8 mm, sampled densely enough for the narrowest Gaussian.

On a log-r axis (an option: skin Gaussians span 0.08 to 1.4 mm of sigma, so on linear axes the
narrow ones are a spike near r = 0) the plot shows r²·R(r): the same area rule in d(ln r), so each
Gaussian is a bump whose height is proportional to its weight, whatever its width.

R(r) itself comes from ``skinviewer.physics.diffusion`` (one copy of the math). The plot takes no
mouse input: the wheel over it scrolls the panel instead of zooming the plot."""
from __future__ import annotations

import math

import numpy as np

from skinviewer.physics.diffusion import profile

TAIL = 0.005  # the range ends where the widest Gaussian has this fraction of its response left
CHANNELS = (("R", (1.0, 0.35, 0.3)), ("G", (0.35, 0.9, 0.4)), ("B", (0.4, 0.6, 1.0)))
PLOT_H = 190.0


def radius_range(gaussians) -> tuple[float, float]:
    """(r_min, r_max) in mm for a Gaussian table: from a tenth of the narrowest sigma to the radius
    outside which the widest Gaussian keeps ``TAIL`` of its energy (1 - exp(-r²/2v) = 1 - TAIL)."""
    vs = [float(g.variance) for g in gaussians if float(g.variance) > 0 and max(g.weights) > 0]
    if not vs:
        return 1e-3, 1.0
    r_max = math.sqrt(-2.0 * max(vs) * math.log(TAIL))
    r_min = 0.1 * math.sqrt(min(vs))
    return max(r_min, 1e-4), min(max(r_max, 0.05), 100.0)


def radii(r_min: float, r_max: float, log_r: bool, n: int = 400) -> np.ndarray:
    if log_r:
        return np.geomspace(max(r_min, 1e-4), r_max, n)
    return np.linspace(0.0, r_max, n)


def weighted(r: np.ndarray, R: np.ndarray, log_r: bool) -> np.ndarray:
    """r·R(r) (linear r) or r²·R(r) (log r): the curve whose area is the diffuse response."""
    w = r * r if log_r else r
    return np.ascontiguousarray(w[:, None] * np.asarray(R, dtype=np.float64))


def gaussian_curve(gaussians, log_r: bool, n: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """(r, weighted R) of a Gaussian table, R from ``physics.diffusion.profile`` (seed 000 eq. 20-21)."""
    r = radii(*radius_range(gaussians), log_r, n)
    return r, weighted(r, profile(r, gaussians), log_r)


def y_label(log_r: bool) -> str:
    return "r² R(r) (per ln r)" if log_r else "r R(r) (1/mm)"


def draw(title: str, series, log_r: bool, height: float = PLOT_H,
         legend: list | None = None, hidden: set[str] | None = None, rects: dict | None = None) -> tuple[float, float, float, float] | None:
    """One plot of ``series`` [(label, r, y, (r, g, b, a), thickness)]; returns its screen rect.
    No mouse input (``no_inputs``): the wheel scrolls the window it is in. ``hidden``: the caller's
    set of series labels a click on the legend has hidden; ``rects``: the legend items' rects."""
    from imgui_bundle import imgui, implot

    from skinviewer.ui.widgets import flow_legend
    p = imgui.get_cursor_screen_pos()
    w = imgui.get_content_region_avail().x
    # the legend above the plot, wrapped into rows at the panel's width (issue 34: implot's one-row
    # outside legend was cut at the panel's edge, "B look" at 960x600); it never hides the curves
    right, edge = flow_legend([(label, col) for label, _, _, col, _ in series], hidden=hidden, rects=rects)
    if legend is not None:  # (rightmost x drawn, the window's right edge): tests
        legend[:] = [right, edge]
    flags = implot.Flags_.no_inputs.value | implot.Flags_.no_menus.value | implot.Flags_.no_legend.value
    implot.push_style_var(implot.StyleVar_.fit_padding.value, imgui.ImVec2(0.0, 0.08))  # peaks not on the frame
    if implot.begin_plot(title, imgui.ImVec2(-1, height), flags):
        implot.setup_axes("r (mm)", y_label(log_r), implot.AxisFlags_.auto_fit.value, implot.AxisFlags_.auto_fit.value)
        if log_r:
            implot.setup_axis_scale(implot.ImAxis_.x1.value, implot.Scale_.log10.value)
        for label, r, y, col, thick in series:
            if hidden and label in hidden:
                continue
            implot.set_next_line_style(imgui.ImVec4(*col), thick)
            implot.plot_line(label, np.ascontiguousarray(r, dtype=np.float64), np.ascontiguousarray(y, dtype=np.float64))
        implot.end_plot()
    implot.pop_style_var()
    return (p.x, p.y, w, height)
