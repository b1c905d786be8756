"""Where a d'Eon light move's time goes, draw by draw (issue 27, "Also asked"): every full-screen draw
and mesh draw of a light-move frame timed with glFinish before and after (sync timing: llvmpipe's
timer queries are not trustworthy), grouped by pass and program variant, medians over --repeats,
in plain copies (shaders/copy.frag, RGBA32F) of the map size, with Phong's light move beside them
in the same run.

    python benchmarks/bench_deon_draws.py [--maps 1024] [--size 640] [--repeats 3] [--set key=value ...]
        [--ab program:DEFINE=value ...] [--ab-no-zone-split] [--ab-no-seam-split] [--ab-unsplit-sum]
        [--ab-unsplit-irradiance] [--ab-no-quad-sum] [--ab-no-sum-cuts] [--ab-unsplit-final] [--ab-no-view-cull]

--ab times a side B too, interleaved with A in each repeat: the named program compiled with the extra
define (e.g. deon_irradiance_texels:DEON_TEXEL_SAMPLES=0, the uniform-driven irradiance); the
--ab-no-* flags make B draw every blur tile with the zone checks / seam-fill every fill tile (the code
before passes.deon.zone_split / seam_split); --ab-unsplit-sum makes B sum the narrow step in one pass
(deon_surface_gather.frag, passes.deon.SPLIT_SUM off: the code before the weights were kept), in a second
renderer (a light move does not re-reflect the pass); --ab-unsplit-irradiance makes B shade the irradiance
in one pass (passes.deon.SPLIT_IRRADIANCE off: the code before its light-independent pass), in a second
renderer too; --ab-no-quad-sum makes B sum the split step one texel a fragment (deon_gather_sum.frag,
passes.deon.QUAD_SUM 0: the code before the quad sum), in a second renderer too; --ab-no-sum-cuts makes B
seam-fill the summed step's input without the plain tiles and fetch every combine slot (passes.deon.
GATHER_FILL_SPLIT and COMBINE_ONCE off: the code before session 9), in a second renderer too;
--ab-unsplit-final makes B shade the final pass in one pass (passes.deon.SPLIT_FINAL 0), in a second
renderer too; --ab-no-view-cull runs A with deon.view_cull = view and B with off (every texture-space tile, the code before
section 17), in a second renderer too, and times per side the camera-only frames after each light move (yaw
+10: the tiles the turned view needs and no pass holds; then back: every tile held) and prints the share of
tiles the culled passes made. B's rows are marked (B).

The timing itself adds a glFinish per draw (a few ms a frame on llvmpipe): the per-draw figures
are for comparing draws, the frame figure is bench_blur_floor.py's. Under load the A and B frame
lines can differ by far more than their draws do (seen once: 1.9 vs 3.0 s with draws 5 % apart):
trust the per-draw lines, each fenced on both sides.
"""
from __future__ import annotations

import argparse
import collections
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(__file__))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from bench_blur_floor import light_frame  # noqa: E402
from bench_frames import copy_draw_ms, settings_for  # noqa: E402

import skinviewer.passes.deon as deon_passes  # noqa: E402
from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import with_values  # noqa: E402
from skinviewer.kernel import execute  # noqa: E402
from skinviewer.kernel.gl import describe, headless_context  # noqa: E402

LOG: list[tuple[str, str, tuple, float]] = []
NAMES: dict[int, str] = {}
VARIANT: dict[str, dict] = {}  # program name -> extra defines (--ab), while the B side runs


def _label(name: str, defines: dict) -> str:
    keep = {k: v for k, v in defines.items() if k not in ("MAX_GAUSSIANS", "N_LIGHTS")}
    return name + ("[" + ",".join(f"{k}={v}" for k, v in sorted(keep.items())) + "]" if keep else "")


def instrument() -> None:
    """Wrap ExecuteContext.program (to name programs) and its draws (to time them)."""
    ec_cls = execute.ExecuteContext
    program = ec_cls.program

    def named_program(self, name, **defines):
        if not defines:
            declared = [d for n, d in self._refl.programs if n == name]
            defines = dict(declared[0]) if len(declared) == 1 else {}
        if name in VARIANT:  # the B side of --ab: the same program with extra defines
            defines = {**defines, **VARIANT[name]}
            prog = self.graph.shaders.get(name, defines)
        else:
            prog = program(self, name, **defines)
        NAMES[id(prog)] = _label(name, defines)
        return prog

    ec_cls.program = named_program
    for meth in ("draw_fullscreen", "draw_mesh"):
        orig = getattr(ec_cls, meth, None)
        if orig is None:
            continue

        def timed(self, prog, *a, _orig=orig, **k):
            self.gl.finish()
            t0 = time.perf_counter()
            _orig(self, prog, *a, **k)
            self.gl.finish()
            LOG.append((self.pass_.name, NAMES.get(id(prog), "?"), bool(k.get("tiles")), (time.perf_counter() - t0) * 1000.0))

        setattr(ec_cls, meth, timed)


def parse_sets(items: list[str]) -> dict:
    out = {}
    for kv in items:
        k, v = kv.split("=", 1)
        val: object = {"true": True, "false": False}.get(v.lower(), v)
        if isinstance(val, str):
            try:
                val = float(v) if "." in v else int(v)
            except ValueError:
                pass
        out[k] = val
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", default="1024",
                    help="map size; a list (1024,2048): the growth mode, each size's light move (whole frames, "
                         "no per-draw fences) and plain copy interleaved in each repeat, in one process")
    ap.add_argument("--size", type=int, default=640)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--scene", default="head")
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("--ab", action="append", default=[],
                    help="program:DEFINE=value: time the program with that extra define too (B), interleaved")
    ap.add_argument("--ab-no-zone-split", action="store_true",
                    help="B also draws every blur tile with the zone checks (passes.deon.zone_split off)")
    ap.add_argument("--ab-no-seam-split", action="store_true",
                    help="B also seam-fills every fill tile (passes.deon.seam_split off)")
    ap.add_argument("--ab-unsplit-sum", action="store_true",
                    help="B sums the narrow step in one pass (passes.deon.SPLIT_SUM off), in its own renderer")
    ap.add_argument("--ab-unsplit-irradiance", action="store_true",
                    help="B shades the irradiance in one pass (passes.deon.SPLIT_IRRADIANCE off), in its own renderer")
    ap.add_argument("--ab-no-quad-sum", action="store_true",
                    help="B sums the split step one texel a fragment (passes.deon.QUAD_SUM 0), in its own renderer")
    ap.add_argument("--ab-no-sum-cuts", action="store_true",
                    help="B without the summed step's split seam fill and the combine's shared fetches "
                         "(passes.deon.GATHER_FILL_SPLIT, COMBINE_ONCE off), in its own renderer")
    ap.add_argument("--ab-unsplit-final", action="store_true",
                    help="B shades the final pass in one pass (passes.deon.SPLIT_FINAL 0), in its own renderer")
    ap.add_argument("--ab-no-view-cull", action="store_true",
                    help="B makes every texture-space tile (deon.view_cull = off), in its own renderer; camera frames timed")
    args = ap.parse_args()
    sizes = [int(v) for v in str(args.maps).split(",")]
    if len(sizes) > 1:
        growth(args, sizes)
        return
    args.maps = sizes[0]
    quad = deon_passes.QUAD_SUM
    split_final = deon_passes.SPLIT_FINAL
    ctx = headless_context()
    print(f"# d'Eon light move, draw by draw — {describe(ctx)}; load {os.getloadavg()[0]:.1f} at start")
    instrument()
    r = Renderer(ctx)
    s = settings_for("deon", args.scene, args.size, args.maps, **parse_sets(args.set))
    phong = settings_for("phong", args.scene, args.size, args.maps)
    r.render(s, force=True)
    r.render(phong, force=True)
    ra = rb = r
    own = (args.ab_unsplit_sum or args.ab_unsplit_irradiance or args.ab_no_quad_sum or args.ab_no_sum_cuts
           or args.ab_unsplit_final or args.ab_no_view_cull)  # B in a renderer of its own
    if args.ab_no_view_cull:  # A culls (deon.view_cull = view), B does not
        s = with_values(s, {"deon.view_cull": "view"})
        ra.render(s, force=True)
    s_b = with_values(s, {"deon.view_cull": "off"}) if args.ab_no_view_cull else s
    cuts = deon_passes.GATHER_FILL_SPLIT, deon_passes.COMBINE_ONCE
    if own:
        deon_passes.SPLIT_SUM = not args.ab_unsplit_sum
        deon_passes.SPLIT_IRRADIANCE = not args.ab_unsplit_irradiance
        deon_passes.QUAD_SUM = "0" if args.ab_no_quad_sum else quad
        if args.ab_no_sum_cuts:
            deon_passes.GATHER_FILL_SPLIT = deon_passes.COMBINE_ONCE = False
        deon_passes.SPLIT_FINAL = "0" if args.ab_unsplit_final else split_final
        rb = Renderer(ctx)
        rb.render(s_b, force=True)
        deon_passes.SPLIT_SUM = deon_passes.SPLIT_IRRADIANCE = True
        deon_passes.QUAD_SUM = quad
        deon_passes.GATHER_FILL_SPLIT, deon_passes.COMBINE_ONCE = cuts
        deon_passes.SPLIT_FINAL = split_final
        ra = Renderer(ctx)  # A in a renderer of its own too: neither side shares Phong's pool
        ra.render(s, force=True)
    per: dict[tuple, list[float]] = collections.defaultdict(list)
    counts: dict[tuple, int] = {}
    frames, frames_b, phongs, copies, halves = [], [], [], [], []
    cams: dict[tuple[str, str], list[float]] = collections.defaultdict(list)  # (side, turned | back) -> ms
    shares: dict[tuple[str, str], list[float]] = collections.defaultdict(list)  # (side, pass) -> tiles made
    variant: dict[str, dict] = {}
    for a in args.ab:
        name, kv = a.split(":", 1)
        variant.setdefault(name, {}).update(parse_sets([kv]))
    zone_split, seam_split = deon_passes.zone_split, deon_passes.seam_split
    for k in range(args.repeats):
        sides = ("A", "B") if variant or args.ab_no_zone_split or args.ab_no_seam_split or own else ("A",)
        for side in (sides if k % 2 == 0 else sides[::-1]):  # each side first in every other repeat
            VARIANT.clear()
            deon_passes.zone_split, deon_passes.seam_split = zone_split, seam_split
            deon_passes.SPLIT_SUM = side == "A" or not args.ab_unsplit_sum
            deon_passes.SPLIT_IRRADIANCE = side == "A" or not args.ab_unsplit_irradiance
            deon_passes.QUAD_SUM = "0" if side == "B" and args.ab_no_quad_sum else quad
            deon_passes.GATHER_FILL_SPLIT, deon_passes.COMBINE_ONCE = (False, False) if side == "B" and args.ab_no_sum_cuts else cuts
            deon_passes.SPLIT_FINAL = "0" if side == "B" and args.ab_unsplit_final else split_final
            if side == "B":
                VARIANT.update(variant)
                if args.ab_no_zone_split:
                    deon_passes.zone_split = lambda *a, **k: None
                if args.ab_no_seam_split:
                    deon_passes.seam_split = lambda *a, **k: None
            LOG.clear()
            rs, ss = (ra, s) if side == "A" else (rb, s_b)
            ms_frame, rep_light = light_frame(rs, ss, k)
            (frames if side == "A" else frames_b).append(ms_frame)
            for p in rep_light.passes:
                if p.status == "ran" and "view_tiles" in p.figures:
                    shares[(side, p.name)].append(p.figures["view_tiles"])
            # the base frame of light_frame is untimed but its draws are logged too: keep the second half
            frame = collections.defaultdict(float)
            n = collections.Counter()
            base = len(LOG) // 2
            for p, prog, _tiled, ms in LOG[base:]:
                label = prog if side == "A" else "(B) " + prog  # B: the --ab side
                frame[(p, label)] += ms
                n[(p, label)] += 1
            for key, ms in frame.items():
                per[key].append(ms)
                counts[key] = n[key]
            if args.ab_no_view_cull:  # the camera-only frames after the light move (not per draw)
                moved = rep_light_settings(ss, k)
                for label, view in (("turned", with_values(moved, {"camera.yaw": moved.camera.yaw + 10.0})),
                                    ("back", moved)):
                    rs.ctx.finish()
                    t0 = time.perf_counter()
                    rs.render(view)
                    rs.ctx.finish()
                    cams[(side, label)].append((time.perf_counter() - t0) * 1000.0)
        VARIANT.clear()
        deon_passes.zone_split, deon_passes.seam_split = zone_split, seam_split
        deon_passes.SPLIT_SUM = deon_passes.SPLIT_IRRADIANCE = True
        deon_passes.QUAD_SUM = quad
        deon_passes.GATHER_FILL_SPLIT, deon_passes.COMBINE_ONCE = cuts
        deon_passes.SPLIT_FINAL = split_final
        LOG.clear()
        phongs.append(light_frame(r, phong, k)[0])
        copies.append(copy_draw_ms(r, args.maps, 3))
        halves.append(copy_draw_ms(r, args.maps // 2, 3))
    copy, half = statistics.median(copies), statistics.median(halves)
    print(f"# scene={args.scene} image={args.size}^2 maps={args.maps}^2 repeats={args.repeats} {args.set or 'defaults'}; "
          f"load {os.getloadavg()[0]:.1f} at the end")
    ph = statistics.median(phongs)
    b = (f"; with --ab (B) {statistics.median(frames_b):.0f} ms = {statistics.median(frames_b) / ph:.2f} x Phong"
         if frames_b else "")
    print(f"# light move (timed per draw) {statistics.median(frames):.0f} ms = {statistics.median(frames) / ph:.2f} x Phong{b}; "
          f"Phong {ph:.0f} ms; "
          f"copy {copy:.2f} ms ({args.maps}^2), {half:.2f} ms ({args.maps // 2}^2)")
    for (side, label), ms_list in sorted(cams.items()):
        print(f"# camera frame after the light move, {label} ({'view culling' if side == 'A' else 'B: off'}): "
              f"{statistics.median(ms_list):.0f} ms")
    for (side, name), fr in sorted(shares.items()):
        print(f"# {name} made {100.0 * statistics.median(fr):.0f} % of its tiles in the light move ({side})")
    hdr = f"{'pass':<18} {'program':<58} {'draws':>5} {'ms':>8} {'/ copy':>7}"
    print(hdr)
    print("-" * len(hdr))
    total = 0.0
    for key in sorted(per, key=lambda k: -statistics.median(per[k])):
        ms = statistics.median(per[key])
        total += ms
        print(f"{key[0]:<18} {key[1]:<58} {counts[key]:>5} {ms:8.1f} {ms / copy:7.1f}")
    print(f"{'sum of draws':<18} {'':<58} {'':>5} {total:8.1f} {total / copy:7.1f}")


def rep_light_settings(s, k: int):
    """The settings light_frame moved the key light to in repeat ``k`` (bench_blur_floor.light_frame)."""
    d = s.lights[0].direction
    return with_values(s, {"lights.0.direction": (d[0] + 0.02 * (k + 1), d[1], d[2])})


def growth(args, sizes: list[int]) -> None:
    """Issue 27's growth goal (a light move's cost at most linear in texels): per map size, one renderer,
    its light move (light_frame: whole frames, sync timing at the frame's ends only) and a plain copy of that
    size, interleaved in each repeat (sizes in turn, the order reversed every other repeat), Phong beside."""
    ctx = headless_context()
    print(f"# d'Eon light move by map size — {describe(ctx)}; load {os.getloadavg()[0]:.1f} at start")
    sets = parse_sets(args.set)
    renderers, settings = {}, {}
    for n in sizes:
        settings[n] = settings_for("deon", args.scene, args.size, n, **sets)
        renderers[n] = Renderer(ctx)
        renderers[n].render(settings[n], force=True)
    phong_r = Renderer(ctx)
    phong = settings_for("phong", args.scene, args.size, sizes[0])
    phong_r.render(phong, force=True)
    frames: dict[int, list[float]] = collections.defaultdict(list)
    copies: dict[int, list[float]] = collections.defaultdict(list)
    phongs = []
    for k in range(args.repeats):
        for n in (sizes if k % 2 == 0 else sizes[::-1]):
            frames[n].append(light_frame(renderers[n], settings[n], k)[0])
            copies[n].append(copy_draw_ms(renderers[n], n, 3))
        phongs.append(light_frame(phong_r, phong, k)[0])
    ph = statistics.median(phongs)
    print(f"# scene={args.scene} image={args.size}^2 repeats={args.repeats} {args.set or 'defaults'}; "
          f"load {os.getloadavg()[0]:.1f} at the end; Phong's light move {ph:.0f} ms")
    print(f"{'maps':>6} {'light move ms':>14} {'x Phong':>8} {'copy ms':>8} {'/ copy':>7}")
    med = {n: (statistics.median(frames[n]), statistics.median(copies[n])) for n in sizes}
    for n in sizes:
        ms, cp = med[n]
        print(f"{n:>6} {ms:14.0f} {ms / ph:8.2f} {cp:8.2f} {ms / cp:7.1f}")
    for a, b in zip(sizes, sizes[1:]):
        texels = (b / a) ** 2
        print(f"# growth {a}^2 -> {b}^2 ({texels:.0f}x texels): light move {med[b][0] / med[a][0]:.2f}x "
              f"(goal <= {texels:.0f}x); a plain copy {med[b][1] / med[a][1]:.2f}x")


if __name__ == "__main__":
    main()
