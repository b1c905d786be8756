"""Frame time of each technique relative to Phong, full frame vs camera-only frame, measured side by
side in one run (synchronous per-pass timing: glFinish + wall clock, right on llvmpipe), and the
ratios of issue 14.

    python benchmarks/bench_frames.py [--scene head] [--size 640] [--maps 1024] [--repeats 5] [--lighter]

By default the defaults a user gets (640^2 view, 1024^2 maps); --lighter also runs 256^2 / 512^2 and
says so beside it (issue 27: figures of lighter settings are named as such).

A "full frame" re-runs every pass (forced); a "camera-only frame" changes the yaw, so the graph
re-runs only view-dependent passes. Figures are medians over --repeats.

Two states, both printed and named:
* "sequence": one Renderer runs every technique in turn, interleaved (machine noise hits all
  alike; techniques share the texture pool and the shader library, as in the viewer);
* "fresh": each technique in its own new Renderer and ShaderLibrary, nothing else run before it.

Memory ("tex MiB", fresh state) is everything a renderer holds after that technique's frames alone
(engine/memory.py: graph outputs, free pooled scratch, depth buffers, scene maps with mips, mesh
buffers), not only declared outputs; the sequence renderer's total is printed below the ratios.
"""
from __future__ import annotations

import argparse
import statistics
import time

import moderngl

from skinviewer import techniques
from skinviewer.engine.memory import renderer_memory
from skinviewer.engine.renderer import Renderer
from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.gl import describe, headless_context
from skinviewer.scene.scenes import scene_overrides


def settings_for(tech: str, scene: str, size: int, maps: int, **extra) -> Settings:
    return with_values(Settings(), {"scene.name": scene, **scene_overrides(scene), "technique": tech,
                                    "render.width": size, "render.height": size, "render.timing": "sync",
                                    "shadow.map_size": maps, "gosselin.light_map_size": maps,
                                    "deon.irradiance_size": maps, "deon.tsm_size": maps, **extra})


def wall_ms(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return (time.perf_counter() - t0) * 1000.0


def full_ms(r: Renderer, s: Settings) -> float:
    return wall_ms(lambda: (r.render(s, force=True), r.ctx.finish()))


def cam_ms(r: Renderer, s: Settings, k: int) -> tuple[float, list[str]]:
    s2 = with_values(s, {"camera.yaw": s.camera.yaw + 5.0 * (k + 1)})
    out = {}

    def frame():
        out["rep"] = r.render(s2)
        r.ctx.finish()
    ms = wall_ms(frame)
    r.render(s)  # back to the base view (not timed)
    return ms, out["rep"].ran


def light_ms(r: Renderer, s: Settings, k: int) -> float:
    """A frame after the key light moved: every lighting-dependent pass re-runs, mesh-only passes
    (gutter and seam maps, stretch, LUTs) stay cached: the cost of dragging a light."""
    d = s.lights[0].direction
    s2 = with_values(s, {"lights.0.direction": (d[0] + 0.02 * (k + 1), d[1], d[2])})
    r.render(s)  # from the base frame (not timed): a frame of other settings may have run in between
    r.ctx.finish()
    ms = wall_ms(lambda: (r.render(s2), r.ctx.finish()))
    r.render(s)  # back to the base light (not timed)
    return ms


def copy_draw_ms(r: Renderer, size: int, repeats: int) -> float:
    """One plain full-screen copy (shaders/copy.frag) into an RGBA32F size x size target."""
    ctx = r.ctx
    prog = r.shaders.get("copy")
    src = ctx.texture((size, size), 4, dtype="f4")
    dst = ctx.texture((size, size), 4, dtype="f4")
    fbo = ctx.framebuffer([dst])
    vao = ctx.vertex_array(prog, [])
    src.use(0)
    prog["source"].value = 0
    fbo.use()
    ctx.disable(moderngl.DEPTH_TEST)
    times = []
    for _ in range(repeats + 1):
        ctx.finish()
        t0 = time.perf_counter()
        vao.render(vertices=3)
        ctx.finish()
        times.append((time.perf_counter() - t0) * 1000.0)
    for o in (vao, fbo, src, dst):
        o.release()
    return statistics.median(times[1:])


def blur_draw_ms(report, name: str, seam_fill: bool) -> tuple[float | None, int]:
    """A blur pass's time per blur direction (its H and V draws, times its sub-steps), the seam-fill
    draw that precedes each direction (scene.seam_aware) included."""
    rec = {p.name: p for p in report.passes}.get(name)
    if rec is None or rec.ms is None or not rec.draws:
        return None, 0
    directions = rec.figures.get("directions") or (rec.draws // 2 if seam_fill else rec.draws)
    return rec.ms / max(directions, 1), directions


DEFAULTS = (640, 1024)  # what a user gets: a 640^2 view, 1024^2 maps (ground/settings.py)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="head")
    ap.add_argument("--size", type=int, default=DEFAULTS[0], help="image size (default: the defaults' 640)")
    ap.add_argument("--maps", type=int, default=DEFAULTS[1], help="shadow / light / irradiance map size (default 1024)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--lighter", action="store_true",
                    help="also a lighter configuration (256^2 image, 512^2 maps), printed after and named so")
    args = ap.parse_args()
    configs = [(args.size, args.maps)] + ([(256, 512)] if args.lighter else [])
    for size, maps in configs:
        args.size, args.maps = size, maps
        which = ("the defaults" if (size, maps) == DEFAULTS else
                 f"LIGHTER than the defaults ({DEFAULTS[0]}^2 view, {DEFAULTS[1]}^2 maps)"
                 if size * size <= DEFAULTS[0] ** 2 and maps <= DEFAULTS[1] else "heavier than the defaults")
        print(f"## configuration: image {size}^2, maps {maps}^2 — {which}")
        run(args)
        print()


def run(args) -> None:
    ctx = headless_context()
    names = techniques.names()
    base = {t: settings_for(t, args.scene, args.size, args.maps) for t in names}

    # -- sequence: one renderer, techniques interleaved ------------------------------------------
    r = Renderer(ctx)
    full: dict[str, list[float]] = {t: [] for t in names}
    cam: dict[str, list[float]] = {t: [] for t in names}
    ran_cam: dict[str, list[str]] = {}
    mem: dict[str, float] = {}
    # the extra frames (d'Eon): every light at zero; head under 1 % of the screen vs close-up
    auto = {"deon.irradiance_size_mode": "auto", "shadow.map_size_mode": "auto"}
    dark = settings_for("deon", args.scene, args.size, args.maps,
                        **{f"lights.{i}.intensity": 0.0 for i in range(len(base["deon"].lights))})
    close = settings_for("deon", args.scene, args.size, args.maps, **auto)
    far = with_values(close, {"camera.distance": close_distance(r, close) * 12.0})
    extra = {"dark": dark, "close": close, "far": far}
    extra_ms: dict[str, list[float]] = {k: [] for k in extra}
    unsummed = with_values(base["deon"], {"deon.combine_blurs": False})  # the final pass sums the blurs
    unsummed_cam: list[float] = []
    r_unsummed = Renderer(ctx, r.shaders)  # its own graph: switching would re-run the chain
    light: dict[str, list[float]] = {t: [] for t in ("phong", "deon")}
    extra_light: dict[str, list[float]] = {"close": [], "far": []}
    for t in names:  # warm-up: compile shaders, build scene, first allocation
        r.render(base[t], force=True)
    for s in extra.values():
        r.render(s, force=True)
    r_unsummed.render(unsummed, force=True)
    for k in range(args.repeats):
        for t in names:
            full[t].append(full_ms(r, base[t]))
            ms, ran = cam_ms(r, base[t], k)
            cam[t].append(ms)
            ran_cam[t] = ran
        for key, s in extra.items():
            extra_ms[key].append(full_ms(r, s))
        unsummed_cam.append(cam_ms(r_unsummed, unsummed, k)[0])
        for t in light:
            light[t].append(light_ms(r, base[t], k))
        for key in ("close", "far"):
            extra_light[key].append(light_ms(r, extra[key], k))
    # one d'Eon blur direction (pass time / its H+V directions) vs a plain copy of the same size and format
    rep = r.render(base["deon"], force=True)
    blur_name = next((p.name for p in rep.passes if p.name.startswith("deon_blur_") and p.status == "ran"
                      and p.draws), "deon_blur_5")  # the first blur not folded (deon.fold_below_texels)
    blur, draws = blur_draw_ms(rep, blur_name, base["deon"].scene.seam_aware)
    copy = copy_draw_ms(r, args.maps, args.repeats)
    far_rep = r.render(far, force=True)
    coverage = {p.name: p.reason for p in far_rep.passes}.get("deon_irradiance", "")

    # -- fresh: each technique alone in a new renderer -------------------------------------------
    fresh_full: dict[str, float] = {}
    fresh_cam: dict[str, float] = {}
    for t in names:
        rf = Renderer(ctx)
        rf.render(base[t], force=True)
        fresh_full[t] = statistics.median(full_ms(rf, base[t]) for _ in range(args.repeats))
        fresh_cam[t] = statistics.median(cam_ms(rf, base[t], k)[0] for k in range(args.repeats))
        mem[t] = sum(renderer_memory(rf).values()) / 2**20  # this technique alone
        rf.release()
        rf.shaders.release()

    print(f"# skinviewer frame times — {describe(ctx)}")
    print(f"# scene={args.scene} image={args.size}x{args.size} maps={args.maps}^2 repeats={args.repeats}; "
          f"timing mode: sync (glFinish + wall clock); medians; one run, side by side (shared, loaded machine)")
    print("# sequence = one renderer, techniques interleaved; fresh = each technique alone in a new renderer")
    ref, fref = statistics.median(full["phong"]), fresh_full["phong"]
    cref = statistics.median(cam["phong"])
    hdr = (f"{'technique':<10} {'seq full ms':>12} {'x phong':>8} {'seq cam ms':>11} {'x phong':>8} "
           f"{'fresh full':>11} {'x phong':>8} {'fresh cam':>10} {'tex MiB':>8}  camera-only re-ran")
    print(hdr)
    print("-" * len(hdr))
    for t in names:
        f, c = statistics.median(full[t]), statistics.median(cam[t])
        print(f"{t:<10} {f:12.1f} {f / ref:8.2f} {c:11.1f} {c / cref:8.2f} {fresh_full[t]:11.1f} "
              f"{fresh_full[t] / fref:8.2f} {fresh_cam[t]:10.1f} {mem[t]:8.1f}  {', '.join(ran_cam[t])}")
    print()
    m = {k: statistics.median(v) for k, v in extra_ms.items()}
    lit = statistics.median(full["deon"])
    print("## issue 14 ratios (sequence state unless said)")
    print(f"{'figure':<58} {'ratio':>7}  {'goal':>6}  detail")
    rows = [
        ("d'Eon full frame / Phong full frame", lit / ref, "<= 3.0", f"{lit:.1f} / {ref:.1f} ms"),
        ("d'Eon light-move frame / Phong light-move frame", statistics.median(light["deon"])
         / statistics.median(light["phong"]), "", f"{statistics.median(light['deon']):.1f} / "
         f"{statistics.median(light['phong']):.1f} ms (mesh-only passes cached)"),
        ("d'Eon full frame / Phong full frame (fresh)", fresh_full["deon"] / fref, "<= 3.0",
         f"{fresh_full['deon']:.1f} / {fref:.1f} ms"),
        ("d'Eon camera-only / Phong camera-only", statistics.median(cam["deon"]) / cref, "<= 1.2",
         f"{statistics.median(cam['deon']):.1f} / {cref:.1f} ms"),
        ("  the same, deon.combine_blurs off (blurs summed per pixel)", statistics.median(unsummed_cam) / cref,
         "", f"{statistics.median(unsummed_cam):.1f} / {cref:.1f} ms"),
        ("head under 1 % of the screen / close-up (d'Eon, auto)", m["far"] / m["close"], "<= 0.1",
         f"{m['far']:.1f} / {m['close']:.1f} ms; {coverage}"),
        ("  the same, light-move frames", statistics.median(extra_light["far"]) / statistics.median(extra_light["close"]),
         "", f"{statistics.median(extra_light['far']):.1f} / {statistics.median(extra_light['close']):.1f} ms"),
        ("every light at zero / lit frame (d'Eon)", m["dark"] / lit, "<= 0.05", f"{m['dark']:.1f} / {lit:.1f} ms"),
        ("one d'Eon blur direction / plain full-screen copy", (blur or 0.0) / copy, "<= 2.0",
         f"{blur or 0:.2f} / {copy:.2f} ms ({args.maps}^2 RGBA32F; {blur_name} / its {draws} directions, "
         "each with its seam fill)"),
    ]
    for name, ratio, goal, detail in rows:
        print(f"{name:<58} {ratio:7.3f}  {goal:>6}  {detail}")
    print()
    print("## memory held by the sequence renderer (every technique's graph), MiB")
    r.render(base["deon"])
    for k, v in renderer_memory(r).items():
        print(f"  {k:<24} {v / 2**20:8.2f}")
    print()
    for t in names:
        print(f"## {t}: last full frame, per pass (sequence)")
        print(r.render(base[t], force=True).table())
    for key in ("dark", "far"):
        print(f"## d'Eon {key} frame, per pass")
        print(r.render(extra[key], force=True).table())
    r_unsummed.release()
    r.release()
    ctx.release()


def close_distance(r: Renderer, s: Settings) -> float:
    """The default framing distance (camera.distance None frames the mesh)."""
    v = r.view(s)
    return float(((v.eye - r.scene.gpu.center) ** 2).sum() ** 0.5)


if __name__ == "__main__":
    main()
