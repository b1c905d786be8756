"""When to render. Idle frames render nothing new (the pass graph finds every pass cached; the UI
never edits settings unless a widget changed). While the user holds a widget (slider drag) whose
changes are expensive -- the last change that re-ran passes cost more than ``budget_ms`` -- the new
value is shown in the panel at once but the scene is re-rendered only when the widget is released
or held still for ``rest_s``: the UI stays responsive on slow GL (llvmpipe) instead of freezing for
seconds per slider step. On a real GPU changes cost a few ms, so "adaptive" renders every frame.

Also the accounting the panel shows: the cost of the last change (which passes it re-ran, split
into texture-space and view-dependent work)."""
from __future__ import annotations

import re
import time
from dataclasses import dataclass, field

MODES = ("adaptive", "live", "on release")


@dataclass
class ChangeCost:
    source: str  # what caused it: a settings path ("deon.gaussians.2.variance"), "orbit", "technique", ...
    total_ms: float
    texture_ms: float
    view_ms: float
    passes: list[tuple[str, float]] = field(default_factory=list)  # (pass, ms), most expensive first
    timing_mode: str = "sync"
    when: float = 0.0

    def section(self) -> str:
        """The settings group that caused it: "deon" for "deon.gaussians.2.variance", "camera" for "camera (orbit)"."""
        m = re.match(r"[A-Za-z_]+", self.source or "")
        return m.group(0) if m else ""


def view_side(report, view_dependent: set[str]) -> set[str]:
    """Passes of a frame report that are view-dependent or downstream of one (e.g. the output pass):
    the work an orbit redoes. Everything else is texture-space (or view-independent) work."""
    from_view: set[str] = set()
    view_res: set[str] = set()
    for p in report.passes:  # the report lists live passes in execution order
        if p.name in view_dependent or any(i in view_res for i in p.inputs):
            from_view.add(p.name)
            view_res.update(p.outputs)
    return from_view


def split_ms(report, view_passes: set[str], ms_of) -> tuple[float, float]:
    tex = view = 0.0
    for p in report.passes:
        ms = ms_of(p)
        if ms is None:
            continue
        if p.name in view_passes:
            view += ms
        else:
            tex += ms
    return tex, view


class RenderScheduler:
    def __init__(self, mode: str = "adaptive", budget_ms: float = 120.0, rest_s: float = 0.35):
        self.mode = mode
        self.budget_ms = budget_ms
        self.rest_s = rest_s
        self.changed_at = 0.0  # when the settings last changed
        self.deferred = False  # this frame showed the previous image although settings changed

    def configure(self, mode: str | None = None, budget_ms: float | None = None) -> None:
        if mode is not None:
            if mode not in MODES:
                raise ValueError(f"render scheduling '{mode}' (have: {', '.join(MODES)})")
            self.mode = mode
        if budget_ms is not None:
            self.budget_ms = float(budget_ms)

    def set_deferred(self, on: bool) -> None:
        self.deferred = bool(on)

    def note_change(self, now: float | None = None) -> None:
        self.changed_at = time.perf_counter() if now is None else now

    def should_defer(self, pending: bool, widget_active: bool, last_cost_ms: float | None,
                     now: float | None = None) -> bool:
        """True: keep showing the last image this frame (the change is rendered later)."""
        now = time.perf_counter() if now is None else now
        if not pending or not widget_active or self.mode == "live":
            return False
        if now - self.changed_at >= self.rest_s:
            return False  # held still: render it
        if self.mode == "on release":
            return True
        return last_cost_ms is not None and last_cost_ms > self.budget_ms


class RunningCost:
    """A running estimate of a cost that varies frame to frame (the UI and presenting around the
    render: a buffer swap under Xvfb is 7-40 ms here): an exponentially weighted mean and mean
    absolute deviation, and the last ``window`` samples. ``upper`` -- what a frame budgets for it, so
    that the *whole* frame, not the render alone, keeps to the budget (issue 27) -- is the larger of
    the mean plus ``k`` deviations and the largest recent sample: a swap that spikes every few frames
    is budgeted, not averaged away, and a load that eases gives the room back within ``window``."""

    def __init__(self, weight: float = 0.2, k: float = 2.0, window: int = 20, cap: float | None = None):
        from collections import deque
        self.weight = weight
        self.k = k
        self.cap = cap  # a sample above this is taken as this (a pause between frames is not a frame's cost)
        self.mean: float | None = None
        self.dev = 0.0
        self.n = 0
        self.recent: deque[float] = deque(maxlen=window)

    def add(self, ms: float) -> None:
        if not (ms >= 0.0) or ms == float("inf"):  # NaN, negative, inf: not a measurement
            return
        if self.cap is not None:
            ms = min(ms, self.cap)
        self.n += 1
        self.recent.append(ms)
        if self.mean is None:
            self.mean, self.dev = ms, 0.25 * ms  # one sample says little about its spread
            return
        w = self.weight
        self.dev = (1.0 - w) * self.dev + w * abs(ms - self.mean)
        self.mean = (1.0 - w) * self.mean + w * ms

    def upper(self) -> float | None:
        """What to budget for it: mean + k deviations, or the largest recent sample if larger (None:
        never measured)."""
        if self.mean is None:
            return None
        return max(self.mean + self.k * self.dev, max(self.recent))
