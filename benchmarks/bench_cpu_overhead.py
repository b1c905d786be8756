"""The render graph's own CPU work per frame (issue 27): Python and GL-call overhead, not shading.

    python benchmarks/bench_cpu_overhead.py [--repeats 15] [--profile deon] [--techniques a,b]

Each technique at its *default settings* except a tiny view and tiny maps (32² view, 64² shadow /
TSM maps, 256² irradiance and light maps: the least those settings allow; d'Eon's
``deon.subpixel_kernel_px`` 0, else at 32² its kernel is under a pixel and the rule skips its blurs,
stretch and TSM) so that llvmpipe's
shading is small beside the graph's own work. The head stays the default head (its vertex work,
done by llvmpipe on the calling thread, is part of every mesh draw). Three interactive frames, each
from the base frame (side by side in one run, interleaved, medians):

* camera only: the yaw moves 5° (only view-dependent passes re-run);
* light move: the key light's direction moves (every lit pass re-runs);
* slider: one setting of the technique's own section moves (the passes that declare it re-run).

Figures per frame: ``wall`` (ms, one glFinish at the end, timing "gpu" i.e. no glFinish between
passes: what the frame's CPU costs when the GPU keeps up), ``cpu`` (ms of this thread's CPU time:
the Python and the driver's work on the calling thread; llvmpipe's rasterizer threads excluded),
``own`` (ms: RenderGraph.own_ms, the graph's work outside every pass's execute) and per frame the
GL calls the passes made (counted by a shim around moderngl's objects, in this benchmark only):
draws, framebuffer binds, texture binds, uniform writes. ``--profile TECH`` prints cProfile's top
entries of TECH's camera-only and light-move frames.

``--fast ab`` (the default): every frame twice, interleaved, with the graph's cached-frame fast path off
("before": kernel/graph.FAST_CACHED False, as SKINVIEWER_GRAPH_FAST=0) and on ("after"), medians side by
side; the passes run and the draws must be the same (checked: a line says so). ``--fast on|off``: one.
The machine's load is printed at the start and the end (other work shares the cores).

``--size 1920x1080`` (with ``--techniques phong,deon --kinds camera``): the default settings, maps and rules
at that view, as the GPU check's frames (issue 27's goal: d'Eon's camera-only frame <= 1.2x Phong's);
its "GPU ms" column sums the timer queries (meaningful on a real GPU only).
"""
from __future__ import annotations

import argparse
import cProfile
import io
import os
import pstats
import statistics
import sys
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's package

import moderngl  # noqa: E402

from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import Settings, with_values  # noqa: E402
from skinviewer.kernel import graph as graph_mod  # noqa: E402
from skinviewer.kernel.gl import describe, headless_context  # noqa: E402

SIZE, MAPS, MIN_MAPS = int(os.environ.get("CPU_BENCH_SIZE", 32)), 64, 256  # view, shadow/TSM maps, irradiance/light maps (their least value)
TECHNIQUES = ("phong", "deon", "ssss", "burley2", "gosselin", "penner")
SLIDERS = {  # a setting of the technique's own section: its slider
    "phong": ("phong.specular", 0.01), "deon": ("deon.mix", 0.01), "ssss": ("ssss.beta", 10.0),
    "burley2": ("burley.scale", 0.01), "gosselin": ("gosselin.scale_x", 0.01),
    "penner": ("penner.curvature_scale", 0.01), "separable": ("separable.width_mm", 0.01),
    "burley": ("burley.scale", 0.01),
}


VIEW: tuple[int, int] | None = None  # --size WxH: the defaults' maps and rules at this view (the GPU check's frames)


def settings_for(tech: str) -> Settings:
    if VIEW is not None:
        return with_values(Settings(), {"technique": tech, "render.width": VIEW[0], "render.height": VIEW[1],
                                        "render.timing": "gpu"})
    return with_values(Settings(), {"technique": tech, "render.width": SIZE, "render.height": SIZE,
                                    "render.timing": "gpu", "shadow.map_size": MAPS, "deon.tsm_size": MAPS,
                                    "deon.irradiance_size": MIN_MAPS, "gosselin.light_map_size": MIN_MAPS,
                                    # at a 32² view d'Eon's widest Gaussian spans under 0.3 px: the rule would
                                    # skip its blurs, stretch and TSM (passes/rules.kernel_under_pixel)
                                    "deon.subpixel_kernel_px": 0.0})


class GLCounter:
    """Counts GL-issuing calls on moderngl's wrapper classes while ``on`` (a benchmark-only shim)."""

    WRAPPED = {
        "draws": [(moderngl.VertexArray, "render")],
        "fbo binds": [(moderngl.Framebuffer, "use")],
        "clears": [(moderngl.Framebuffer, "clear")],
        "tex binds": [(moderngl.Texture, "use")],
        "uniform writes": [(moderngl.Uniform, "write")],
        "state": [(moderngl.Context, "enable"), (moderngl.Context, "disable")],
        "finish": [(moderngl.Context, "finish")],
        "fbo made": [(moderngl.Context, "framebuffer")],
    }

    def __init__(self) -> None:
        self.counts: Counter[str] = Counter()
        self.on = False
        self._orig: list[tuple[type, str, object]] = []
        for label, targets in self.WRAPPED.items():
            for cls, name in targets:
                self._wrap(cls, name, label)
        # Uniform.value is a property: its setter counts as a uniform write
        prop = moderngl.Uniform.__dict__["value"]
        self._orig.append((moderngl.Uniform, "value", prop))
        counter = self

        def fset(u, v, _set=prop.fset):
            if counter.on:
                counter.counts["uniform writes"] += 1
            _set(u, v)
        moderngl.Uniform.value = property(prop.fget, fset)

    def _wrap(self, cls: type, name: str, label: str) -> None:
        orig = cls.__dict__[name]
        self._orig.append((cls, name, orig))
        counter = self

        def wrapper(*a, **k):
            if counter.on:
                counter.counts[label] += 1
            return orig(*a, **k)
        setattr(cls, name, wrapper)

    def restore(self) -> None:
        for cls, name, orig in reversed(self._orig):
            setattr(cls, name, orig)


class GraphClock:
    """This thread's CPU time inside the graph's reflect (every pass) and cache keys, while ``on``: the
    part of ``own`` that is pure Python (``own`` also holds the NaN/Inf check's readbacks, which wait
    for the rasterizer). A benchmark-only shim around RenderGraph's methods."""

    def __init__(self) -> None:
        from skinviewer.kernel import graph as g
        self.g, self.s, self.on = g, 0.0, False
        self._orig = [(g.RenderGraph, n, g.RenderGraph.__dict__[n]) for n in ("_reflect_all", "_key")]
        for cls, name, orig in self._orig:
            setattr(cls, name, self._timed(orig))

    def _timed(self, orig):
        clock = self

        def wrapper(*a, **k):
            t0 = time.thread_time()
            try:
                return orig(*a, **k)
            finally:
                if clock.on:
                    clock.s += time.thread_time() - t0
        return wrapper

    def restore(self) -> None:
        for cls, name, orig in self._orig:
            setattr(cls, name, orig)


CLOCK: GraphClock | None = None


def frames(s: Settings, k: int) -> dict[str, Settings]:
    d = s.lights[0].direction
    path, step = SLIDERS[s.technique]
    from skinviewer.ground.settings import get_path
    return {"camera": with_values(s, {"camera.yaw": s.camera.yaw + 5.0 * (1 + k % 3)}),
            "light": with_values(s, {"lights.0.direction": (d[0] + 0.02 * (1 + k % 3), d[1], d[2])}),
            "slider": with_values(s, {path: get_path(s, path) + step * (1 + k % 3)})}


def measure(r: Renderer, base: Settings, edited: Settings, counter: GLCounter | None = None
            ) -> tuple[float, float, float, float, list[str], float]:
    r.render(base)  # the base frame (not timed)
    r.ctx.finish()
    if counter is not None:
        counter.counts.clear()
        counter.on = True
    if CLOCK is not None:
        CLOCK.s, CLOCK.on = 0.0, True
    c0, t0 = time.thread_time(), time.perf_counter()
    rep = r.render(edited)
    r.ctx.finish()
    wall, cpu = (time.perf_counter() - t0) * 1000.0, (time.thread_time() - c0) * 1000.0
    if counter is not None:
        counter.on = False
    graph_ms = 0.0
    if CLOCK is not None:
        CLOCK.on = False
        graph_ms = CLOCK.s * 1000.0
    gpu = sum(p.ms or 0.0 for p in rep.passes if p.status == "ran")  # timer queries (llvmpipe's: far too low)
    return wall, cpu, r.graph(base.technique).own_ms, graph_ms, rep.ran, gpu


def profile(r: Renderer, base: Settings, edited: Settings, runs: int, top: int) -> str:
    pr = cProfile.Profile()
    for _ in range(runs):
        r.render(base)
        r.ctx.finish()
        pr.enable()
        r.render(edited)
        r.ctx.finish()
        pr.disable()
    out = io.StringIO()
    pstats.Stats(pr, stream=out).sort_stats("tottime").print_stats(top)
    lines = out.getvalue().splitlines()
    start = next((i for i, ln in enumerate(lines) if "tottime" in ln), 0)
    return "\n".join(lines[start:start + top + 1])


def load() -> str:
    one, five, fifteen = os.getloadavg()
    return f"load {one:.2f} {five:.2f} {fifteen:.2f} (1, 5, 15 min)"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--techniques", default=",".join(TECHNIQUES))
    ap.add_argument("--profile", default="deon", help="technique whose frames cProfile lists ('' : none)")
    ap.add_argument("--top", type=int, default=18)
    ap.add_argument("--fast", choices=("ab", "on", "off"), default="ab",
                    help="the graph's cached-frame fast path (kernel/graph.FAST_CACHED): both, interleaved, or one")
    ap.add_argument("--kinds", default="camera,light,slider", help="frame kinds (camera, light, slider)")
    ap.add_argument("--size", default="", help="WxH: the default settings (maps, rules) at this view instead of "
                    "the tiny view and maps (e.g. 1920x1080, the GPU check's frames)")
    args = ap.parse_args(argv)
    global VIEW
    if args.size:
        w, _, h = args.size.partition("x")
        VIEW = (int(w), int(h or w))
    techs = [t for t in args.techniques.split(",") if t]
    kinds = tuple(k for k in args.kinds.split(",") if k)
    modes = {"ab": (False, True), "on": (True,), "off": (False,)}[args.fast]
    start_load = load()
    ctx = headless_context()
    global CLOCK
    CLOCK = GraphClock()
    r = Renderer(ctx)
    base = {t: settings_for(t) for t in techs}
    for t in techs:  # warm-up: compile shaders, build the scene, allocate; then every frame kind once
        r.render(base[t], force=True)
        for mode in modes:
            graph_mod.FAST_CACHED = mode
            for kind, s in frames(base[t], 0).items():
                if kind in kinds:
                    measure(r, base[t], s)
    Key = tuple[str, str, bool]
    res: dict[Key, list[tuple[float, float, float, float, float]]] = {(t, k, m): [] for t in techs for k in kinds
                                                                      for m in modes}
    ran: dict[Key, list[str]] = {}
    for i in range(args.repeats):
        for t in techs:
            for kind, s in frames(base[t], i).items():
                if kind not in kinds:
                    continue
                for mode in (modes if i % 2 == 0 else modes[::-1]):  # interleaved, each first half the time
                    graph_mod.FAST_CACHED = mode
                    w, c, o, gm, names, gpu = measure(r, base[t], s)
                    res[(t, kind, mode)].append((w, c, o, gm, gpu))
                    ran[(t, kind, mode)] = names
    counter = GLCounter()
    calls: dict[Key, Counter[str]] = {}
    try:
        for t in techs:
            for kind, s in frames(base[t], 1).items():
                for mode in modes:
                    if kind in kinds:
                        graph_mod.FAST_CACHED = mode
                        measure(r, base[t], s, counter)
                        calls[(t, kind, mode)] = Counter(counter.counts)
    finally:
        counter.restore()
    graph_mod.FAST_CACHED = modes[-1]

    def med(t: str, kind: str, mode: bool, j: int) -> float:
        return statistics.median(x[j] for x in res[(t, kind, mode)])

    ref = "phong" if "phong" in techs else techs[0]
    new = modes[-1]
    print(f"# the graph's own CPU work per frame — {describe(ctx)}; {start_load} at the start")
    what = (f"default settings at a {VIEW[0]}x{VIEW[1]} view" if VIEW else
            f"default settings but a {SIZE}² view, {MAPS}² shadow/TSM maps, {MIN_MAPS}² irradiance/light maps "
            f"(LIGHTER than the defaults' 640² view and 1024² maps, so that shading is small; d'Eon's "
            f"kernel-under-a-pixel rule off, so its whole chain runs as at the default view)")
    print(f"# {what}; default head; timing 'gpu' (no glFinish between passes), one glFinish after the frame; "
          f"medians of {args.repeats}; SKINVIEWER_SPLIT_FINAL={os.environ.get('SKINVIEWER_SPLIT_FINAL', 'auto')}")
    print(f"# wall: frame ms; cpu: this thread's CPU ms; own: the graph's work outside the passes' execute; "
          f"reflect+keys: this thread's CPU ms in the graph's reflect (every pass) and cache keys; "
          f"x {ref}: ratio to {ref}'s in the same run and mode; "
          + ("before / after: the graph's cached-frame fast path off / on (kernel/graph.FAST_CACHED), "
             "interleaved; GL calls counted in one frame of each" if len(modes) == 2 else
             f"fast path {'on' if new else 'off'}"))
    print()
    if len(modes) == 2:
        print(f"| technique | frame | passes run | wall ms before / after | wall × {ref} before / after "
              f"| GPU ms (timer queries) | cpu ms before / after | cpu after/before "
              f"| cpu × {ref} before / after | own ms before / after | reflect+keys ms before / after "
              "| draws | fbo binds | fbo made before / after | tex binds | uniform writes | state |")
        print("| --- " * 17 + "|")
        same = True
        for kind in kinds:
            for t in techs:
                b, a = calls.get((t, kind, False), Counter()), calls.get((t, kind, True), Counter())
                same &= ran[(t, kind, False)] == ran[(t, kind, True)] and b["draws"] == a["draws"]
                print(f"| {t} | {kind} | {len(ran[(t, kind, True)])} | "
                      f"{med(t, kind, False, 0):.2f} / {med(t, kind, True, 0):.2f} | "
                      f"{med(t, kind, False, 0) / med(ref, kind, False, 0):.2f} / "
                      f"{med(t, kind, True, 0) / med(ref, kind, True, 0):.2f} | {med(t, kind, True, 4):.2f} | "
                      f"{med(t, kind, False, 1):.2f} / {med(t, kind, True, 1):.2f} | "
                      f"{med(t, kind, True, 1) / med(t, kind, False, 1):.2f} | "
                      f"{med(t, kind, False, 1) / med(ref, kind, False, 1):.2f} / "
                      f"{med(t, kind, True, 1) / med(ref, kind, True, 1):.2f} | "
                      f"{med(t, kind, False, 2):.2f} / {med(t, kind, True, 2):.2f} | "
                      f"{med(t, kind, False, 3):.2f} / {med(t, kind, True, 3):.2f} | "
                      f"{a['draws']} | {a['fbo binds']} | {b['fbo made']} / {a['fbo made']} | {a['tex binds']} | "
                      f"{a['uniform writes']} | {a['state']} |")
        print(f"\n# the same passes ran and the same draws were made before and after: {'yes' if same else 'NO'}")
    else:
        print(f"| technique | frame | passes run | wall ms | × {ref} | cpu ms | × {ref} | own ms | reflect+keys ms "
              f"| × {ref} | draws | fbo binds | fbo made | tex binds | uniform writes | state | finish |")
        print("| --- " * 17 + "|")
        for kind in kinds:
            for t in techs:
                c = calls.get((t, kind, new), Counter())
                print(f"| {t} | {kind} | {len(ran[(t, kind, new)])} | {med(t, kind, new, 0):.2f} | "
                      f"{med(t, kind, new, 0) / med(ref, kind, new, 0):.2f} | {med(t, kind, new, 1):.2f} | "
                      f"{med(t, kind, new, 1) / med(ref, kind, new, 1):.2f} | {med(t, kind, new, 2):.2f} | "
                      f"{med(t, kind, new, 3):.2f} | {med(t, kind, new, 3) / max(med(ref, kind, new, 3), 1e-9):.2f} | "
                      f"{c['draws']} | {c['fbo binds']} | {c['fbo made']} | {c['tex binds']} | "
                      f"{c['uniform writes']} | {c['state']} | {c['finish']} |")
    print(f"# {load()} at the end")
    if args.profile and args.profile in techs:
        t = args.profile
        for kind in ("camera", "light"):
            print(f"\n## cProfile: {t}, {kind} frame, fast path {'on' if new else 'off'} "
                  f"({max(args.repeats // 3, 3)} frames, by own time)\n```")
            print(profile(r, base[t], frames(base[t], 1)[kind], max(args.repeats // 3, 3), args.top))
            print("```")
    r.release()
    CLOCK.restore()


if __name__ == "__main__":
    main()
