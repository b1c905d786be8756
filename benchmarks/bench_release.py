"""Release -> final after a light drag in the real viewer (issue 27, session 11), an A/B of this
session's release rules -- ``ui/frame.KEEP_VIEW_POOLS``, ``kernel.graph.COST_PER_SIZE`` and
``kernel.graph.MIN_BAND_BY_COST`` (all off: the rules before; all on: this session's) -- in one viewer, the arms interleaved (off, on, off, on, ...) so a load that drifts hits
both; medians per technique. Run it under Xvfb:

    PYTHONPATH=. xvfb-run -a -s "-screen 0 1280x800x24" python3 benchmarks/bench_release.py
        [--techniques ssss,burley2,penner] [--scenes head,scan] [--reps 4] [--seconds 2] [--rules release|frame]

``--rules frame``: the arms alternate session 12's rules instead (``kernel.graph.SYNC_CHECKS``,
``ui/frame.RELEASE_RENDERS_FIRST``), the release rules on in both.

Per arm: release -> final (ms, from letting go of a key-light drag to the complete image at the user's
settings on screen), its ratio to that image's frame measured alone right after (sync timing, no
budget), the release frames' longest graph own time (texture allocation lands there) and longest
frame, and the bands the largest tileable pass of the final ran in. The load average is printed
beside each row. The defaults a user gets: 1040x700 window (640x676 view), 1024² maps, 100 ms budget,
this machine's calibration."""
from __future__ import annotations

import argparse
import os
import re
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(__file__))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--techniques", default="ssss,burley2,penner")
    ap.add_argument("--scenes", default="head")
    ap.add_argument("--reps", type=int, default=4)
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--rules", choices=("release", "frame"), default="release",
                    help="the switches the arms alternate: release (session 11's release rules) or frame (session 12: "
                         "kernel.graph.SYNC_CHECKS, CHECKS_KEPT and ui/frame.RELEASE_RENDERS_FIRST, the release rules on in "
                         "both)")
    a = ap.parse_args()
    os.environ.setdefault("SKINVIEWER_CALIBRATE", "0")
    import bench_interaction as bi

    from skinviewer.ground.settings import Settings, validate, with_values
    from skinviewer.kernel import graph as graph_mod
    from skinviewer.kernel.gl import describe
    from skinviewer.ui import frame as frame_mod
    from skinviewer.ui.app import create_app, destroy_app
    checks_kept = graph_mod.CHECKS_KEPT
    scenes: dict[str, dict] = {}
    for name in a.scenes.split(","):
        if name == "head":
            scenes["head"] = {}
        else:
            from bench_tsm_gather import scenes as shared
            scenes[name] = shared()[name]
    t0 = time.strftime("%Y-%m-%d %H:%M", time.gmtime())
    lines = []
    for scene_name, scene in scenes.items():
        app = create_app(with_values(Settings(), scene), size=bi.WINDOW, vsync=False)
        try:
            app.step(2)
            fr = app.frame
            fr.load_calibration(auto=False)
            if not lines:
                print(f"# bench_release — {describe(app.ctx)}; view {app.state.settings.render.width}x"
                      f"{app.state.settings.render.height}, {a.seconds:g} s light drags, {a.reps} reps an arm", flush=True)
            for t in a.techniques.split(","):
                st = app.state
                st.set_settings(validate({**st.settings.model_dump(mode="json"), "technique": t}), "technique")
                st.apply({"render.governor": "interactive"})
                res: dict[bool, list[tuple[float, float, float, float, int]]] = {False: [], True: []}
                loads = []
                for k in range(2 * a.reps):
                    on = k % 2 == 1
                    if a.rules == "frame":
                        graph_mod.SYNC_CHECKS = frame_mod.RELEASE_RENDERS_FIRST = on
                        graph_mod.CHECKS_KEPT = checks_kept if on else 1
                    else:
                        frame_mod.KEEP_VIEW_POOLS = graph_mod.COST_PER_SIZE = graph_mod.MIN_BAND_BY_COST = on
                    d = bi.Driver(app, None, {"technique": t})
                    d.until_final()
                    d.rest(0.5)
                    d.drag(app.wnd.mouse.right, a.seconds)
                    n0 = len(d.frame_ms)
                    own: list[float] = []
                    bands: dict[str, int] = {}
                    step = d.step

                    def logged(step=step, own=own, bands=bands, fr=fr):
                        step()
                        g = fr.last_graph
                        own.append(g.own_ms if g is not None else 0.0)
                        for p in (fr.report.passes if fr.report is not None else []):
                            m = re.search(r"in (\d+) bands", p.reason or "")
                            if m and p.status == "ran":
                                bands[p.name] = int(m.group(1))
                    d.step = logged  # type: ignore[method-assign]
                    ms = d.until_final()
                    frames = d.frame_ms[n0:]
                    alone = bi.full_frame_alone(app)
                    ms_of = {p.name: p.ms or 0.0 for p in app.renderer.graph(t).last_report.passes}
                    top = max(bands, key=lambda n: ms_of.get(n, 0.0), default="")
                    if os.environ.get("BENCH_RELEASE_DEBUG"):
                        print(t, on, round(ms), bands, flush=True)
                    res[on].append((ms, ms / alone, max(own, default=0.0), max(frames, default=0.0), bands.get(top, 1)))
                    loads.append(os.getloadavg()[0])
                for on in (False, True):
                    rows = res[on]
                    med = [statistics.median(x[i] for x in rows) for i in range(5)]
                    line = (f"| {scene_name} | {t} | {'on' if on else 'off'} | {med[0]:,.0f} ms | {med[1]:.2f}× "
                            f"({', '.join(f'{x[1]:.2f}' for x in rows)}) | {med[2]:.0f} ms | {med[3]:.0f} ms | {med[4]:.0f} "
                            f"| {min(loads):.1f}–{max(loads):.1f} |")
                    lines.append(line)
                    print(line, flush=True)
        finally:
            destroy_app(app)
    up = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"\n`{' '.join(sys.argv)}` ({t0}–{time.strftime('%H:%M', time.gmtime())} UTC, load average at the end {up}); "
          "medians of the reps, each arm's reps interleaved with the other's:\n")
    print(f"| scene | technique | {a.rules} rules | release → final | × alone (each rep) | longest own time | longest frame "
          "| bands of the costliest banded pass | load |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
