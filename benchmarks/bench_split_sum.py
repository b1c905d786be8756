"""The summed step split in two (issue 27), before | after in one process: d'Eon at the defaults (640^2
view, 1024^2 maps, head) with the narrow step summed in one pass (deon_surface_gather.frag:
passes.deon.SPLIT_SUM off, the code before) and split (its weights kept by deon_gather_weights_i, the
light summed by deon_gather_sum.frag), each in its own renderer, the two interleaved in every repeat,
Phong beside them. Sync timing (render.timing = sync: glFinish per pass, wall clock), medians.

    python benchmarks/bench_split_sum.py [--maps 1024[,2048]] [--size 640] [--repeats 3] [--scene head|scan]
        [--lit-rings 2,1]

Per side: the light move (frame, summed step), the full frame (forced: every pass, the weight pass
included) and the camera-only frame, each as ms and x Phong's same frame kind; the weight pass's own
ms; and the memory the renderer holds (engine/memory.renderer_memory). With several map sizes, each is
measured in turn within every repeat (its own renderers), and the growth of each frame kind from the first
size to the others is printed against the growth in texels. --lit-rings adds split sides with
passes.deon.LIT_RING set (the rings past it take their light at the area's mean point), beside the rest.
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

import skinviewer.passes.deon as deon_passes  # noqa: E402
from skinviewer.engine.memory import renderer_memory  # noqa: E402
from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import with_values  # noqa: E402
from skinviewer.kernel.gl import describe, headless_context  # noqa: E402


def summed_ms(rep) -> float:
    """The summed step's pass (the blur pass that notes its sigma in mean texels)."""
    return sum(p.ms or 0.0 for p in rep.passes if p.name.startswith("deon_blur_") and p.status == "ran"
               and "sigma_texels" in p.figures)


def weights_ms(rep) -> float:
    return sum(p.ms or 0.0 for p in rep.passes if p.name.startswith("deon_gather_weights_") and p.status == "ran")


def timed(r: Renderer, s, force: bool = False):
    import time
    r.ctx.finish()
    t0 = time.perf_counter()
    rep = r.render(s, force=force)
    r.ctx.finish()
    return (time.perf_counter() - t0) * 1000.0, rep


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", default="1024", help="map sizes, comma-separated")
    ap.add_argument("--size", type=int, default=640)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--scene", default="head", choices=("head", "scan"))
    ap.add_argument("--lit-rings", default="", help="also split sides with passes.deon.LIT_RING = each of these")
    args = ap.parse_args()
    ctx = headless_context()
    print(f"# summed step split | one pass — {describe(ctx)}; load {os.getloadavg()[0]:.1f} at start")
    extra = {}
    if args.scene == "scan":
        from bench_fidelity import SCAN_VALUES
        extra = dict(SCAN_VALUES)
    maps_list = [int(x) for x in args.maps.split(",")]
    # side -> (SPLIT_SUM, LIT_RING); True / False: split / one pass as the defaults have them
    kinds: dict = {True: (True, deon_passes.LIT_RING), False: (False, None)}
    kinds.update({f"lit{x}": (True, int(x)) for x in args.lit_rings.split(",") if x})
    default_lit = deon_passes.LIT_RING

    def use(side) -> None:
        deon_passes.SPLIT_SUM, deon_passes.LIT_RING = kinds[side]
    setups = {}
    for maps in maps_list:
        s = settings_for("deon", "head", args.size, maps, **extra)
        phong = settings_for("phong", "head", args.size, maps, **extra)
        sides = {}
        for side in kinds:
            use(side)
            sides[side] = Renderer(ctx)
            sides[side].render(s, force=True)
        use(True)
        rp = Renderer(ctx)
        rp.render(phong, force=True)
        setups[maps] = (s, phong, sides, rp)
    ms: dict[tuple, list[float]] = {}

    def add(key, v):
        ms.setdefault(key, []).append(v)

    for k in range(args.repeats):
        for maps, (s, phong, sides, rp) in setups.items():
            for split in kinds:
                use(split)
                r = sides[split]
                t, rep = light_frame(r, s, k)
                add((maps, split, "light"), t)
                add((maps, split, "light summed"), summed_ms(rep))
                t, rep = timed(r, s, force=True)
                add((maps, split, "full"), t)
                add((maps, split, "full summed"), summed_ms(rep))
                add((maps, split, "full weights"), weights_ms(rep))
                cam = with_values(s, {"camera.yaw": s.camera.yaw + 3.0 * (k + 1)})
                r.render(s)
                add((maps, split, "camera"), timed(r, cam)[0])
                r.render(s)
            use(True)
            add((maps, "phong", "light"), light_frame(rp, phong, k)[0])
            add((maps, "phong", "full"), timed(rp, phong, force=True)[0])
            rp.render(phong)
            add((maps, "phong", "camera"), timed(rp, with_values(phong, {"camera.yaw": phong.camera.yaw + 3.0 * (k + 1)}))[0])
            rp.render(phong)
            add((maps, "copy", ""), copy_draw_ms(rp, maps, 3))
    med = {key: statistics.median(v) for key, v in ms.items()}
    for maps, (_s, _phong, sides, _rp) in setups.items():
        copy = med[(maps, "copy", "")]
        print(f"# scene={args.scene} image={args.size}^2 maps={maps}^2 repeats={args.repeats}; load "
              f"{os.getloadavg()[0]:.1f} at the end; plain copy {copy:.2f} ms ({maps}^2 RGBA32F)")
        print(f"{'':<28} {'one pass (before)':>20} {'split (after)':>20} {'change':>8}")
        for kind in ("light", "full", "camera"):
            b, a, p = med[(maps, False, kind)], med[(maps, True, kind)], med[(maps, "phong", kind)]
            print(f"{kind + ' frame':<28} {b:>9.0f} ms {b / p:>5.2f}x {a:>9.0f} ms {a / p:>5.2f}x "
                  f"{100 * (a / b - 1):>+7.0f}%   (Phong {p:.0f} ms)")
        for key, label in (("light summed", "summed step, light move"), ("full summed", "summed step, full frame"),
                           ("full weights", "weight pass, full frame")):
            b, a = med[(maps, False, key)], med[(maps, True, key)]
            print(f"{label:<28} {b:>9.0f} ms {b / copy:>5.0f}cp {a:>9.0f} ms {a / copy:>5.0f}cp")
        for side in (k for k in kinds if isinstance(k, str)):
            b = med[(maps, False, "light")]
            print(f"split, LIT_RING = {kinds[side][1]}: light move {med[(maps, side, 'light')]:.0f} ms "
                  f"({100 * (med[(maps, side, 'light')] / b - 1):+.0f} % against one pass), summed step "
                  f"{med[(maps, side, 'light summed')]:.0f} ms ({med[(maps, side, 'light summed')] / copy:.0f} copies)")
        for split in (False, True):
            mem = renderer_memory(sides[split])
            w = sum(t.size[0] * t.size[1] * t.components * 2 for name, t in
                    sides[split].graph("deon").res.textures.items() if name.startswith("deon_gather_w"))
            print(f"# memory held, {'split' if split else 'one pass'}: {sum(mem.values()) / 2**20:.1f} MiB "
                  f"(the kept weights {w / 2**20:.1f} MiB)")
    deon_passes.SPLIT_SUM, deon_passes.LIT_RING = True, default_lit
    first = maps_list[0]
    for maps in maps_list[1:]:
        texels = (maps / first) ** 2
        for split in (False, True):
            print(f"# growth {first}^2 -> {maps}^2 ({texels:.0f}x texels), {'split' if split else 'one pass'}: "
                  + ", ".join(f"{kind} {med[(maps, split, kind)] / med[(first, split, kind)]:.2f}x"
                              for kind in ("full", "light", "camera")))

if __name__ == "__main__":
    main()
