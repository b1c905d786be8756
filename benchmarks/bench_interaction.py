"""The viewer's interactivity with the quality governor off and on (issue 27), side by side in one
run: the real viewer's frame loop (a window: run it under Xvfb, `xvfb-run -a -s "-screen 0
1280x800x24" python3 benchmarks/bench_interaction.py`) driven through a scripted sequence per
technique: an orbit drag, a key-light drag, slider edits (the key light's intensity, one edit a
frame), then a still view until the image is final.

    python benchmarks/bench_interaction.py [--quick] [--techniques deon,phong] [--scenes head,scan | --scan]
        [--seconds 3] [--frame-log frames.jsonl] [--rest 1] [--prime on|off|both] [--cold-shaders]
        [--frames on|off|both] [--whole-frame on|off|both] [--share on|off|both] [--release-rules on|off|both]
        [--frame-rules on|off|both]

``--scenes``: the default head (default), the shared scan (``scan``: ../shared/assets/lee-perry-smith) or
both; ``--scan`` is ``--scenes head,scan``. At the end it prints the table ready to paste (markdown: per
scene and technique the governor off and on side by side, the load beside each row).

``--frame-log``: one JSON line per frame (technique, governor, phase, frame ms, the render graph's
wall ms and its own ms outside every pass -- RenderGraph.own_ms --, whether it presented, its buffer
swap's ms -- presenting under Xvfb, timed apart --, Python's collections in it (ms, generations), the
rung, the passes that ran): where a long frame's time went.

``--rest``: before each drag and the edits the user looks at the still, final image for this long (1 s;
and on, at most 30 s, until the viewer's idle priming of the next drag's preview variants is done --
ui/warm.Primer); those idle frames are timed apart (the "rests" table), not in the script's figures.
``--prime both``: the A/B of that priming, each arm in a fresh viewer (a new GL context: nothing
JIT-compiled yet); ``--cold-shaders`` turns Mesa's on-disk shader cache off, so every variant is
JIT-compiled at its first draw, as on a first run or for a variant never drawn on this machine.

Per technique and governor mode it prints:
- p95 of the interval between visible image updates while dragging (a frame that completed and ran
  passes puts a new image on screen); goal <= 150 ms;
- release -> final: from the last input to the complete image at the user's settings; its ratio to
  that settings' light-move frame measured alone (sync timing, no budget); goal <= 1.5;
- the longest main-thread stall (the longest frame of the loop, UI included); goal <= 100 ms (a frame
  that drew a program for the first time holds its JIT compile, which no band can split: such frames over
  100 ms are counted apart, "k compiles", with the longest frame without one); beside
  it that frame less its buffer swap (our work), the longest swap, the longest collection, how many
  frames took longer than 100 ms (of all the frames of the script) and the load average
  of the machine while the row was measured (one minute, os.getloadavg);
- the light drag's first 3 frames (the longest), the programs drawn for the first time during the
  drags (ShaderLibrary.first_draws: each a JIT compile on llvmpipe) and the longest frame of the rests;
- the preview's error against the ground truth (the calibration's figure for the rung shown at
  the end of the light drag: techniques/preview_errors.json, measured at 160² on the default view),
  and whether the final image equals the ungoverned render of the same settings bit for bit.

The defaults a user gets: the default settings (1024² maps), a 1040 x 700 window (the view beside
the 400 px panel is 640 px wide), the governor's 100 ms budget and the calibration of this machine
(measured first when missing: `skinviewer calibrate`). ``--quick``: d'Eon and Phong on the default
head, 1.5 s phases and 6 slider edits (the same settings, a shorter script)."""
from __future__ import annotations

import argparse
import gc
import json
import os
import statistics
import sys
import time

import numpy as np

from skinviewer.engine import calibration
from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.gl import describe

WINDOW = (1040, 700)


def p95(xs: list[float]) -> float:
    return float(np.percentile(xs, 95)) if xs else float("nan")


class GcTimer:
    """Python's garbage collections during a frame (gc.callbacks): ms and generations."""

    def __init__(self):
        self.ms = 0.0
        self.gens: list[int] = []
        self._t0 = 0.0
        gc.callbacks.append(self._cb)

    def _cb(self, phase, info):
        if phase == "start":
            self._t0 = time.perf_counter()
        else:
            self.ms += (time.perf_counter() - self._t0) * 1000.0
            self.gens.append(int(info["generation"]))

    def take(self) -> tuple[float, list[int]]:
        out = (self.ms, self.gens)
        self.ms, self.gens = 0.0, []
        return out


GC = GcTimer()


def _frame_mod():
    from skinviewer.ui import frame
    return frame


class Driver:
    """The scripted user: mouse drags and edits into a ViewerApp, one frame per step, timed."""

    def __init__(self, app, log=None, tag: dict | None = None):
        self.app = app
        self.log = log  # an open text file: one JSON line per frame (--frame-log)
        self.tag = dict(tag or {}, phase="settle")
        self.frame_ms: list[float] = []
        self.swap_ms: list[float] = []  # each frame's buffer swap (presenting under Xvfb), timed apart
        self.gc_ms: list[float] = []
        self.full_gcs = 0  # generation-2 collections during the script
        self.updates: list[float] = []  # perf_counter of frames that put a new, complete image on screen
        self._first_draws = app.frame.renderer.shaders.first_draws
        self.first_draws: dict[str, int] = {}  # per phase: programs drawn for the first time (a JIT each)
        self.idle_ms: list[float] = []  # the frames of the rests before each drag (the priming's)
        self.frame_fd: list[int] = []  # each frame's first draws (a program JIT-compiled there: a compile, not a band)
        # frames that ran passes under a budget: (the graph's wall ms, the budget it was given), the graph's
        # own keeping of its budget apart from the frame around it (the UI, the swap, the machine's stalls)
        self.graph_fits: list[tuple[float, float]] = []
        self.idle_fd: list[int] = []

    def step(self) -> None:
        GC.take()
        t0 = time.perf_counter()
        self.app.step(1)
        t1 = time.perf_counter()
        gc_ms, gens = GC.take()
        swap = getattr(self.app, "swap_ms", 0.0)
        self.frame_ms.append((t1 - t0) * 1000.0)
        self.swap_ms.append(swap)
        self.gc_ms.append(gc_ms)
        self.full_gcs += gens.count(2)
        fr = self.app.frame
        rep = fr.report
        if rep is not None and rep.complete and rep.ran:
            self.updates.append(t1)
        first = fr.renderer.shaders.first_draws - self._first_draws  # programs drawn for the first time
        self._first_draws += first
        self.first_draws[self.tag["phase"]] = self.first_draws.get(self.tag["phase"], 0) + first
        self.frame_fd.append(first)
        gb, g = getattr(fr, "last_budget_ms", None), fr.last_graph
        if gb is not None and g is not None and rep is not None and rep.ran and not first and self.tag["phase"] != "rest":
            self.graph_fits.append((g.run_ms, gb))
        if self.log is not None:
            self.log.write(json.dumps({**self.tag, "frame_ms": round((t1 - t0) * 1000.0, 2),
                                       "render_ms": round(fr._render_ms or 0.0, 2),
                                       "graph_own_ms": round(getattr(fr, "last_own_ms", 0.0), 2),
                                       "presented": fr.presented, "swap_ms": round(swap, 2),
                                       "gc_ms": round(gc_ms, 2), "gc_generations": gens, "rung": fr._rung.label,
                                       "first_draws": first, "primed": fr.primer.frames,
                                       "ran": [p.name for p in rep.passes if p.status == "ran"] if rep else [],
                                       # passes part-way through their bands: (bands done, bands)
                                       "bands": {k: list(v) for k, v in getattr(fr.last_graph, "in_progress", {}).items()},
                                       # each pass that ran or ran a band here: its ms (sync timing on llvmpipe)
                                       "pass_ms": {k: round(v, 1) for k, v in getattr(fr.last_graph, "frame_ms", {}).items()},
                                       "budget_ms": round(fr.graph_budget_ms() or 0.0, 1),
                                       "render_budget_ms": round(getattr(fr, "last_budget_ms", None) or 0.0, 1),
                                       "graph_run_ms": round(getattr(fr.last_graph, "run_ms", 0.0), 2),
                                       # its NaN/Inf checks (render.check_finite: frames not a preview's), in its run
                                       "check_ms": round(getattr(fr.last_graph, "check_ms", 0.0), 2),
                                       # the graph's margin on its predictions (every pass's p99: kernel/margin.py)
                                       "margin": round(fr.last_graph.margins.factor("") or 0.0, 2)
                                       if getattr(fr.last_graph, "margins", None) is not None else None,
                                       "overhead_ms": round(fr.overhead_ms or 0.0, 1),
                                       "whole_frame": _frame_mod().WHOLE_FRAME}) + "\n")

    def rest(self, seconds: float, cap_s: float = 30.0) -> float:
        """The user looks at the final image before the next drag: idle frames for ``seconds``, and
        on until the viewer's priming of the next drag's preview variants is done (at most
        ``cap_s``); their frame times go to ``idle_ms``, not the script's. Returns the seconds."""
        fr = self.app.frame
        self.tag["phase"] = "rest"
        start = time.perf_counter()
        n, gcs = len(self.frame_ms), self.full_gcs
        while time.perf_counter() - start < cap_s:
            self.step()
            el = time.perf_counter() - start
            if el >= seconds and (not (fr.primer.enabled and fr._governing) or fr.primer.error
                                  or not fr.primer.pending(fr.governor, fr.state.settings)):
                break
        self.idle_ms += self.frame_ms[n:]
        self.idle_fd += self.frame_fd[n:]
        del self.frame_ms[n:], self.swap_ms[n:], self.gc_ms[n:], self.frame_fd[n:]
        self.full_gcs = gcs  # the idle full collection (ui/collector.py) is the rest's, not the script's
        return time.perf_counter() - start

    def drag(self, button, seconds: float, dx: float = 6.0, dy: float = 1.5) -> list[float]:
        """Drag in the view for ``seconds``; the intervals between visible updates meanwhile (ms)."""
        app = self.app
        self.tag["phase"] = "orbit drag" if button == app.wnd.mouse.left else "light drag"
        vx, vy, vw, vh = app.frame.layout.view
        x, y = vx + vw * 0.5, vy + vh * 0.5
        app.on_mouse_position_event(x, y, 0, 0)
        app.on_mouse_press_event(x, y, button)
        start, n0 = time.perf_counter(), len(self.updates)
        k = 0
        while time.perf_counter() - start < seconds:
            k += 1
            # back and forth, the way back shorter: the drag never ends where it began (where the
            # user's settings are still cached, which would time a cache hit as the refinement)
            sgn = 1.0 if (k // 20) % 2 == 0 else -0.5
            x, y = x + sgn * dx, y + sgn * dy
            app.on_mouse_drag_event(x, y, sgn * dx, sgn * dy)
            self.step()
        app.on_mouse_release_event(x, y, button)
        times = [start] + self.updates[n0:] + [time.perf_counter()]
        return [(b - a) * 1000.0 for a, b in zip(times, times[1:])]

    def edits(self, n: int) -> list[float]:
        app = self.app
        self.tag["phase"] = "edits"
        start, n0 = time.perf_counter(), len(self.updates)
        base = app.state.settings.lights[0].intensity
        for k in range(n):
            app.state.apply({"lights.0.intensity": base * (1.0 + 0.02 * ((k % 5) + 1))}, "lights.0.intensity")
            self.step()
        app.state.apply({"lights.0.intensity": base}, "lights.0.intensity")
        self.step()
        times = [start] + self.updates[n0:] + [time.perf_counter()]
        return [(b - a) * 1000.0 for a, b in zip(times, times[1:])]

    def until_final(self, limit_s: float = 120.0) -> float:
        """ms from now (input released) to the complete image at the user's settings, on screen."""
        fr = self.app.frame
        self.tag["phase"] = "until final"
        start = time.perf_counter()
        while time.perf_counter() - start < limit_s:
            self.step()
            rep = fr.report
            still = fr.input_stopped  # a release ends the input at once; an edit after the rest time
            if still and rep is not None and rep.complete and not fr.governor.refining \
                    and fr.governor_status == "" and not fr._partial_ran and fr.presented:
                return (time.perf_counter() - start) * 1000.0
        return float("nan")


def full_frame_alone(app) -> float:
    """The user's settings' light-move frame, sync timing, no budget, measured alone (median of 2)."""
    s = app.state.settings
    r = app.renderer
    ms = []
    for k in range(2):
        d = list(s.lights[0].direction)
        d[0] += 0.03 if k % 2 == 0 else -0.03
        ms.append(r.render(with_values(s, {"lights.0.direction": d}), timing="sync").total_ms)
    r.render(s, timing="sync")
    return statistics.median(ms)


def run_one(app, technique: str, mode: str, seconds: float, n_edits: int, log=None, rest_s: float = 1.0,
            arm: dict | None = None) -> dict:
    from skinviewer.ground.settings import validate
    st = app.state
    st.set_settings(validate({**st.settings.model_dump(mode="json"), "technique": technique}), "technique")
    st.apply({"render.governor": mode})
    d = Driver(app, log, {"technique": technique, "governor": mode, **(arm or {})})  # arm: the A/B switches
    d.until_final()
    d.frame_ms.clear()
    d.swap_ms.clear()
    d.gc_ms.clear()
    d.frame_fd.clear()
    d.graph_fits.clear()
    d.full_gcs = 0
    d.first_draws.clear()
    load0 = os.getloadavg()[0]
    rested = d.rest(rest_s)
    drag = d.drag(app.wnd.mouse.left, seconds)
    orbit_final = d.until_final()
    rested += d.rest(rest_s)
    n_light = len(d.frame_ms)
    light = d.drag(app.wnd.mouse.right, seconds)
    light_start = max(d.frame_ms[n_light:n_light + 3], default=float("nan"))  # the light drag's first frames
    fr = app.frame
    shown = fr.governor.shown
    entry = fr.governor.entry(technique, shown) if mode != "off" else None
    preview_err = entry.error if entry is not None else None
    preview = shown.label if mode != "off" else "(your settings)"
    release = d.until_final()
    rested += d.rest(rest_s)
    edits = d.edits(n_edits)
    edit_final = d.until_final()
    live = st.settings
    img = app.renderer.image(live)
    app.renderer.render(live, force=True)
    identical = bool(np.array_equal(img, app.renderer.image(live)))
    alone = full_frame_alone(app)
    return {"technique": technique, "mode": mode, "p95_drag": p95(drag + light), "p95_orbit": p95(drag),
            "p95_light": p95(light), "p95_edits": p95(edits), "release_ms": release, "alone_ms": alone,
            "orbit_final_ms": orbit_final, "edit_final_ms": edit_final, "stall_ms": max(d.frame_ms),
            # our own work: the longest frame less its buffer swap (presenting under Xvfb, apart)
            "work_stall_ms": max(f - w for f, w in zip(d.frame_ms, d.swap_ms)), "swap_max_ms": max(d.swap_ms),
            "gc_max_ms": max(d.gc_ms), "full_gcs": d.full_gcs,
            "over_100": sum(ms > 100.0 for ms in d.frame_ms), "frames": len(d.frame_ms),
            "load": 0.5 * (load0 + os.getloadavg()[0]),
            "preview": preview, "preview_err": preview_err, "identical": identical,
            "light_start_ms": light_start, "idle_max_ms": max(d.idle_ms, default=0.0), "rest_s": rested,
            # a frame that drew a program for the first time holds its compile (llvmpipe's JIT at the first
            # draw, which no band can split): the longest frames and rests without one, and with one
            "stall_band_ms": max((f for f, c in zip(d.frame_ms, d.frame_fd) if not c), default=0.0),
            "over_100_compile": sum(f > 100.0 and c > 0 for f, c in zip(d.frame_ms, d.frame_fd)),
            "idle_band_ms": max((f for f, c in zip(d.idle_ms, d.idle_fd) if not c), default=0.0),
            "idle_compile_ms": max((f for f, c in zip(d.idle_ms, d.idle_fd) if c), default=0.0),
            "idle_compiles": sum(c > 0 for c in d.idle_fd),
            # the render graph against the budget it was given (frames that ran passes, no compile)
            "graph_over": sum(ms > b + 1.0 for ms, b in d.graph_fits), "graph_frames": len(d.graph_fits),
            "graph_over_p99": float(np.percentile([ms / b for ms, b in d.graph_fits], 99)) if d.graph_fits else float("nan"),
            "drag_first_draws": d.first_draws.get("orbit drag", 0) + d.first_draws.get("light drag", 0),
            "first_draws": dict(d.first_draws), "prime": app.frame.primer.enabled}


def _compiles(row: dict) -> str:
    """ " (k compiles, longest frame without one: x ms)" when k of the frames over 100 ms drew a program for
    the first time (its JIT, not a band: nothing the budget can split)."""
    k = row.get("over_100_compile", 0)
    return f" ({k} compiles; without: {row['stall_band_ms']:,.0f} ms)" if k else ""


def markdown(rows: list[dict], head: str) -> str:
    """The table ready to paste (notes/governor.md, the README): per scene and technique, the governor
    off and on side by side (one run), the load beside each row."""
    out = [head, "",
           "| scene | technique | p95 drags: off → on | p95 edits: off → on | release → final, on (× alone) "
           "| longest frame: off → on | on: its work / swap | on: frames > 100 ms | on: renders over their budget "
           "(p99 of render / budget) | on: full GCs | load |",
           "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    by = {(r["scene"], r["technique"], r["mode"], r["prime"]): r for r in rows}
    both = len({r["prime"] for r in rows}) > 1
    for (scene, t, mode, prime), on in by.items():
        if mode == "off":
            continue
        off = by.get((scene, t, "off", prime))
        if both:
            t = f"{t} (priming {'on' if prime else 'off'})"
        b = (lambda x: f"**{x:,.0f}**")
        p_off = f"{off['p95_drag']:,.0f}" if off else "-"
        e_off = f"{off['p95_edits']:,.0f}" if off else "-"
        s_off = f"{off['stall_ms']:,.0f}" if off else "-"
        ratio = on["release_ms"] / on["alone_ms"]
        load = f"{off['load']:.1f} / {on['load']:.1f}" if off else f"{on['load']:.1f}"
        out.append(f"| {scene} | {t} | {p_off} → {b(on['p95_drag'])} ms | {e_off} → {b(on['p95_edits'])} ms "
                   f"| {on['release_ms']:,.0f} ms ({ratio:.2f}×) | {s_off} → {b(on['stall_ms'])} ms "
                   f"| {on['work_stall_ms']:,.0f} / {on['swap_max_ms']:,.0f} ms | {on['over_100']} / {on['frames']}"
                   f"{_compiles(on)} | {on['graph_over']} / {on['graph_frames']} ({on['graph_over_p99']:.2f}) "
                   f"| {on['full_gcs']} | {load} |")
    out += ["", "The first draws (issue 27): the governor on, the light drag's first 3 frames (the longest), programs "
            "drawn for the first time during the drags (each a JIT compile on llvmpipe), the longest frame of the "
            "rests before each drag (the idle priming's slices), the rests' seconds in all:", "",
            "| scene | technique | priming | light drag's first frames | first draws in the drags "
            "| longest rest frame: no compile / a compile (rest frames compiling) | rests |",
            "| --- | --- | --- | --- | --- | --- | --- |"]
    for (scene, t, mode, prime), on in by.items():
        if mode != "off":
            out.append(f"| {scene} | {t} | {'on' if prime else 'off'} | {on['light_start_ms']:,.0f} ms "
                       f"| {on['drag_first_draws']} | {on['idle_band_ms']:,.0f} / {on['idle_compile_ms']:,.0f} ms "
                       f"({on['idle_compiles']}) | {on['rest_s']:.1f} s |")
    same = all(r["identical"] for r in rows)
    out += ["", f"Every final image equals the ungoverned render bit for bit: {'yes' if same else 'NO'} "
            f"({sum(r['identical'] for r in rows)} / {len(rows)} rows)."]
    return "\n".join(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--techniques", help="a subset, comma-separated (default: all 8)")
    ap.add_argument("--scan", action="store_true", help="also the shared head scan (../shared/assets/lee-perry-smith)")
    ap.add_argument("--scenes", help="head, scan or head,scan (--scan: head,scan)")
    ap.add_argument("--seconds", type=float)
    ap.add_argument("--edits", type=int)
    ap.add_argument("--frame-log", help="write one JSON line per frame here")
    ap.add_argument("--rest", type=float, default=1.0,
                    help="seconds of still view before each drag and the edits (and until the priming is done)")
    ap.add_argument("--prime", choices=("on", "off", "both"), default="on",
                    help="the idle priming of the next drag's preview variants (ui/warm.Primer); both: A/B, "
                         "each in a fresh viewer (a new GL context: nothing JIT-compiled yet)")
    ap.add_argument("--cold-shaders", action="store_true",
                    help="Mesa's on-disk shader cache off (MESA_SHADER_CACHE_DISABLE): every variant is "
                         "JIT-compiled at its first draw, as on a first run or a variant never drawn here")
    ap.add_argument("--share", choices=("on", "off", "both"), default="on",
                    help="passes copied between the user's graph and a preview's when their keys are equal "
                         "(RenderGraph.share_passes); both: the governed row twice, sharing off then on, in one viewer")
    ap.add_argument("--governor-margin", choices=("on", "off", "both"), default="off",
                    help="the governor fits a rung at the render graph's p99 margin (ui/frame.GOVERNOR_MARGIN); "
                         "both: A/B")
    ap.add_argument("--frames", choices=("on", "off", "both"), default="on",
                    help="this session's budget keeping (issue 27, session 10): the look-ahead's margin at the p99 "
                         "of each draw's recent errors (kernel.graph.QUANTILE_MARGIN), a first pass that does not fit "
                         "after the frame's own time waits a frame (DEFER_UNFIT_FIRST); off: the pace and its mean "
                         "error (the rule before); both: the governed row twice, off then on, in one viewer (an A/B)")
    ap.add_argument("--repeat", type=int, default=1,
                    help="the governed arms this many times, interleaved (A, B, A, B): on a shared machine whose load "
                         "drifts, each arm's figures then come from the same stretch of time (rows 'run k')")
    ap.add_argument("--release-rules", choices=("on", "off", "both"), default="on",
                    help="issue 27, session 11: a drag's smaller view of your graph keeps the full size's pooled "
                         "textures (ui/frame.KEEP_VIEW_POOLS), a pass is predicted at a size it ran at by that "
                         "size's cost (kernel.graph.COST_PER_SIZE), a band's average-cost floor is taken on the "
                         "predicted cost (kernel.graph.MIN_BAND_BY_COST); off: the rules before; both: the governed "
                         "row twice, off then on, in one viewer (an A/B)")
    ap.add_argument("--frame-rules", choices=("on", "off", "both"), default="on",
                    help="issue 27, session 12: under sync timing the NaN/Inf check's scans are waited for where they "
                         "are drawn, so their cost is the check's, predicted by the look-ahead (kernel.graph.SYNC_CHECKS) at the median of "
                         "its last CHECKS_KEPT, and a "
                         "release's frame only renders until the refinement's image is complete (ui/frame."
                         "RELEASE_RENDERS_FIRST); off: the rules before; both: the governed row twice, off then on, "
                         "in one viewer (an A/B)")
    ap.add_argument("--no-off", action="store_true", help="no governor-off row (only the governed arms: an A/B)")
    ap.add_argument("--whole-frame", choices=("on", "off", "both"), default="on",
                    help="the frame budget kept on the whole frame (ui/frame.WHOLE_FRAME: the UI and swap "
                         "budgeted at their running upper bound, the look-ahead's error margin, no refresh of an "
                         "unchanged image, sampled sync of the bands); off: the budgeting before, a glFinish "
                         "around every band; both: the governed row twice, off then on, in one viewer (an A/B)")
    args = ap.parse_args()
    if args.cold_shaders:
        os.environ["MESA_SHADER_CACHE_DISABLE"] = "true"  # before any GL context
    log = open(args.frame_log, "w") if args.frame_log else None  # noqa: SIM115 (closed at the end of main)
    from skinviewer import techniques
    names = args.techniques.split(",") if args.techniques else (["deon", "phong"] if args.quick else techniques.names())
    seconds = args.seconds or (1.5 if args.quick else 3.0)
    n_edits = args.edits or (6 if args.quick else 20)
    want = args.scenes.split(",") if args.scenes else (["head", "scan"] if args.scan else ["head"])
    scenes = {}
    if "head" in want:
        scenes["head"] = {}
    if any(w != "head" for w in want):
        sys.path.insert(0, os.path.dirname(__file__))
        from bench_tsm_gather import scenes as shared
        scenes.update({k: v for k, v in shared().items() if k != "head" and k in want})
    t_start = time.strftime("%Y-%m-%d %H:%M", time.gmtime())
    os.environ.setdefault("SKINVIEWER_CALIBRATE", "0")
    from skinviewer.ui.app import create_app, destroy_app
    rows = []
    arms = {"on": [True], "off": [False], "both": [False, True]}[args.prime]
    for scene_name, scene, prime in [(n, sc, p) for n, sc in scenes.items() for p in arms]:
        app = create_app(with_values(Settings(), scene), size=WINDOW, vsync=False)
        app.frame.primer.enabled = prime
        try:
            app.step(2)
            fr = app.frame
            fr.load_calibration(auto=False)
            cal = fr.governor.calibration
            missing = [n for n in names if cal is None or n not in cal.entries]
            if missing:
                print(f"# calibrating {', '.join(missing)} on this machine first", file=sys.stderr, flush=True)
                cal = calibration.calibrate(app.renderer, app.state.settings, missing, runs=2, into=cal)
                calibration.save(cal)
                fr.governor.set_calibration(cal)
            if not rows:
                w, h = app.state.settings.render.width, app.state.settings.render.height
                print(f"# bench_interaction — {describe(app.ctx)}; window {WINDOW[0]}x{WINDOW[1]} (view {w}x{h}), "
                      f"default settings (1024² maps), governor budget {app.state.settings.render.governor_budget_ms:g} ms; "
                      f"{seconds:g} s drags, {n_edits} edits; sync timing for 'alone'")
                print(f"{'scene':<6} {'technique':<9} {'governor':<11} {'prime':<5} {'p95 drag':>9} {'p95 edits':>9} "
                      f"{'release→final':>13} {'alone':>8} {'ratio':>6} {'stall':>8} {'work':>6} {'swap':>6} {'gc':>5} {'>100ms':>9} {'load':>5} "
                      f"{'preview (end of light drag)':<48} "
                      f"{'error':>7} {'final = ungoverned':>18} {'light start':>11} {'1st draws':>9} {'idle max':>8}",
                      flush=True)
            from skinviewer.kernel import graph as graph_mod
            from skinviewer.ui import frame as frame_mod
            shares = {"on": [True], "off": [False], "both": [False, True]}[args.share]
            wholes = {"on": [True], "off": [False], "both": [False, True]}[args.whole_frame]
            frames = {"on": [True], "off": [False], "both": [False, True]}[args.frames]
            gms = {"on": [True], "off": [False], "both": [False, True]}[args.governor_margin]
            vss = {"on": [True], "off": [False], "both": [False, True]}[args.release_rules]
            frs = {"on": [True], "off": [False], "both": [False, True]}[args.frame_rules]
            pace_err_k = graph_mod.PACE_ERR_K
            checks_kept = graph_mod.CHECKS_KEPT
            for name in names:
                arms = ([] if args.no_off else [("off", shares[-1], wholes[-1], frames[-1], gms[-1], vss[-1], frs[-1], 0)]) + [
                    ("interactive", sh, wh, fr, gm, vs, fx, k) for k in range(max(args.repeat, 1))
                    for sh in shares for wh in wholes for fr in frames for gm in gms for vs in vss for fx in frs]
                for mode, share, whole, new, gm, vs, fx, k in arms:
                    graph_mod.SYNC_CHECKS = frame_mod.RELEASE_RENDERS_FIRST = fx
                    graph_mod.CHECKS_KEPT = checks_kept if fx else 1
                    frame_mod.GOVERNOR_MARGIN = gm
                    frame_mod.KEEP_VIEW_POOLS = graph_mod.COST_PER_SIZE = graph_mod.MIN_BAND_BY_COST = vs
                    graph_mod.SHARE_PASSES = share
                    frame_mod.WHOLE_FRAME = whole
                    graph_mod.PACE_ERR_K = pace_err_k if whole else 0.0
                    graph_mod.SAMPLED_SYNC = whole
                    graph_mod.QUANTILE_MARGIN = graph_mod.DEFER_UNFIT_FIRST = new
                    for g in app.renderer.graphs.values():
                        g.margins.clear()  # each arm learns its own margins
                    row = run_one(app, name, mode, seconds, n_edits, log, args.rest,
                                  {"share": share, "whole_frame": whole, "p99_margin": new, "governor_margin": gm,
                                   "release_rules": vs, "frame_rules": fx, "run": k})
                    row["scene"] = scene_name
                    if len(shares) > 1 and mode != "off":
                        row["technique"] = f"{name} (sharing {'on' if share else 'off'})"
                        if not share:
                            row["mode"] = "interactive, sharing off"
                    # each A/B switch with both arms in this run names its arm in the row
                    for arms, on, label in ((wholes, whole, "whole frame"), (frames, new, "p99 margin"),
                                            (gms, gm, "governor margin"), (vss, vs, "release rules"),
                                            (frs, fx, "frame rules")):
                        if len(arms) > 1 and mode != "off":
                            row["technique"] = f"{row['technique']} ({label} {'on' if on else 'off'})"
                            if not on:
                                row["mode"] = row["mode"] + f", {label} off"
                    if args.repeat > 1 and mode != "off":
                        row["technique"] = f"{row['technique']} run {k + 1}"
                    rows.append(row)
                    err = "" if row["preview_err"] is None else f"{row['preview_err']:.1%}"
                    print(f"{scene_name:<6} {row['technique']:<9} {mode:<11} {'on' if prime else 'off':<5} "
                          f"{row['p95_drag']:9.0f} {row['p95_edits']:9.0f} "
                          f"{row['release_ms']:13.0f} {row['alone_ms']:8.0f} {row['release_ms'] / row['alone_ms']:6.2f} "
                          f"{row['stall_ms']:8.0f} {row['work_stall_ms']:6.0f} {row['swap_max_ms']:6.0f} {row['gc_max_ms']:5.0f} "
                          f"{row['over_100']:>4}/{row['frames']:<4} {row['load']:5.1f} "
                          f"{row['preview']:<48} {err:>7} {row['identical']!s:>18} {row['light_start_ms']:11.0f} "
                          f"{row['drag_first_draws']:9d} {row['idle_max_ms']:8.0f} "
                          f"graph over budget {row['graph_over']}/{row['graph_frames']} p99 {row['graph_over_p99']:.2f}",
                          flush=True)
        finally:
            destroy_app(app)
    if log is not None:
        log.close()
    up = "load average: " + ", ".join(f"{x:.2f}" for x in os.getloadavg())  # as `uptime` prints it
    print()
    print(markdown(rows, f"`{' '.join(sys.argv)}` ({t_start}–{time.strftime('%H:%M', time.gmtime())} UTC; "
                         f"uptime at the end: {up}; governor off and on side by side per row, sync timing)"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
