"""The ruler's own figures (issue 30; printed, never asserted):

  edge    the zoomed shadow-edge (light -0.5, 0, 0.866; camera 100 mm above the cast edge x = 21 tan 30,
          3 deg field; no specular, rho_dt off) against E sum_i w_i Phi((x - x_e) / sigma_i): the worst
          pixel in % of the lit level, version 4 (elements carry their corners' mean) and version 5
          (elements cut along the shadow edge), at 0.5 and 0.25 mm elements.
  head    the default head's truth: CPU seconds (time.process_time) of version 4 and of version 5 with its
          uncertainty, in one process; how far the truth moved; its uncertainty (median / p99 / as RMS).
  unc     the stated uncertainty against the true error on the analytic scenes (zoomed edge, lit slab, laser).
  rim     d'Eon on the uniformly lit 24 mm slab: power kept and the rim profile against the analytic open square,
          deon.open_border absorb (before issue 30 item 5) and reflect (the default), at 512^2 (the first step
          summed over the surface, its rim texel counted by its share) and 1024^2 (every step separable).

  truth   d'Eon, open border absorb and reflect, against the ground truth on the scenes with open borders.
  cost    what deon.open_border = reflect costs against absorb (shadow-edge, sync timing, interleaved).
  samples deon.texel_samples 1 / 4 (issue 30 item 4) x irr512 / irr1024 against the ground truth on the default
          head and the scan (--size, default 512; the notes' table: 192), with the default lights and the key light
          only (--samples-rigs): the truth as computed and converged further where the p99 is decided
          (reference.refine_at, --samples-rounds), and the paired p99 change (metrics.p99_change_bounds).
  samples-tail  where the p99 tail of d'Eon against the truth is (head and scan, --size; --tail-map DIR: PNG maps).
  samples-cost  the irradiance pass and the whole frame, texel_samples 1 vs 4 x PCF default vs 0, at the defaults (1024^2 maps,
          640^2 view), head and scan, sync timing, 3 interleaved repeats.
  interp  the environment's interpolation term on tests/test_reference.py's blade under the studio environment: the
          truth's error against the same truth with the environment estimated at every point it is read, within
          the +- without the term, with version 9's (the mean of the 8 nearest checks) and with this one (each
          triangle's corner checks through the diffusion sum), and where red's error comes from (the blade's
          far face estimated at every point instead).

Run: python3 benchmarks/bench_ruler.py [--parts edge,unc,rim,truth,cost,head,samples,samples-tail,samples-cost,interp] [--size 512] [--edge-size 32] [--rim-size 512,1024]
     [--samples-scenes head,scan] [--samples-rigs default,key] [--samples-rounds 2] [--samples-max-pixels 1500] [--tail-map DIR]
     [--samples-env-factors 8,64]
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np
from scipy.special import ndtr

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # analytic_judge: the tests' closed-form oracle

import analytic_judge as A

from skinviewer.engine.reference import compute_reference
from skinviewer.ground.settings import Settings, with_values
from skinviewer.physics import ground_truth as gt
from skinviewer.scene.scenes import scene_overrides

G = Settings().deon.gaussians
V = np.array([g.variance for g in G])
W = np.array([g.weights for g in G])
XE = 21.0 * math.tan(math.radians(30.0))
LIT = 0.8 * 0.866 / math.hypot(0.5, 0.866)


def scene(name: str, size: int, **assign) -> Settings:
    return with_values(Settings(), {"scene.name": name, **scene_overrides(name), "render.width": size,
                                    "render.height": size, "deon.energy_conservation": False,
                                    "specular.rho_s": 0.0, **assign})


def zoomed_edge(size: int) -> Settings:
    return scene("shadow-edge", size, lights=[{"kind": "directional", "direction": [-0.5, 0.0, 0.866], "intensity": 0.8, "cast_shadow": True}], camera={"yaw": 0.0, "pitch": 0.0, "distance": 100.0, "target": [XE, 0.0, 0.0], "fov_y": 3.0})


def edge_expect(p):
    return LIT * (W[None] * ndtr((p[:, :1] - XE) / np.sqrt(V)[None])[..., None]).sum(1)


def slab(size: int) -> Settings:
    return scene("laser", size, lights=[{"kind": "directional", "direction": [0, 0, 1], "intensity": 2.0,
                                          "cast_shadow": True}])


def box(u, sd, a=12.0):
    return ndtr((a - u) / sd) - ndtr((-a - u) / sd)


def slab_expect(p):
    sd = np.sqrt(V)[None, :]
    return 2.0 * (W[None] * (box(p[:, :1], sd) * box(p[:, 1:2], sd))[..., None]).sum(1)


def part_edge(size: int) -> None:
    print(f"## zoomed shadow edge, {size}^2: worst pixel, % of the lit level (R / G / B)")
    for h in (0.5, 0.25):
        row = []
        for split in (False, True):
            ref = compute_reference(zoomed_edge(size), h_mm=h, use_cache=False, split_edges=split, uncertainty=False)
            p = ref.position[ref.mask]
            err = np.abs(ref.diffuse[ref.mask] - edge_expect(p)).max(0) / LIT
            row.append(" / ".join(f"{100 * e:.2f}" for e in err))
        print(f"  {h} mm elements: version 4 {row[0]}   version 5 {row[1]}")


def part_unc() -> None:
    print("## the stated uncertainty u against the true error |truth - analytic|")
    cases = []
    ref = compute_reference(zoomed_edge(24), use_cache=False)
    cases.append(("zoomed edge 24^2", ref, edge_expect(ref.position[ref.mask]), ref.mask))
    ref = compute_reference(slab(48), use_cache=False)
    cases.append(("lit slab 48^2", ref, slab_expect(ref.position[ref.mask]), ref.mask))
    ref = compute_reference(scene("laser", 64), use_cache=False)
    p = ref.position[ref.mask]
    r = np.hypot(p[:, 0], p[:, 1])
    keep = (r > 0.15) & (r < 8.0)
    expect = 400.0 * sum(W[None, i] * gt.gaussian_disc_convolution(r[keep], V[i], 0.02)[:, None] for i in range(len(V)))
    sel = ref.mask.copy()
    sel[ref.mask] = keep
    cases.append(("laser 64^2, r 0.15-8 mm", ref, expect, sel))
    for name, ref, expect, sel in cases:
        u, err = ref.uncertainty[sel], np.abs(ref.diffuse[sel] - expect)
        print(f"  {name:26s} err > u at {' / '.join(f'{100 * x:.2f}' for x in (err > u).mean(0))} % of pixels; "
              f"worst err/u {' / '.join(f'{x:.2f}' for x in (err / u).max(0))}; RMS err "
              f"{' / '.join(f'{x:.2e}' for x in np.sqrt((err ** 2).mean(0)))} vs RMS u "
              f"{' / '.join(f'{x:.2e}' for x in np.sqrt((u ** 2).mean(0)))}")


def part_head(size: int) -> None:
    print(f"## default head {size}^2: CPU seconds in one process")
    s = with_values(Settings(), {"render.width": size, "render.height": size})
    out = {}
    for split, unc in ((False, False), (True, False), (True, True)):
        c0 = time.process_time()
        r = compute_reference(s, use_cache=False, split_edges=split, uncertainty=unc)
        out[(split, unc)] = (time.process_time() - c0, r)
        print(f"  cut {split!s:5s} uncertainty {unc!s:5s}: {out[(split, unc)][0]:6.1f} s CPU, "
              f"{r.meta['elements']} elements", flush=True)
    base = out[(False, False)][0]
    print("  ratios: cut " + f"{out[(True, False)][0] / base:.2f}, cut + uncertainty {out[(True, True)][0] / base:.2f}")
    a, b = out[(False, False)][1], out[(True, True)][1]
    m = b.mask
    den = np.maximum(b.lit[m], 0.01 * b.lit[m].mean(0))
    rel = np.abs(a.lit[m] - b.lit[m]) / den
    print("  the truth moved by p99 " + " / ".join(f"{100 * x:.1f}" for x in np.percentile(rel, 99, 0)) +
          " %, p99.9 " + " / ".join(f"{100 * x:.1f}" for x in np.percentile(rel, 99.9, 0)) + " %")
    u = b.uncertainty[m]
    print("  uncertainty: median " + " / ".join(f"{100 * x:.2f}" for x in np.median(u / den, 0)) + " %, p99 "
          + " / ".join(f"{100 * x:.1f}" for x in np.percentile(u / den, 99, 0)) + " %, as an RMS figure "
          + " / ".join(f"{100 * x:.2f}" for x in np.sqrt((u ** 2).sum(0) / (b.lit[m] ** 2).sum(0))) + " %")


def part_rim(n: int = 1024, mode: str = "reflect") -> None:
    from skinviewer.engine.renderer import Renderer
    from skinviewer.kernel.gl import headless_context
    from skinviewer.passes.deon import DIFFUSE
    from skinviewer.physics.diffusion import IRRADIANCE
    from skinviewer.scene.scenes import build_scene
    s = scene("laser", 64, **{"technique": "deon", "deon.irradiance_size": n, "deon.tsm": False,
                               "deon.open_border": mode,
                               "deon.subpixel_kernel_px": 0.0,
                               "lights": [{"kind": "directional", "direction": [0, 0, 1], "intensity": 1.0,
                                           "cast_shadow": False}]})
    ctx = headless_context()
    r = Renderer(ctx)
    r.render(s)
    g = r.graph("deon")
    E = g.read(IRRADIANCE)[..., :3].astype(np.float64)
    D = g.read(DIFFUSE)[..., :3].astype(np.float64)
    m = build_scene("laser").mesh
    X, Y, _ = A.plane_coords(m.positions, m.uvs, m.mm_per_unit, n)
    inside = (np.abs(X) < 12) & (np.abs(Y) < 12)
    xs = np.linspace(-12, 12, 4801)
    ana = np.array([W[i] * np.trapezoid(box(xs, np.sqrt(V[i])), xs) ** 2 / 24 ** 2 for i in range(len(V))]).sum(0)
    kept = D[inside].sum(0) / E[inside].sum(0)
    print(f"## d'Eon on the uniformly lit 24 mm slab, {n}^2 map, deon.open_border={mode}: power kept R / G / B "
          f"{' / '.join(f'{x:.4f}' for x in kept)}, analytic open square {' / '.join(f'{x:.4f}' for x in ana)}")
    row = int(np.argmin(np.abs(Y[:, 0])))
    for d in (0.0, 0.5, 1.0):
        j = int(np.argmin(np.abs(X[0] - (12 - d))))
        got = D[row, j] / E[inside].mean(0)
        exp = (W * box(X[0, j], np.sqrt(V))[:, None]).sum(0)
        print(f"  {d} mm in: d'Eon {' / '.join(f'{x:.3f}' for x in got)}, analytic {' / '.join(f'{x:.3f}' for x in exp)}")
    r.release()
    ctx.release()


def part_rim_cost(n: int, repeats: int = 3) -> None:
    """What deon.open_border = reflect costs against absorb: forced frames of the zoomed-out
    shadow-edge scene (open borders all round; 160^2 image, n^2 maps), interleaved, sync timing
    (glFinish + wall clock), medians of the blur passes' sum; and the border frame, once per mesh and size."""
    import statistics

    from skinviewer.engine.renderer import Renderer
    from skinviewer.kernel.gl import headless_context
    ctx = headless_context()
    r = Renderer(ctx)
    base = scene("shadow-edge", 160, **{"technique": "deon", "deon.irradiance_size": n, "render.timing": "sync"})
    variants = {m: with_values(base, {"deon.open_border": m}) for m in ("absorb", "reflect")}
    once = 0.0
    for s in variants.values():  # warm-up: compile, scene, the once-per-mesh maps
        rep = r.render(s, force=True)
        once += sum(p.ms or 0.0 for p in rep.passes if p.name == "deon_border_frame" and p.status == "ran")
    ms: dict[str, list[float]] = {m: [] for m in variants}
    for _ in range(repeats):
        for m, s in variants.items():
            rep = r.render(s, force=True)
            ms[m].append(sum(p.ms or 0.0 for p in rep.passes if p.name.startswith("deon_blur_") and p.status == "ran"))
    a, b = statistics.median(ms["absorb"]), statistics.median(ms["reflect"])
    print(f"## open border cost, shadow-edge {n}^2 maps, sync timing, {repeats} interleaved repeats: blur passes "
          f"absorb {a:.0f} ms, reflect {b:.0f} ms ({b / a:.2f}x); border frame once per mesh and size {once:.0f} ms")
    r.release()
    ctx.release()


def part_rim_truth(size: int = 128) -> None:
    """d'Eon with deon.open_border absorb and reflect against the ground truth on the scenes with open
    borders: the laser slab under a uniform light (tests/test_bench.py's plane), backlit-ear, shadow-edge."""
    from skinviewer.engine.bench import compare_mask, linear_image
    from skinviewer.engine.renderer import Renderer
    from skinviewer.kernel.gl import headless_context
    from skinviewer.physics.metrics import image_error
    ctx = headless_context()
    r = Renderer(ctx)
    print(f"## d'Eon against the ground truth, {size}^2, open border absorb / reflect")
    lit_plane = [{"kind": "directional", "direction": [0.2, 0.1, 1.0], "intensity": 1.5, "cast_shadow": True}]
    for name, sc, extra in (("lit slab", "laser", {"lights": lit_plane}), ("backlit-ear", "backlit-ear", {}),
                            ("shadow-edge", "shadow-edge", {})):
        base = with_values(Settings(), {"scene.name": sc, **scene_overrides(sc), "render.width": size,
                                        "render.height": size, **extra})
        ref = compute_reference(base)
        for mode in ("absorb", "reflect"):
            s = with_values(base, {"technique": "deon", "deon.open_border": mode})
            r.render_settled(s)
            img, cov = linear_image(r, s)
            e = image_error(img, ref.lit, compare_mask(ref.mask, cov), exposure=s.render.exposure,
                            uncertainty=ref.uncertainty)
            print(f"  {name:12s} {mode:8s} {e.summary()}", flush=True)
    r.release()
    ctx.release()


# ../shared beside the checkout, or SKINVIEWER_SHARED (as tests/conftest.py)
SHARED = Path(os.environ.get("SKINVIEWER_SHARED") or Path(__file__).resolve().parents[2] / "shared")
SCAN = SHARED / "assets" / "lee-perry-smith" / "LeePerrySmith.glb"
SCAN_VALUES = {"scene.mesh": str(SCAN), "scene.mm_per_unit": 48.0}


SAMPLE_ROWS = {"1 sample (default)": {}, "4 samples": {"deon.texel_samples": 4}}


def tail_pixels(images: dict[str, np.ndarray], lit: np.ndarray, u: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """The pixels that can decide a p99 (issue 30 item 4): those whose error interval |x - r| -/+ u
    (relative, as p99_rel) reaches into [p99 - its uncertainty, p99 + its uncertainty] of some image
    and channel; a pixel wholly above or below every such band cannot move any p99 or its bound."""
    from skinviewer.physics.metrics import figure_uncertainty, rel_error_map
    den = np.maximum(lit, np.maximum(0.01 * lit[mask].mean(0), 1e-12))
    ur = u / den
    out = np.zeros(mask.shape, bool)
    for img in images.values():
        e = rel_error_map(img, lit, mask)
        _, pu, _ = figure_uncertainty(img, lit, u, mask)
        p = np.percentile(e[mask], 99, axis=0)
        out |= (mask[..., None] & (e + ur >= p - pu) & (np.maximum(e - ur, 0.0) <= p + pu)).any(2)
    return out


def key_light_only() -> list[dict]:
    """The default rig less its environment light: what deon.texel_samples acts on, alone."""
    return [light.model_dump(mode="json") for light in Settings().lights if light.kind != "environment"]


def part_samples(size: int, rounds: int = 2, scenes: str = "head,scan", rigs: str = "default",
                 max_pixels: int = 1500, env_factors: str = "8") -> None:
    """deon.texel_samples 1 vs 4 against the ground truth (the judge that shares neither the shadow map nor
    the texel grid), head and scan, irr512 / irr1024: RMS and p99 with the truth's uncertainty, the
    truth as computed and converged further at the pixels that decide a p99 (tail_pixels, then
    reference.refine_at, ``rounds`` times: the band moves as the uncertainty shrinks), and the paired
    p99 change of 4 samples against 1 (metrics.p99_change_bounds: both judged against the same truth;
    where they straddle 0, metrics.p99_change_witness: a truth within the +- that reverses the order makes
    the tie real, none found leaves it undecided). ``env_factors``: the environment's rays at the refined
    pixels per round (x ENV_DIFFUSE_RAYS; the last one for the rounds after): a round stops early when every
    comparison is decided."""
    from skinviewer.engine.bench import compare_mask, linear_image
    from skinviewer.engine.reference import ENV_DIFFUSE_RAYS, Surface, load_scene, refine_at
    from skinviewer.engine.renderer import Renderer
    from skinviewer.kernel.gl import headless_context
    from skinviewer.physics.metrics import certainly_better, image_error, p99_change_bounds, p99_change_witness, with_u
    ctx = headless_context()
    r = Renderer(ctx)
    todo = [(n, e, rig) for n, e in (("head", {}), ("scan", SCAN_VALUES)) if n in scenes.split(",")
            for rig in rigs.split(",")]
    for name, extra, rig in todo:
        if rig == "key":  # the key light alone (environment off)
            extra = {**extra, "lights": key_light_only()}
            name = f"{name}, key light only"
        s0 = with_values(Settings(), {"render.width": size, "render.height": size, **extra})
        t = time.perf_counter()
        ref = compute_reference(s0)
        t_truth = time.perf_counter() - t
        images: dict[tuple[int, str], np.ndarray] = {}
        mask = ref.mask.copy()
        for irr in (512, 1024):
            for row, v in SAMPLE_ROWS.items():
                s = with_values(s0, {"technique": "deon", "deon.irradiance_size": irr, **v})
                r.render_settled(s)
                img, cov = linear_image(r, s)
                images[(irr, row)] = img
                mask &= compare_mask(ref.mask, cov)
        truths = {"as computed": ref}
        sel = np.zeros_like(mask)
        t = time.perf_counter()
        fine = ref
        mesh, mm = load_scene(s0)
        surf = Surface(mesh, mm, s0)  # kept between the rounds: the environment's estimates
        factors = [int(f) for f in env_factors.split(",")]
        for k_round in range(rounds):
            factor = factors[min(k_round, len(factors) - 1)]
            decided = all(h_ < 0 or l_ > 0 for irr in (512, 1024) for l_, h_ in zip(*p99_change_bounds(
                images[(irr, "4 samples")], images[(irr, "1 sample (default)")], fine.lit, fine.uncertainty, mask)))
            if decided:
                break
            grow = tail_pixels({str(k): x for k, x in images.items()}, fine.lit, fine.uncertainty, mask) & ~sel
            room = max_pixels - int(sel.sum())
            if int(grow.sum()) > room:  # the largest relative uncertainties first
                rel = (fine.uncertainty / np.maximum(fine.lit, 0.01 * fine.lit[mask].mean(0))).max(2)
                keep = np.argsort(-np.where(grow, rel, -1.0).ravel())[:max(room, 0)]
                print(f"  [{name}: {int(grow.sum())} more pixels decide a p99; the {max(room, 0)} most uncertain refined]")
                grow = np.zeros_like(grow).ravel()
                grow[keep] = True
                grow = grow.reshape(sel.shape)
            more_rays = k_round > 0 and factor > factors[min(k_round - 1, len(factors) - 1)]
            if not grow.any() and not more_rays:
                break
            sel |= grow
            t_r = time.perf_counter()
            fine = refine_at(s0, ref, sel, surface=surf, env_factor=factor)
            print(f"  [{name}: round {k_round + 1}, environment x{factor} ({factor * ENV_DIFFUSE_RAYS} rays a point), "
                  f"{int(sel.sum())} pixels, {time.perf_counter() - t_r:.0f} s]", flush=True)
            for irr in (512, 1024):  # each round's figures: how far the refinement moved them
                p = [image_error(images[(irr, row)], fine.lit, mask, uncertainty=fine.uncertainty) for row in SAMPLE_ROWS]
                lo, hi = p99_change_bounds(images[(irr, "4 samples")], images[(irr, "1 sample (default)")], fine.lit,
                                           fine.uncertainty, mask)
                print(f"  [{name}: {int(sel.sum())} pixels refined, {time.perf_counter() - t:.0f} s] irr{irr} p99 "
                      + "; ".join(f"{row} {with_u(e.p99, e.p99_u, 2)}" for row, e in zip(SAMPLE_ROWS, p))
                      + f"; paired {' / '.join(f'[{100 * l_:+.2f}, {100 * h_:+.2f}]' for l_, h_ in zip(lo, hi))}", flush=True)
        t_fine = time.perf_counter() - t
        truths["converged at the tail"] = fine
        print(f"## {name} {size}^2: d'Eon against the ground truth ({'cached' if ref.meta.get('cached') else f'{t_truth:.0f} s'}; "
              f"{int(mask.sum())} pixels compared, {int(sel.sum())} refined in {t_fine:.0f} s)", flush=True)
        for label, tr in truths.items():
            print(f"  truth {label}:")
            for irr in (512, 1024):
                errs = {}
                for row in SAMPLE_ROWS:
                    e = image_error(images[(irr, row)], tr.lit, mask, exposure=s0.render.exposure,
                                    uncertainty=tr.uncertainty)
                    errs[row] = e
                    print(f"    irr{irr} {row:<20} {e.summary()}", flush=True)
                a, b = images[(irr, "4 samples")], images[(irr, "1 sample (default)")]
                lo, hi = p99_change_bounds(a, b, tr.lit, tr.uncertainty, mask)
                plain = np.array(errs["4 samples"].p99) - np.array(errs["1 sample (default)"].p99)
                verdict = ["falls" if h_ < 0 else "rises" if l_ > 0 else "tie" for l_, h_ in zip(lo, hi)]
                # a tie of the bounds: is there a truth within the +- that reverses the plain order (a real tie)?
                w_lo, w_hi, share = p99_change_witness(a, b, tr.lit, tr.uncertainty, mask)
                verdict = [v if v != "tie" else "tie (reversed)" if wl < 0 < wh else "undecided (kept)"
                           for v, wl, wh in zip(verdict, w_lo, w_hi)]
                better = certainly_better(a, b, tr.lit, tr.uncertainty, mask)
                worse = certainly_better(b, a, tr.lit, tr.uncertainty, mask)
                rms = ["lower" if x else "higher" if y else "tie" for x, y in zip(better, worse)]
                print(f"    irr{irr} 4 vs 1 sample: p99 change {' / '.join(f'{100 * x:+.2f}' for x in plain)} points, "
                      f"paired bounds {' / '.join(f'[{100 * l_:+.2f}, {100 * h_:+.2f}]' for l_, h_ in zip(lo, hi))}: "
                      f"{' / '.join(verdict)}; RMS (pairwise) {' / '.join(rms)}", flush=True)
                print(f"      under truths within the +- (p99_change_witness, {len(share)} channels): change found "
                      f"{' / '.join(f'[{100 * l_:+.2f}, {100 * h_:+.2f}]' for l_, h_ in zip(w_lo, w_hi))} points, "
                      f"the plain sign kept by {' / '.join(f'{100 * x:.0f} %' for x in share)} of the truths", flush=True)
    r.release()
    ctx.release()


def part_samples_tail(size: int, map_dir: str | None = None) -> None:
    """Where the p99 tail is (issue 30 item 4): the worst 1 % of each channel of d'Eon (irr512 / irr1024,
    1 sample) against the truth on the head and the scan, the default rig: the share in the key light's
    cast shadow, facing away from it, darker than 10 % of the mean, near a shadow boundary or the
    silhouette, d'Eon brighter there, changed by deon.texel_samples 4, and the truth's relative
    uncertainty there; ``map_dir``: a PNG per scene (the truth, then per channel the worst 1 % in red
    where d'Eon is brighter, yellow where darker, the key light's shadow boundary in blue)."""
    from PIL import Image
    from scipy.ndimage import binary_dilation, distance_transform_edt

    from skinviewer.engine.bench import compare_mask, linear_image
    from skinviewer.engine.reference import Surface, camera_hits, load_scene
    from skinviewer.engine.renderer import Renderer
    from skinviewer.kernel.gl import headless_context
    from skinviewer.physics.metrics import display_encode, rel_error_map
    ctx = headless_context()
    r = Renderer(ctx)
    for name, extra in (("head", {}), ("scan", SCAN_VALUES)):
        s0 = with_values(Settings(), {"render.width": size, "render.height": size, **extra})
        ref = compute_reference(s0)
        mesh, mm = load_scene(s0)
        surf = Surface(mesh, mm, s0)
        mask, tri, bary, _ = camera_hits(surf, s0)
        a = surf.attributes(tri, bary)
        U, vis = surf.irradiance_parts(a, s0.deon.mix, s0.deon.energy_conservation)
        faces = np.zeros(mask.shape, bool)
        lit = np.zeros(mask.shape, bool)
        faces[mask], lit[mask] = U[0].sum(1) > 0, vis[0]
        shadow = faces & ~lit
        edge = (binary_dilation(shadow) & lit & faces) | (binary_dilation(lit & faces) & shadow)
        near_edge, near_sil = distance_transform_edt(~edge) <= 3, distance_transform_edt(mask) <= 3
        print(f"## {name} {size}^2, the default rig: the worst 1 % of d'Eon's pixels against the truth (R / G / B)")
        panels = [(display_encode(ref.lit, s0.render.exposure) * 255).astype(np.uint8)]
        for irr in (512, 1024):
            imgs, m = {}, ref.mask.copy()
            for k in (1, 4):
                s = with_values(s0, {"technique": "deon", "deon.irradiance_size": irr, "deon.texel_samples": k})
                r.render_settled(s)
                imgs[k], cov = linear_image(r, s)
                m &= compare_mask(ref.mask, cov)
            e = rel_error_map(imgs[1], ref.lit, m)
            den = np.maximum(ref.lit, np.maximum(0.01 * ref.lit[m].mean(0), 1e-12))
            moved = np.abs(imgs[4] - imgs[1]) / den > 0.01
            rows: dict[str, list[float]] = {}
            for c in range(3):
                w = m & (e[..., c] >= np.percentile(e[..., c][m], 99))
                for label, where in (("in the key light's cast shadow", shadow), ("facing away from it", ~faces),
                                     ("darker than 10 % of the mean", ref.lit[..., c] < 0.1 * ref.lit[m][:, c].mean()),
                                     ("within 3 px of its shadow boundary", near_edge),
                                     ("within 3 px of the silhouette", near_sil),
                                     ("d'Eon brighter than the truth", imgs[1][..., c] > ref.lit[..., c]),
                                     ("changed > 1 point by 4 samples", moved[..., c])):
                    rows.setdefault(label, []).append(100 * float(where[w].mean()))
                    rows.setdefault(label + " (all pixels)", []).append(100 * float(where[m].mean()))
                rows.setdefault("the truth's u, median % of the pixel", []).append(
                    100 * float(np.median((ref.uncertainty / den)[..., c][w])))
                if map_dir and irr == 1024:
                    pan = (0.5 * display_encode(ref.lit, s0.render.exposure) * 255).astype(np.uint8)
                    pan[edge & m] = (0, 80, 255)
                    pan[w & (imgs[1][..., c] > ref.lit[..., c])] = (255, 0, 0)
                    pan[w & (imgs[1][..., c] <= ref.lit[..., c])] = (255, 255, 0)
                    panels.append(pan)
            print(f"  irr{irr}, 1 sample: " + "; ".join(f"{k} {' / '.join(f'{v:.0f}' for v in vals)} %"
                                                         for k, vals in rows.items()), flush=True)
        if map_dir:
            Path(map_dir).mkdir(parents=True, exist_ok=True)
            out = Path(map_dir) / f"tail_{name}_{size}.png"
            Image.fromarray(np.concatenate(panels, 1)).save(out)
            print(f"  map: {out} (the truth; the worst 1 % of R, G, B at irr1024: red d'Eon brighter, yellow "
                  f"darker; blue the key light's shadow boundary)")
    r.release()
    ctx.release()


SAMPLE_CONFIGS = {"1 sample, PCF default": {}, "4 samples": {"deon.texel_samples": 4},
                  "1 sample, PCF 0": {"shadow.pcf": 0}, "4 samples, PCF 0": {"deon.texel_samples": 4, "shadow.pcf": 0}}


def part_samples_cost(repeats: int = 3) -> None:
    """deon.texel_samples 1 vs 4 x shadow.pcf default vs 0 at the defaults (1024^2 maps, 640^2 view): the
    irradiance pass and the whole forced frame, sync timing (glFinish + wall clock), interleaved, medians,
    as ratios to the defaults."""
    import statistics

    from skinviewer.engine.renderer import Renderer
    from skinviewer.kernel.gl import headless_context
    ctx = headless_context()
    r = Renderer(ctx)
    for name, extra in (("head", {}), ("scan", SCAN_VALUES)):
        base = with_values(Settings(), {"technique": "deon", "render.timing": "sync", **extra})
        v = {k: with_values(base, c) for k, c in SAMPLE_CONFIGS.items()}
        for s in v.values():
            r.render(s, force=True)
        irr: dict[str, list[float]] = {k: [] for k in v}
        frame: dict[str, list[float]] = {k: [] for k in v}
        for _ in range(repeats):
            for k, s in v.items():
                rep = r.render(s, force=True)
                ran = [p for p in rep.passes if p.status == "ran"]
                irr[k].append(sum(p.ms or 0.0 for p in ran if p.name.startswith("deon_irradiance")))
                frame[k].append(sum(p.ms or 0.0 for p in ran))
        a0, f0 = statistics.median(irr[next(iter(v))]), statistics.median(frame[next(iter(v))])
        print(f"## {name}, {base.render.width}x{base.render.height}, {base.deon.irradiance_size}^2 maps", flush=True)
        for k in v:
            a, f = statistics.median(irr[k]), statistics.median(frame[k])
            print(f"  {k:<24} irradiance pass {a:6.0f} ms ({a / a0:.2f}x), forced frame {f:6.0f} ms ({f / f0:.2f}x)",
                  flush=True)
    r.release()
    ctx.release()


def part_interp() -> None:
    """The environment's interpolation term against its true error on the blade (issue 30, session 11)."""
    from test_reference import _blade_under_an_environment

    import skinviewer.engine.reference as R
    s, sc = _blade_under_an_environment()
    t = time.process_time()
    ref = compute_reference(s, h_mm=1.0, scene=sc)
    t_ref = time.process_time() - t
    term = R.env_interpolation_uncertainty
    parts: dict[str, np.ndarray] = {}

    def version9(surf, a, variances, weights, mix, energy, h_mm):  # the mean of the 8 nearest checks (version 9)
        made = np.unique(np.nonzero(surf.env_done["full"])[0] // 3)
        checks = R.env_interpolation_checks(surf, mix, energy, tri=made)
        own, _ = surf.env_direct(a, energy, seed=4242)
        here = np.abs(surf.env_irradiance(a["tri"], a["bary"], energy) - own) * R._safe_pow(a["C"], mix)
        return R.env_element_uncertainty(checks, a["P"] * surf.mm, np.asarray(weights).reshape(-1, 3).sum(0), here=here)
    for name, fn in (("without the term", lambda surf, a, *_a, **_k: np.zeros((len(a["P"]), 3))),
                     ("version 9 (8 nearest checks)", version9)):
        R.env_interpolation_uncertainty = fn
        try:
            parts[name] = compute_reference(s, h_mm=1.0, scene=sc).uncertainty
        finally:
            R.env_interpolation_uncertainty = term
    parts["this (corner checks, diffusion sum)"] = ref.uncertainty
    read = R.Surface.env_irradiance

    def judged(direct_tri: np.ndarray | None) -> np.ndarray:
        """The same truth with the environment estimated at every point it is read (2x the rays, other
        seeds); ``direct_tri``: only on these triangles (interpolated, with 8x the rays, elsewhere)."""
        def at_points(self, tri, bary, energy, level="full"):
            if direct_tri is None:
                return self.env_direct(self.attributes(tri, bary), energy, rays=2 * R.ENV_DIFFUSE_RAYS, seed=len(tri) + 11)[0]
            v = read(self, tri, bary, energy, level)
            on = np.isin(tri, direct_tri)
            if on.any():
                v[on] = self.env_direct(self.attributes(tri[on], bary[on]), energy, rays=8 * R.ENV_DIFFUSE_RAYS,
                                        seed=int(on.sum()) + 5)[0]
            return v
        R.Surface.env_irradiance = at_points
        rays = R.ENV_DIFFUSE_RAYS
        R.ENV_DIFFUSE_RAYS = rays if direct_tri is None else 8 * rays
        try:
            return compute_reference(s, h_mm=1.0, scene=sc, uncertainty=False).lit
        finally:
            R.Surface.env_irradiance, R.ENV_DIFFUSE_RAYS = read, rays
    judge = judged(None)
    m = ref.mask & (ref.lit.sum(-1) > 0)
    err = np.abs(ref.lit - judge)[m]
    print(f"## the blade under the studio environment, 32^2, 1 mm elements ({int(m.sum())} pixels; truth "
          f"{t_ref:.1f} CPU s, of it the term {ref.meta['seconds']['uncertainty_env_interpolation']:.2f} s); "
          f"RMS error {' / '.join(f'{x:.2f}' for x in 100 * np.sqrt((err ** 2).mean(0) / (ref.lit[m] ** 2).mean(0)))} "
          "% of the RMS value", flush=True)
    for name, u in parts.items():
        um = u[m]
        print(f"  {name:<38} error > +- at {' / '.join(f'{x:.2f}' for x in 100 * (err > um).mean(0))} % of the pixels; "
              f"worst error / +- {' / '.join(f'{x:.2f}' for x in (err / np.maximum(um, 1e-300)).max(0))}; "
              f"RMS +- / RMS error {' / '.join(f'{x:.2f}' for x in np.sqrt((um ** 2).mean(0) / (err ** 2).mean(0)))}",
              flush=True)
    # where red's error comes from: the blade is a box of 12 triangles (the plane's 512 first); its top face
    # (normal +z) is what the camera sees of it, its far face (normal -z) 2 mm below
    surf = R.Surface(*sc, s)
    top, far = (np.nonzero((np.arange(len(surf.F)) >= 512) & (surf.Ng[:, 2] * sg > 0.99))[0] for sg in (1.0, -1.0))
    fine_far = judged(far)
    fine_blade = judged(np.arange(512, len(surf.F)))
    lit_r = np.maximum(ref.lit[..., 0], 1e-300)
    z_top = float(surf.P[surf.F[top]][..., 2].mean() * sc[1])
    assert ref.position is not None
    face = m & (np.abs(ref.position[..., 2] * sc[1] - z_top) < 1e-3)
    for name, other in (("interpolated everywhere (8x the rays)", judged(np.zeros(0, np.int64))),
                        ("estimated at every point of the far face", fine_far),
                        ("... of every blade face", fine_blade)):
        rel = np.abs(other[..., 0] - judge[..., 0]) / lit_r
        print(f"  the blade's top face ({int(face.sum())} pixels), red against the judge, {name}: mean "
              f"{100 * rel[face].mean():.2f} %, worst {100 * rel[face].max():.2f} %", flush=True)


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--parts", default="edge,unc,rim")
    ap.add_argument("--size", type=int, default=512, help="head size")
    ap.add_argument("--edge-size", type=int, default=32)
    ap.add_argument("--rim-size", default="512,1024", help="d'Eon's map sizes on the slab (512: its first step is summed)")
    ap.add_argument("--rim-modes", default="absorb,reflect", help="deon.open_border values to compare")
    ap.add_argument("--samples-scenes", default="head,scan")
    ap.add_argument("--samples-rigs", default="default,key", help="default: the default lights; key: the key light only")
    ap.add_argument("--samples-rounds", type=int, default=2, help="refinements of the truth at the p99's pixels")
    ap.add_argument("--tail-map", default=None, help="samples-tail: a folder for the PNG maps")
    ap.add_argument("--samples-env-factors", default="8", help="samples: the environment's rays at the refined pixels "
                    "per round, x 256 (e.g. 8,64: the second round 64x; the last for later rounds)")
    ap.add_argument("--samples-max-pixels", type=int, default=1500, help="at most this many refined pixels a view")
    a = ap.parse_args()
    parts = set(a.parts.split(","))
    if "edge" in parts:
        part_edge(a.edge_size)
    if "unc" in parts:
        part_unc()
    if "rim" in parts:
        for n in (int(x) for x in a.rim_size.split(",")):
            for mode in a.rim_modes.split(","):
                part_rim(n, mode)
    if "truth" in parts:
        part_rim_truth()
    if "cost" in parts:
        part_rim_cost(int(a.rim_size.split(",")[-1]))
    if "head" in parts:
        part_head(a.size)
    if "samples-cost" in parts:
        part_samples_cost()
    if "samples-tail" in parts:
        part_samples_tail(a.size, a.tail_map)
    if "interp" in parts:
        part_interp()
    if "samples" in parts:
        part_samples(a.size, a.samples_rounds, a.samples_scenes, a.samples_rigs, a.samples_max_pixels,
                     a.samples_env_factors)
    return 0


if __name__ == "__main__":
    sys.exit(main())
