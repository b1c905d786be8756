"""d'Eon's final pass split in two (issue 27), before | after in one process: d'Eon at the defaults (640^2
view, 1024^2 maps, the default rig: studio environment + key light) with the final pass in one pass
(passes.deon.SPLIT_FINAL 0, the code before) and split (deon_final_view, kept across light moves, + the
light pass deon_final), each in its own renderer, the two interleaved in every repeat (each side first in
every other one), Phong beside them. Sync timing (glFinish + wall clock per frame; render.timing = sync for
the per-pass figures), medians.

    python benchmarks/bench_split_final.py [--maps 1024] [--size 640] [--repeats 3] [--scene head|scan]

Per side: the light move, the full frame (forced: every pass, the light-independent pass included) and the
camera-only frame, as ms and x Phong's same frame kind; the final pass and the view pass on each frame kind in
plain copies of the view size (640^2 RGBA32F); and the memory each renderer holds
(engine/memory.renderer_memory).
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from bench_blur_floor import light_frame  # noqa: E402
from bench_frames import copy_draw_ms, settings_for  # noqa: E402
from bench_split_sum import timed  # noqa: E402

import skinviewer.passes.deon as deon_passes  # noqa: E402
from skinviewer.engine.memory import renderer_memory  # noqa: E402
from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import with_values  # noqa: E402
from skinviewer.kernel.gl import describe, headless_context  # noqa: E402


def pass_ms(rep, name: str) -> float:
    return sum(p.ms or 0.0 for p in rep.passes if p.name == name and p.status == "ran")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", type=int, default=1024)
    ap.add_argument("--size", type=int, default=640)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--scene", default="head", choices=("head", "scan"))
    ap.add_argument("--draws", action="store_true",
                    help="also time the final passes' draws alone (glFinish before and after each draw, as "
                         "bench_deon_draws.py; adds a few ms to every frame, on both sides)")
    args = ap.parse_args()
    if args.draws:
        import bench_deon_draws
        bench_deon_draws.instrument()
    ctx = headless_context()
    print(f"# final pass split | one pass — {describe(ctx)}; load {os.getloadavg()[0]:.1f} at start")
    extra = {}
    if args.scene == "scan":
        from bench_fidelity import SCAN_VALUES
        extra = dict(SCAN_VALUES)
    maps = args.maps
    s = settings_for("deon", "head", args.size, maps, **extra)
    phong = settings_for("phong", "head", args.size, maps, **extra)
    sides = {}
    for split in (True, False):
        deon_passes.SPLIT_FINAL = "1" if split else "0"
        sides[split] = Renderer(ctx)
        sides[split].render(s, force=True)
    deon_passes.SPLIT_FINAL = "1"
    rp = Renderer(ctx)
    rp.render(phong, force=True)
    ms: dict[tuple, list[float]] = {}

    def add(key, v):
        ms.setdefault(key, []).append(v)

    def draws(split, kind):
        """The final passes' draw ms of the frame just timed (--draws), then a fresh log."""
        if not args.draws:
            return
        import bench_deon_draws
        log = bench_deon_draws.LOG
        base = len(log) // 2 if kind == "light" else 0  # light_frame renders its base frame first
        for name in ("deon_final", "deon_final_view"):
            add((split, f"{kind} draw {name}"), sum(x[3] for x in log[base:] if x[0] == name))
        log.clear()

    for k in range(args.repeats):
        for split in ((True, False) if k % 2 == 0 else (False, True)):
            deon_passes.SPLIT_FINAL = "1" if split else "0"
            r = sides[split]
            if args.draws:
                import bench_deon_draws
                bench_deon_draws.LOG.clear()
            t, rep = light_frame(r, s, k)
            draws(split, "light")
            add((split, "light"), t)
            add((split, "light final"), pass_ms(rep, "deon_final"))
            add((split, "light view"), pass_ms(rep, "deon_final_view"))
            if args.draws:
                import bench_deon_draws
                bench_deon_draws.LOG.clear()
            t, rep = timed(r, s, force=True)
            draws(split, "full")
            add((split, "full"), t)
            add((split, "full final"), pass_ms(rep, "deon_final"))
            add((split, "full view"), pass_ms(rep, "deon_final_view"))
            cam = with_values(s, {"camera.yaw": s.camera.yaw + 3.0 * (k + 1)})
            r.render(s)
            if args.draws:
                import bench_deon_draws
                bench_deon_draws.LOG.clear()
            t, rep = timed(r, cam)
            draws(split, "camera")
            add((split, "camera"), t)
            add((split, "camera final"), pass_ms(rep, "deon_final"))
            add((split, "camera view"), pass_ms(rep, "deon_final_view"))
            r.render(s)
        deon_passes.SPLIT_FINAL = "1"
        add(("phong", "light"), light_frame(rp, phong, k)[0])
        add(("phong", "full"), timed(rp, phong, force=True)[0])
        rp.render(phong)
        add(("phong", "camera"), timed(rp, with_values(phong, {"camera.yaw": phong.camera.yaw + 3.0 * (k + 1)}))[0])
        rp.render(phong)
        add(("copy", ""), copy_draw_ms(rp, args.size, 3))
        add(("copy maps", ""), copy_draw_ms(rp, maps, 3))
    med = {key: statistics.median(v) for key, v in ms.items()}
    copy = med[("copy", "")]
    print(f"# scene={args.scene} image={args.size}^2 maps={maps}^2 repeats={args.repeats}; load "
          f"{os.getloadavg()[0]:.1f} at the end; plain copy {copy:.2f} ms ({args.size}^2 RGBA32F), "
          f"{med[('copy maps', '')]:.2f} ms ({maps}^2)")
    print(f"{'':<34} {'one pass (before)':>20} {'split (after)':>20} {'change':>8}")
    for kind in ("light", "full", "camera"):
        b, a, p = med[(False, kind)], med[(True, kind)], med[("phong", kind)]
        print(f"{kind + ' frame':<34} {b:>9.0f} ms {b / p:>5.2f}x {a:>9.0f} ms {a / p:>5.2f}x "
              f"{100 * (a / b - 1):>+7.0f}%   (Phong {p:.0f} ms)")
    for key, label in (("light final", "final (light) pass, light move"),
                       ("light view", "view pass, light move"),
                       ("camera final", "final (light) pass, camera move"),
                       ("camera view", "view pass, camera move"),
                       ("full final", "final (light) pass, full frame"),
                       ("full view", "view pass, full frame")):
        b, a = med[(False, key)], med[(True, key)]
        print(f"{label:<34} {b:>9.0f} ms {b / copy:>5.1f}cp {a:>9.0f} ms {a / copy:>5.1f}cp")
    if args.draws:
        for kind in ("light", "camera", "full"):
            b = med[(False, f"{kind} draw deon_final")]
            a, v = med[(True, f"{kind} draw deon_final")], med[(True, f"{kind} draw deon_final_view")]
            print(f"{'draws alone, ' + kind:<34} {b:>9.1f} ms {b / copy:>5.1f}cp {a + v:>9.1f} ms {(a + v) / copy:>5.1f}cp "
                  f"(light part {a:.1f} + view part {v:.1f} ms)")
    for split in (False, True):
        mem = renderer_memory(sides[split])
        kept = sum(t.size[0] * t.size[1] * t.components * 4 for name, t in
                   sides[split].graph("deon").res.textures.items() if name.startswith("deon_final_view"))
        print(f"# memory held, {'split' if split else 'one pass'}: {sum(mem.values()) / 2**20:.1f} MiB "
              f"(the view pass's maps {kept / 2**20:.1f} MiB)")


if __name__ == "__main__":
    main()
