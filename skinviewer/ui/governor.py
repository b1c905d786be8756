"""The quality governor (issue 27): while the user drags or edits, each technique shows the most
accurate rung of its own preview ladder (techniques/preview.py) whose measured cost on this machine
(engine/calibration.py) fits the interaction budget; when input stops it refines, step by step, up
to the user's own settings, never going back down while the view is still. The last step renders
the user's settings themselves, so the final image is the ungoverned render, bit for bit.

Modes (``render.governor``): ``off`` (today's viewer: every frame renders the user's settings,
spread over frames by the frame budget), ``interactive`` (the default in the viewer), and
``fixed-budget`` (the pick that fits the budget is shown even when still: a constant frame cost).
``skinviewer render`` and ``bench`` never use it: it is a viewer-side policy over the settings a
frame renders, not a change to any technique.

A camera drag only considers rungs that keep the texture-space work already made (the same
changes as the image on screen, on a smaller view), timed by their camera-move cost; any other
edit considers every rung, timed by its light-move cost.

The costs are the calibration's until the viewer has seen a rung's frames itself: each complete
frame the viewer renders is reported (``observe``) and its cost replaces the calibrated one (a
running mean), and rungs not yet seen are scaled by how far the seen ones are from their
calibration (the machine's load, another window size, a calibration made on a busier day)."""
from __future__ import annotations

from dataclasses import dataclass

from skinviewer.engine.calibration import Calibration, Entry, rung_settings, truth_note
from skinviewer.ground.settings import Settings
from skinviewer.techniques.preview import FINAL, Rung, ladder

MODES = ("off", "interactive", "fixed-budget")
REFINE_STEP_SHARE = 0.1  # an intermediate refinement step costs at most this share of the final frame
SKIP_STEP_FRAMES = 2.0  # no intermediate step when the final frame costs at most this many frames' room
FIT_MARGIN = 0.85  # a rung fits when its cost is within this share of the frame's render budget
OBSERVED_WEIGHT = 0.5  # the running mean of the costs seen: the newest frame's share


@dataclass
class Pick:
    rung: Rung
    ms: float | None  # its calibrated cost for the interaction at hand (None: not calibrated)
    error: float | None
    note: str = ""  # why (nothing fits, budget <= 0, no calibration)


class Governor:
    def __init__(self, mode: str = "interactive", budget_ms: float = 100.0, calibration: Calibration | None = None):
        self.mode = mode
        self.budget_ms = float(budget_ms)
        self.calibration = calibration
        self.shown: Rung = FINAL  # the rung whose frame is on screen (or being rendered)
        self._plan: list[Rung] = []  # the refinement steps left, in order, ending with FINAL
        self._steps = 0  # refinement steps in the current plan (for "refining 2/4")
        self._pick: Pick | None = None
        self._memo: tuple | None = None  # (user settings, rung, rendered settings)
        self._was_interacting = False  # the last rung_for was an interaction's (the next still one releases)
        self.message = ""  # one line: why the pick is what it is (budget, nothing fits, calibrating)
        # what a displayed frame costs here besides rendering (UI, presenting): a rung fits when its
        # render cost plus this is within the budget (the frame controller keeps it up to date)
        self.overhead_ms = 0.0
        # the render graph's margin (kernel/margin.py: the p99 of its recent actual / predicted costs): the
        # graph stops a frame once its next work, at that upper bound, would pass the budget, so a rung
        # fits one frame when its cost times this does (issue 27, session 10); 1: no margin known
        self.margin = 1.0
        # costs seen here: (technique, rung, camera) -> running mean ms of its complete frames
        self._seen: dict[tuple[str, Rung, bool], float] = {}

    # -- configuration ---------------------------------------------------------------------------
    def configure(self, mode: str | None = None, budget_ms: float | None = None) -> None:
        if mode is not None:
            if mode not in MODES:
                raise ValueError(f"render.governor '{mode}' (have: {', '.join(MODES)})")
            if mode != self.mode:
                self._plan, self.shown = [], FINAL
            self.mode = mode
        if budget_ms is not None:
            self.budget_ms = float(budget_ms)

    def set_overhead(self, ms: float | None) -> None:
        """What a displayed frame costs here besides rendering (None: not measured yet)."""
        self.overhead_ms = max(float(ms or 0.0), 0.0)

    def set_margin(self, factor: float | None) -> None:
        """The render graph's margin on its predicted costs (None: not known yet; at least 1)."""
        self.margin = max(float(factor or 1.0), 1.0)

    def hold(self, rung: Rung) -> None:
        """The frame controller finishes a frame of ``rung`` begun earlier (a drag's frame part-way):
        that is what is shown, whatever this frame's pick was."""
        self.shown = rung

    def start_at(self, rung: Rung) -> None:
        """Show ``rung`` now, then the user's settings once its frame is complete (issue 34: the cold
        start's first image, the ladder's declared cheapest rung, before any calibration exists)."""
        self.shown = rung
        self._plan = [] if rung.final else [FINAL]
        self._steps = len(self._plan)
        self.message = ""

    def set_calibration(self, cal: Calibration | None) -> None:
        """The calibration to pick on (None: none; the viewer renders the user's settings)."""
        self.calibration = cal
        self._memo = None

    @property
    def active(self) -> bool:
        return self.mode != "off"

    # -- the pick ------------------------------------------------------------------------------
    def entry(self, technique: str, rung: Rung) -> Entry | None:
        return None if self.calibration is None else self.calibration.entry(technique, rung)

    def calibrated(self, technique: str, rung: Rung, camera: bool) -> float | None:
        """The calibration's cost of ``rung`` for a camera (or any other) change; None: not measured."""
        e = self.entry(technique, rung)
        return None if e is None else (e.camera_ms if camera else e.light_ms)

    def cost(self, technique: str, rung: Rung, camera: bool) -> float | None:
        """What a frame of ``rung`` costs on this machine now: the running mean of its frames seen
        here, else its calibrated cost times the scale the seen rungs show; None: not calibrated."""
        seen = self._seen.get((technique, rung, camera))
        if seen is not None:
            return seen
        cal = self.calibrated(technique, rung, camera)
        return None if cal is None else cal * self.scale(technique)

    def observe(self, technique: str, rung: Rung, camera: bool, ms: float) -> None:
        """A complete frame of ``rung`` (a camera-only change when ``camera``) cost ``ms`` here."""
        if not (ms > 0.0 and ms < 1e7):  # NaN, 0 (nothing ran) or absurd: not a measurement
            return
        key = (technique, rung, camera)
        old = self._seen.get(key)
        self._seen[key] = ms if old is None else (1.0 - OBSERVED_WEIGHT) * old + OBSERVED_WEIGHT * ms

    def scale(self, technique: str) -> float:
        """Seen over calibrated cost, the median over the rungs seen of ``technique`` (of every
        technique when none of it was seen yet); 1 when nothing comparable was seen."""
        def ratios(only: str | None) -> list[float]:
            out = []
            for (t, rung, camera), ms in self._seen.items():
                if only is not None and t != only:
                    continue
                cal = self.calibrated(t, rung, camera)
                if cal is not None and cal > 0.0:
                    out.append(ms / cal)
            return out
        r = ratios(technique) or ratios(None)
        if not r:
            return 1.0
        r.sort()
        n = len(r)
        return r[n // 2] if n % 2 else 0.5 * (r[n // 2 - 1] + r[n // 2])

    def _accuracy_order(self, technique: str, rungs: list[Rung]) -> list[Rung]:
        """Least accurate first: by error against the truth where every rung has one, else by the
        cost of a light move (the front's assumption: what costs more is closer), FINAL last."""
        entries = {r: self.entry(technique, r) for r in rungs}
        errors = {r: e.error for r, e in entries.items() if e is not None and e.error is not None}
        rest = [r for r in rungs if not r.final]
        if rest and all(r in errors for r in rest):
            rest.sort(key=lambda r: -errors[r])
        else:
            light = {r: e.light_ms if e is not None else 0.0 for r, e in entries.items()}
            rest.sort(key=lambda r: light[r])
        return rest + [r for r in rungs if r.final]

    def room(self) -> float:
        """What a rung's render may cost to fit: the budget less the rest of a frame (UI,
        presenting), with a margin (a pick that just fits is split over two frames by the graph's
        own budget whenever the machine is a little slower than last time) -- or the graph's own margin
        (``set_margin``) where that is wider: a rung that fits the graph's look-ahead in one frame."""
        return min(FIT_MARGIN, 1.0 / self.margin) * (self.budget_ms - max(self.overhead_ms, 0.0))

    def pick(self, s: Settings, camera: bool = False) -> Pick:
        """The most accurate rung of ``s``'s ladder that fits the budget on the calibration held
        (for a camera drag: only rungs keeping the texture-space work on screen). Budget <= 0 or
        nothing fits: the cheapest, with a note saying so. No calibration: FINAL, noted."""
        t = s.technique
        rungs = ladder(s)
        if camera:
            rungs = [r for r in rungs if r.changes in ({}, self.shown.changes)]
        if self.calibration is None or t not in self.calibration.entries:
            return Pick(FINAL, None, None, "governor: no calibration for this technique yet (shown at your settings)")
        timed = [(r, ms) for r in rungs if (ms := self.cost(t, r, camera)) is not None]
        if not timed:
            return Pick(FINAL, None, None, "governor: no calibration for this ladder (shown at your settings)")
        order = self._accuracy_order(t, [r for r, _ in timed])
        ms_of = dict(timed)
        cheapest = min(timed, key=lambda x: x[1])[0]
        if self.budget_ms <= 0:
            note = f"governor budget {self.budget_ms:g} ms is not positive: showing the cheapest configuration"
            return Pick(cheapest, ms_of[cheapest], self._error(t, cheapest), note)
        room = self.room()
        fits = [r for r in order if ms_of[r] <= room]
        if not fits:
            note = (f"nothing fits the {self.budget_ms:g} ms budget on this machine (cheapest: "
                    f"{ms_of[cheapest]:.0f} ms): showing the cheapest configuration")
            return Pick(cheapest, ms_of[cheapest], self._error(t, cheapest), note)
        best = fits[-1]
        return Pick(best, ms_of[best], self._error(t, best))

    def _error(self, technique: str, rung: Rung) -> float | None:
        e = self.entry(technique, rung)
        return None if e is None else e.error

    # -- per frame -----------------------------------------------------------------------------
    def rung_for(self, s: Settings, interacting: bool, camera: bool, last_complete: bool) -> Rung:
        """The rung to render this frame. ``interacting``: the user drags or edits (a camera-only
        drag when ``camera``); ``last_complete``: the last frame finished (its rung is on screen)."""
        if not self.active:
            self.shown, self._plan, self.message, self._was_interacting = FINAL, [], "", False
            return FINAL
        if interacting or self.mode == "fixed-budget":
            self._was_interacting = interacting
            p = self.pick(s, camera and interacting)
            self._pick, self.message = p, p.note
            self.shown = p.rung
            self._plan = [] if self.mode == "fixed-budget" else self._refinement(s, p.rung)
            self._steps = len(self._plan)
            return self.shown
        # still: once the frame on screen is complete, step up (never down) towards FINAL; the first
        # still frame steps up at once: a preview frame the drag left part-way is abandoned, not
        # finished (the refinement redoes its work; finishing it cost separable, burley2 and Penner
        # a preview frame, 12-15 % of their release -> final). A refinement step's own frame is
        # never left unfinished while still.
        if self._plan and (last_complete or self._was_interacting):
            self.shown = self._plan.pop(0)
        self._was_interacting = False
        return self.shown

    def _refinement(self, s: Settings, start: Rung) -> list[Rung]:
        """Steps from ``start`` up to FINAL: at most one intermediate rung (the most accurate costing
        at most REFINE_STEP_SHARE of the final frame and more accurate than ``start``), then FINAL."""
        if start.final:
            return []
        t = s.technique
        order = self._accuracy_order(t, ladder(s))
        above = order[order.index(start) + 1:-1] if start in order else []
        final_ms = self.cost(t, FINAL, False)
        if final_ms is not None and final_ms <= SKIP_STEP_FRAMES * self.room():
            # the final image is at most this many frames away: an intermediate image would be on screen
            # for about one frame and cost its own frame of rendering and presenting (issue 27: release ->
            # final); it is shown straight away instead
            return [FINAL]
        cheap = [r for r in above if final_ms is not None and (self.cost(t, r, False) or 0.0) <= REFINE_STEP_SHARE * final_ms]
        return ([cheap[-1]] if cheap else []) + [FINAL]

    def settings_for(self, s: Settings, rung: Rung) -> Settings:
        """``s`` with ``rung`` applied (the same object for FINAL; memoised, so an idle frame hands
        the graph the very same settings object and stays idle)."""
        if rung.final:
            return s
        if self._memo is not None and self._memo[0] is s and self._memo[1] == rung:
            return self._memo[2]
        out = rung_settings(s, Rung(rung.label, rung.changes))  # the view scale: the frame sizes the view
        self._memo = (s, rung, out)
        return out

    @property
    def refining(self) -> bool:
        return bool(self._plan)

    def status(self, s: Settings) -> str:
        """What is shown: "preview: irradiance 256², separable blurs, 6.1 % ± 1.9 from the truth · refining 2/4"."""
        if not self.active or (self.shown.final and not self._plan):
            return ""
        e = self._error(s.technique, self.shown)
        text = f"preview: {self.shown.label}" if not self.shown.final else "your settings"
        if e is not None:
            entry = self.entry(s.technique, self.shown)
            u = entry.uncertainty if entry is not None else None
            # the ruler's own uncertainty beside its figure (issue 30): "6.1 % ± 1.9"
            # (a comma, not a dash: the panel's font has no em dash)
            text += f", {100 * e:.1f} %{f' ± {100 * u:.1f}' if u is not None else ''} from the truth"
            note = truth_note(entry) if entry is not None else ""
            if note:  # measured against an older truth: "(truth version 8, now 10)"
                text += f" ({note})"
        if self._plan:
            done = self._steps - len(self._plan)
            text += f" · refining {done + 1}/{self._steps}"
        elif self.mode == "fixed-budget":
            text += f" · fixed {self.budget_ms:g} ms budget"
        return text


class BackgroundCalibration:
    """``engine.calibration.calibrate`` in a worker thread with its own headless context (the
    viewer's first start, or when the cached one is missing, stale or unreadable): the viewer stays
    live meanwhile (at the user's settings); ``result`` is set when it is done, ``error`` (one line)
    if it failed. ``cancel()`` stops it between rungs."""

    def __init__(self, base: Settings, names: list[str] | None = None, runs: int = 2,
                 into: Calibration | None = None):
        import threading
        self.base = base
        self.into = into
        self.names = names
        self.runs = runs
        self.result: Calibration | None = None
        self.error = ""
        self.progress = ("starting", 0, 1)
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, name="skinviewer-calibrate", daemon=True)

    def start(self) -> BackgroundCalibration:
        self.thread.start()
        return self

    def cancel(self) -> None:
        self._stop.set()

    @property
    def running(self) -> bool:
        return self.thread.is_alive()

    def _run(self) -> None:
        from skinviewer.engine import calibration
        from skinviewer.engine.renderer import Renderer
        from skinviewer.kernel.gl import headless_context
        try:
            ctx = headless_context()
        except Exception as exc:
            self.error = f"calibration: no headless OpenGL context ({exc})"
            return
        r = Renderer(ctx)
        try:
            cal = calibration.calibrate(r, self.base, self.names, self.runs,
                                        progress=lambda what, i, n: setattr(self, "progress", (what, i, n)),
                                        cancelled=self._stop.is_set, into=self.into)
            calibration.save(cal)
            self.result = cal
        except InterruptedError:
            self.error = "calibration cancelled"
        except Exception as exc:  # reported in the status bar; the viewer goes on ungoverned
            self.error = f"calibration failed: {type(exc).__name__}: {exc}"
        finally:
            r.release()
            ctx.release()
