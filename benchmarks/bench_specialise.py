"""Specialised lit shaders vs the generic, uniform-driven ones, per pass, side by side in one run.

    python benchmarks/bench_specialise.py [--scene head] [--size 256] [--maps 512] [--repeats 5]

Two renderers share one GL context: one compiles every program with GENERIC_SHADERS (light loop
bounded by u_light_count, the 7x7 PCF loop with `continue`, all four shadow samplers), the other
with the frame's LIGHT_COUNT / SHADOW_PCF / SHADOW_MASK (shaders/lib/lights.glsl). Forced full
frames, techniques in viewer order, the two variants interleaved; medians of sync timing
(glFinish + wall clock). The images are bit-identical (tests/test_specialise.py).
"""
from __future__ import annotations

import argparse
import statistics

from skinviewer import techniques
from skinviewer.engine.renderer import Renderer
from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.gl import describe, headless_context
from skinviewer.kernel.shaders import ShaderLibrary
from skinviewer.scene.scenes import scene_overrides

LIT_PASSES = ("phong", "gosselin_light_map", "gosselin_final", "deon_irradiance", "deon_final")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="head")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--maps", type=int, default=512)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    ctx = headless_context()
    variants = {"generic": Renderer(ctx, ShaderLibrary(ctx, defines={"GENERIC_SHADERS": 1})),
                "specialised": Renderer(ctx)}
    names = techniques.names()
    base = {t: with_values(Settings(), {"scene.name": args.scene, **scene_overrides(args.scene), "technique": t,
                                        "render.width": args.size, "render.height": args.size,
                                        "render.timing": "sync", "shadow.map_size": args.maps,
                                        "gosselin.light_map_size": args.maps, "deon.irradiance_size": args.maps,
                                        "deon.tsm_size": args.maps}) for t in names}
    for r in variants.values():  # warm-up: compile, scene, allocation
        for t in names:
            r.render(base[t], force=True)
    ms: dict[tuple[str, str, str], list[float]] = {}
    for _ in range(args.repeats):
        for t in names:
            for v, r in variants.items():
                rep = r.render(base[t], force=True)
                ms.setdefault((v, t, "frame"), []).append(rep.total_ms)
                for p in rep.passes:
                    if p.status == "ran" and p.ms is not None:
                        ms.setdefault((v, t, p.name), []).append(p.ms)
    print(f"# specialised vs generic lit shaders — {describe(ctx)}")
    print(f"# scene={args.scene} image={args.size}^2 maps={args.maps}^2 repeats={args.repeats}; sync timing")
    print(f"{'technique/pass':<28} {'generic ms':>11} {'special ms':>11} {'ratio':>6}")
    for t in names:
        for p in [n for n in LIT_PASSES if ("generic", t, n) in ms] + ["frame"]:
            g = statistics.median(ms[("generic", t, p)])
            s = statistics.median(ms[("specialised", t, p)])
            print(f"{t + '/' + p:<28} {g:11.1f} {s:11.1f} {s / g:6.2f}")
    for r in variants.values():
        r.release()
        r.shaders.release()
    ctx.release()


if __name__ == "__main__":
    main()
