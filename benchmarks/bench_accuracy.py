"""What accuracy costs in time: d'Eon and Gosselin settings measured side by side in one run, each
configuration's per-pass time next to its error against the analytic answer.

    python benchmarks/bench_accuracy.py [--quick] [--repeats N] [--timing sync|gpu]

1. d'Eon on the laser (24 mm slab, 0.02 mm beam): irradiance size, first Gaussian blurred or reusing
   the irradiance, the 7-tap sub-steps as implemented (and, patched in this process only, one 7-tap
   blur per Gaussian), stretch on/off (laser and stretch-plane), 2..6 Gaussians fitted to the default
   profile. Error: always against the *default six-Gaussian* profile, so fewer Gaussians show their
   true error (tests/analytic_judge.py: l1 = tests/test_deon.py's r-weighted radial metric, eq31 =
   seed 001 eq. 3.1 over the plane).
2. Gosselin on shadow-edge: iterations x kernel scale -> blur time, penumbra width (mm), and the
   blurred edge against an erf edge of the same variance (max abs error, edge normalised to 0..1).
3. Laser, technique against technique: Phong, Gosselin (default preset, and with its kernel scaled to
   the d'Eon profile's variance per channel), d'Eon default.

Timing: every configuration is rendered once (warm-up; its textures are what is measured), then the
configurations of a table get ``--repeats`` forced frames (every pass re-runs) in interleaved rounds,
so other load on the machine hits them alike; figures are per-pass minima (``--stat median``) from
the FrameReport. "tex ms" sums the view-independent passes (texture space, including one-off
ones: gutter, stretch, LUTs, radius map), "relight ms" the subset that re-runs when a light changes
(shadow maps, irradiance / light map, blurs), "final ms" the view-dependent final pass. The timing
mode that produced the figures is printed at the end. Never asserted anywhere: machine-dependent.

``--quick`` (CI size, ~30 s): maps 256/512, 2 repeats. Default (~3 min on a 2-core llvmpipe
machine): irradiance 256..2048, main size 1024, Gosselin edge map 512, 3 repeats.
"""
from __future__ import annotations

import argparse
import contextlib
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # analytic_judge

import analytic_judge as A  # noqa: E402

from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import (  # noqa: E402
    DeonSettings,
    GosselinSettings,
    Settings,
    with_values,
)
from skinviewer.kernel.gl import describe, headless_context  # noqa: E402
from skinviewer.kernel.graph import TIMING_NOTES  # noqa: E402
from skinviewer.physics.diffusion import (  # noqa: E402
    IRRADIANCE,
    blur_plan_texels,
    texture_of,
    uniform_uv_per_mm,
)
from skinviewer.physics.fitting import fit_gaussians  # noqa: E402
from skinviewer.physics.profiles import deon_skin_profile  # noqa: E402
from skinviewer.scene.scenes import build_scene, scene_overrides  # noqa: E402

DEFAULT = DeonSettings().gaussians
DEF_V = np.array([g.variance for g in DEFAULT])
DEF_W = np.array([g.weights for g in DEFAULT])
RELIGHT = ("shadow_map", "deon_tsm", "deon_irradiance", "deon_blur", "gosselin_light_map", "gosselin_blur")
FINAL = {"deon": "deon_final", "gosselin": "gosselin_final", "phong": "phong"}
LIGHT_MAP, BLURRED = "gosselin_light_map", "gosselin_blurred"  # skinviewer/passes/gosselin.py resources


def pct(x) -> str:
    return "   n/a" if x is None or not np.isfinite(x) else f"{100 * x:6.1f}"


def rgb(x) -> str:
    return " ".join(pct(v) for v in x)


class Bench:
    def __init__(self, ctx, repeats: int, timing: str, image: int, stat: str = "min"):
        self.ctx = ctx
        self.stat = statistics.median if stat == "median" else min
        self.r = Renderer(ctx)
        self.repeats = repeats
        self.timing = timing
        self.image = image
        self.modes: set[str] = set()
        self._meshes: dict[str, object] = {}
        self._pending: list[dict] = []

    def settings(self, scene: str, tech: str, values: dict) -> Settings:
        base = {"scene.name": scene, **scene_overrides(scene), "technique": tech, "render.timing": self.timing,
                "render.width": self.image, "render.height": self.image, "shadow.map_size": 1024,
                "deon.tsm_size": 256, "deon.subpixel_kernel_px": 0.0}  # texture-space maps are measured
        return with_values(Settings(), {**base, **values})

    def mesh(self, scene: str):
        if scene not in self._meshes:
            self._meshes[scene] = build_scene(scene).mesh
        return self._meshes[scene]

    def run(self, s: Settings, wrap=contextlib.nullcontext) -> dict:
        """Render ``s`` once (forced: the warm-up, whose textures the caller reads back now) and queue
        it for timing; :meth:`flush` fills in the returned dict's times."""
        with wrap():
            self.r.render(s, force=True)
        h = {"s": s, "wrap": wrap, "per": {}}
        self._pending.append(h)
        return h

    def flush(self) -> None:
        """``repeats`` rounds over the queued configurations, interleaved so that other load on the
        machine hits all of them alike; ms per pass (min or median) and the grouped sums."""
        for _ in range(self.repeats):
            for h in self._pending:
                with h["wrap"]():
                    rep = self.r.render(h["s"], force=True)
                self.modes.add(rep.timing_mode)
                for p in rep.passes:
                    if p.status == "ran":
                        h["per"].setdefault(p.name, []).append(np.nan if p.ms is None else p.ms)
        self.ctx.finish()
        for h in self._pending:
            s = h["s"]
            med = {k: self.stat(v) for k, v in h.pop("per").items()}
            vdep = {p.name for p in self.r.graph(s.technique).passes if p.view_dependent}
            h.update(passes=med, tex=sum(v for k, v in med.items() if k not in vdep and k != "output"),
                     relight=sum(v for k, v in med.items() if k.startswith(RELIGHT)),
                     final=med.get(FINAL[s.technique], np.nan), frame=sum(med.values()))
        self._pending.clear()

    def read(self, s: Settings, res: str) -> np.ndarray:
        return self.r.graph(s.technique).read(res)

    def coords(self, scene: str, n: int, mask=None):
        m = self.mesh(scene)
        return A.plane_coords(m.positions, m.uvs, m.mm_per_unit, n, mask)

    def texel(self, scene: str, n: int, mask=None) -> tuple[float, float]:
        m = self.mesh(scene)
        return A.texel_mm(m.positions, m.uvs, m.mm_per_unit, n, mask)

    def beam(self, scene: str, n: int) -> float:
        """The laser's 0.02 mm at every map size: the beam is integrated over each texel's footprint
        (shaders/lib/beam.glsl), so a beam narrower than a texel keeps its power."""
        return 0.02

    def uniform_texel(self, scene: str, n: int) -> float:
        m = self.mesh(scene)
        return 1.0 / (n * uniform_uv_per_mm(m.positions, m.uvs, m.indices, m.mm_per_unit))


# ---------------------------------------------------------------------------------------------
# 1. d'Eon on the laser


def _deon_pass_module():
    import skinviewer.passes.deon as D
    return D if hasattr(D, "sub_steps") else None


@contextlib.contextmanager
def single_blur_per_gaussian():
    """Patch (this process only, while rendering one configuration) the d'Eon blur pass to one 7-tap
    H+V blur per Gaussian, i.e. eq. 25's spacing whatever the input's smoothness: what the sub-steps buy."""
    D = _deon_pass_module()
    orig = D.sub_steps
    D.sub_steps = lambda sigma_in, inc, texel, max_steps=8: [math.sqrt(max(inc, 0.0))]
    try:
        yield
    finally:
        D.sub_steps = orig


def deon_case(b: Bench, scene: str, n: int, gaussians=None, reuse=None, stretch=True, rmax=10.0,
              single=False) -> dict:
    gs = gaussians if gaussians is not None else [(g.variance, g.weights) for g in DEFAULT]
    vals = {"deon.irradiance_size": n, "lights.0.beam_radius": b.beam(scene, n), "deon.stretch": stretch,
            "deon.gaussians": [{"variance": float(v), "weights": [float(x) for x in w]} for v, w in gs]}
    if reuse is not None:
        vals["deon.reuse_irradiance_below_texels"] = reuse
    s = b.settings(scene, "deon", vals)
    h = b.run(s, single_blur_per_gaussian if single else contextlib.nullcontext)
    plan = blur_plan_texels([v for v, _ in gs], s.deon.reuse_irradiance_below_texels, b.uniform_texel(scene, n))
    E = b.read(s, IRRADIANCE)[..., :3]
    D = sum(np.asarray(w, np.float64) * b.read(s, texture_of(p))[..., :3].astype(np.float64)
            for (_, w), p in zip(gs, plan))
    X, Y, area = b.coords(scene, n)
    h.update(A.laser_errors(D, E, X, Y, area, DEF_V, DEF_W, rmax=rmax))
    texel = b.uniform_texel(scene, n)
    blurs = A.deon_blur_passes([v for v, _ in gs], (s.deon.reuse_irradiance_below_texels * texel) ** 2, texel)
    h.update(blurs=sum(min(k, 1) for k in blurs) if single else sum(blurs), texel=max(b.texel(scene, n)), n=n,
             beam=b.beam(scene, n))
    return h


DEON_HDR = (f"{'case':<32} {'texel':>6} {'7tap':>4} {'tex ms':>8} {'relight':>8} {'final':>6}  "
            f"{'l1 %  R      G      B':>21}  {'eq3.1 %  R     G      B':>22}")


def deon_row(label: str, c: dict) -> str:
    return (f"{label:<32} {c['texel']:6.3f} {c['blurs']:4d} {c['tex']:8.1f} {c['relight']:8.1f} {c['final']:6.1f}  "
            f"{rgb(c['l1'])}  {rgb(c['eq31'])}")


def _print_rows(b: Bench, rows) -> None:
    """Time the queued configurations (interleaved), then print: rows are strings or (label, case)."""
    b.flush()
    for r in rows:
        print(r if isinstance(r, str) else deon_row(*r))


def part1(b: Bench, sizes, main: int, fits_k) -> dict:
    print("## 1. d'Eon on the laser: error against the default six-Gaussian profile")
    print("texel: mm; 7tap: separable 7-tap H+V blurs the chain runs (sub-steps included); relight = "
          "irradiance + blurs (what a light change re-runs)")
    print("\n### 1a. irradiance size; first Gaussian (v = 0.0064, sigma 0.08 mm): shipped rule (reused as the "
          "irradiance only when sigma < 0.5 texel), always blurred (0), or forced reuse (8 texels)")
    rows: list = [DEON_HDR]
    out = {}
    for n in sizes:
        for reuse in (0.5, 0.0, 8.0):
            try:
                c = deon_case(b, "laser", n, reuse=reuse)
            except Exception as exc:  # e.g. a GL allocation failure at 2048 on a small machine
                rows.append(f"{n}^2 reuse {reuse}: not measured ({exc})")
                continue
            out[(n, reuse)] = c
            beam = "" if c["beam"] <= 0.02 else f" beam {c['beam']:.3f}"
            label = {0.5: "shipped", 0.0: "blur v1", 8.0: "forced reuse"}[reuse]
            rows.append((f"{n}^2 {label}{beam}", c))
    if _deon_pass_module() is not None:
        for reuse in (8.0, 0.0):
            rows.append((f"{main}^2 {'forced reuse' if reuse else 'blur v1'} 1 blur/G*",
                         deon_case(b, "laser", main, reuse=reuse, single=True)))
        rows.append("* patched in this process: one 7-tap blur per Gaussian (no sub-steps) -- what the sub-steps buy")
    _print_rows(b, rows)

    print(f"\n### 1b. stretch correction at {main}^2 (default profile, every Gaussian blurred: reuse 0)")
    rows = [DEON_HDR]
    for scene, rmax in (("laser", 10.0), ("stretch-plane", 2.5)):
        for st in (True, False):
            rows.append((f"{scene} stretch {'on' if st else 'off'} r<{rmax:g}",
                         deon_case(b, scene, main, stretch=st, rmax=rmax, reuse=0.0)))
    rows.append("stretch-plane: 6 x 24 mm mapped to a square (u 4x denser); errors within 2.5 mm of the beam "
                "(the strip is 6 mm wide: the red tail, sigma up to 2.7 mm, is cut at its sides either way)")
    _print_rows(b, rows)

    print(f"\n### 1c. number of Gaussians at {main}^2: fits (fitting.fit_gaussians, shared variances) of the "
          "default profile, every Gaussian blurred (reuse 0); first the eq. 3.1 of each fit itself (its floor)")
    print(f"{'fit of the default profile':<30} {'eq3.1 %  R     G      B':>22}")
    fits = []
    for k in fits_k:
        t0 = time.perf_counter()
        f = fit_gaussians(deon_skin_profile, k)
        fits.append((k, f))
        print(f"{k} Gaussians{'':<20}{rgb(f.errors)}   variances {np.array2string(f.variances, precision=4)}"
              f" ({1000 * (time.perf_counter() - t0):.0f} ms fit)")
    rows = [DEON_HDR, ("default 6 (reuse 0)", deon_case(b, "laser", main, reuse=0.0))]
    for k, f in fits:
        rows.append((f"fit k={k} (reuse 0)", deon_case(b, "laser", main, gaussians=list(zip(f.variances, f.weights)),
                                                        reuse=0.0)))
    _print_rows(b, rows)
    return out


# ---------------------------------------------------------------------------------------------
# 2. Gosselin on the shadow edge


def gosselin_radius_texels(scale_x: float, size: int) -> float:
    """eq. 12's R (texels at ``size``) for region "other" (the analysis planes have no region map)."""
    from skinviewer.passes.gosselin import region_radii
    return float(region_radii(GosselinSettings(scale_x=scale_x), size)[0])


def part2(b: Bench, size: int, scales, iters) -> None:
    scene = "shadow-edge"
    m = b.mesh(scene)
    plane = np.abs(m.positions[:, 2]) < 1e-9  # the plane, not the blade (its own UV island)
    X, _, _ = b.coords(scene, size, plane)
    du = b.texel(scene, size, plane)[0]
    x = X[0]
    win = np.nonzero(np.abs(x) <= 20.0)[0]
    row_i = size // 2
    print(f"\n## 2. Gosselin on shadow-edge: {size}^2 light map ({du:.3f} mm/texel), hard shadow (pcf 0); "
          f"row v = 0.5, x in [-20, 20] mm")
    print("R: eq. 12 tap radius; sigma_eq: std of the iterated 13-tap kernel's x-marginal (bilinear taps "
          "included); sigma_fit: least-squares erf; 'erf 10-90': 10-90 width of erf(sigma_eq) sampled on the same "
          "texels; 'vs erf': max |edge - erf(sigma_eq)|; 'vs model': max |edge - light-map row * exact 1D kernel^n| "
          "(checks the measurement); edges normalised to 0..1; blur ms: the gosselin_blur pass")
    hdr = (f"{'scale':>5} {'R mm':>6} {'iter':>4} {'blur ms':>8} {'tex ms':>7} {'10-90 mm':>8} {'erf 10-90':>9} "
           f"{'sig_eq':>7} {'sig_fit':>7} {'vs erf':>7} {'vs model':>8}")
    print(hdr)
    base = {"shadow.pcf": 0, "gosselin.light_map_size": size}
    s0 = b.settings(scene, "gosselin", {**base, "gosselin.iterations": 0})
    h0 = b.run(s0)
    row0 = b.read(s0, BLURRED)[row_i, :, 0].astype(np.float64)
    lit = float(np.median(row0[win][x[win] > 5.0]))
    n0 = row0 / lit
    x0 = A.edge_position(n0[win])  # in window samples
    idx = np.arange(win.size, dtype=np.float64)
    h0.update(scale=None, R=None, n=0, w=A.width_10_90(n0[win]) * du, werf=0.0, sig=0.0, sig_fit=None,
              vs_erf=float(np.max(np.abs(n0[win] - A.erf_edge(idx, x0, 0.0)))), vs_model=None)
    cases = [h0]
    for sc in scales:
        R = gosselin_radius_texels(sc, size)
        k1 = A.poisson_kernel_1d(R)
        for n in iters:
            if n == 0:
                continue
            s = b.settings(scene, "gosselin", {**base, "gosselin.iterations": n, "gosselin.scale_x": sc})
            h = b.run(s)
            t_win = (b.read(s, BLURRED)[row_i, :, 0].astype(np.float64) / lit)[win]
            kn = A.iterate_kernel(*k1, n)
            sig = math.sqrt(A.kernel_variance(*kn))  # texels
            h.update(scale=sc, R=R * du, n=n, w=A.width_10_90(t_win) * du,
                     werf=A.width_10_90(A.erf_edge(idx, x0, sig)) * du, sig=sig * du,
                     sig_fit=A.fit_erf_sigma(idx, t_win, x0) * du,
                     vs_erf=float(np.max(np.abs(t_win - A.erf_edge(idx, x0, sig)))),
                     vs_model=float(np.max(np.abs(t_win - A.apply_kernel_1d(n0, *kn)[win]))))
            cases.append(h)
    b.flush()

    def f(v, fmt, width):
        return f"{'-':>{width}}" if v is None else format(v, fmt).rjust(width)

    for h in cases:
        print(f"{f(h['scale'], 'g', 5)} {f(h['R'], '.3f', 6)} {h['n']:4d} {h['passes'].get('gosselin_blur', np.nan):8.1f} "
              f"{h['tex']:7.1f} {h['w']:8.3f} {h['werf']:9.3f} {h['sig']:7.3f} {f(h['sig_fit'], '.3f', 7)} "
              f"{h['vs_erf']:7.3f} {f(h['vs_model'], '.3f', 8)}")


# ---------------------------------------------------------------------------------------------
# 3. techniques on the laser


def head_texel_mm_1024() -> float | None:
    try:
        from skinviewer.scene.head import default_head
        h = default_head(detail=1)
        return 1.0 / (1024 * uniform_uv_per_mm(h.positions, h.uvs, h.indices, h.mm_per_unit))
    except Exception:
        return None


def gosselin_case(b: Bench, n: int, scale_x: float, iterations: int) -> dict:
    s = b.settings("laser", "gosselin", {"gosselin.light_map_size": n, "lights.0.beam_radius": b.beam("laser", n),
                                         "gosselin.scale_x": scale_x, "gosselin.iterations": iterations})
    h = b.run(s)
    E = b.read(s, LIGHT_MAP)[..., :3]
    D = b.read(s, BLURRED)[..., :3]
    X, Y, area = b.coords("laser", n)
    h.update(A.laser_errors(D, E, X, Y, area, DEF_V, DEF_W), E=E)
    return h


def scale_for_variance(var_mm2: float, n: int, iterations: int, du: float) -> float:
    """scale_x whose iterated Poisson kernel has per-axis variance var_mm2 (bisection; R ~ scale)."""
    lo, hi = 0.0, 1000.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        v = iterations * A.poisson_variance(gosselin_radius_texels(mid, n)) * du * du
        lo, hi = (mid, hi) if v < var_mm2 else (lo, mid)
    return 0.5 * (lo + hi)


def part3(b: Bench, n: int) -> None:
    gs = GosselinSettings()
    du = b.texel("laser", n)[0]
    X, Y, area = b.coords("laser", n)
    print(f"\n## 3. Techniques on the laser at {n}^2 maps ({du:.4f} mm/texel), {b.image}^2 image: error against "
          "the d'Eon default profile")
    print("sigma: per-axis std (mm) of the diffusion (d'Eon: per channel R/G/B; Gosselin: one kernel for all "
          "channels, sqrt(iterations * var(13-tap kernel)))")
    hdr = (f"{'technique':<36} {'sigma mm':>14} {'frame':>7} {'tex ms':>7} {'relight':>7} {'final':>6}  "
           f"{'l1 %  R      G      B':>21}  {'eq3.1 %  R     G      B':>22}")

    def gsig(scale):
        return math.sqrt(gs.iterations * A.poisson_variance(gosselin_radius_texels(scale, n))) * du

    rows = []
    # Phong: no scattering, its diffuse response is the lit texels themselves (the same eq. 8-10
    # irradiance as Gosselin's light map), measured on the same bins
    hp = b.run(b.settings("laser", "phong", {"lights.0.beam_radius": b.beam("laser", n)}))
    g_def = gosselin_case(b, n, gs.scale_x, gs.iterations)
    hp.update(A.laser_errors(g_def["E"], g_def["E"], X, Y, area, DEF_V, DEF_W))
    rows += [("phong (no scattering)", "0", hp),
             (f"gosselin default (scale {gs.scale_x:g}, {gs.iterations} it)", f"{gsig(gs.scale_x):.3f}", g_def)]
    head = head_texel_mm_1024()
    if head is not None:
        sc = gs.scale_x * head / (b.texel("laser", 1024)[0])
        rows.append((f"gosselin default, head mm (sc {sc:.1f})", f"{gsig(sc):.3f}",
                     gosselin_case(b, n, sc, gs.iterations)))
    target = A.profile_variance(DEF_V, DEF_W)
    for c, name in enumerate("RGB"):
        sc = scale_for_variance(float(target[c]), n, gs.iterations, du)
        rows.append((f"gosselin var = d'Eon {name} (sc {sc:.1f})", f"{gsig(sc):.3f}",
                     gosselin_case(b, n, sc, gs.iterations)))
    sig = "/".join(f"{math.sqrt(v):.2f}" for v in target)
    rows.append(("deon default (6 G)", sig, deon_case(b, "laser", n)))
    b.flush()
    print(hdr)
    for label, sg, c in rows:
        print(f"{label:<36} {sg:>14} {c['frame']:7.1f} {c['tex']:7.1f} {c['relight']:7.1f} {c['final']:6.1f}  "
              f"{rgb(c['l1'])}  {rgb(c['eq31'])}")
    print("Gosselin's radius is in texels (at a 1024 map), not mm: the default preset is tuned on the default "
          f"head ({f'{head:.3f}' if head else '?'} mm/texel at 1024) and is "
          f"{'%.0fx' % (head / b.texel('laser', 1024)[0]) if head else 'much'} narrower on this slab. "
          "'head mm' transplants its width in mm; 'var = d'Eon X' scales the kernel so its variance equals "
          "channel X's profile variance (the best a one-kernel grey blur can be matched to that channel: only "
          "that channel's columns are meaningful for the row). Phong's error: the lit texels themselves "
          "(no scattering), binned like the others.")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="CI size: small maps, 2 repeats (~30 s)")
    ap.add_argument("--repeats", type=int, default=None, help="timed frames per configuration (default 3, quick 2)")
    ap.add_argument("--timing", choices=("sync", "gpu"), default="sync")
    ap.add_argument("--stat", choices=("min", "median"), default="min",
                    help="per-pass statistic over the repeats (min: robust to other processes on the machine)")
    ap.add_argument("--parts", default="123", help="which parts to run, e.g. 13")
    a = ap.parse_args()
    if a.quick:
        sizes, main_n, edge_n, image, reps = (256, 512), 512, 256, 128, 2
        scales, fits_k = (2.0, 8.0, 32.0), (2, 3, 4, 6)
    else:
        sizes, main_n, edge_n, image, reps = (256, 512, 1024, 2048), 1024, 512, 256, 3
        scales, fits_k = (2.0, 8.0, 32.0), (2, 3, 4, 5, 6)
    reps = a.repeats or reps
    t_start = time.perf_counter()
    ctx = headless_context()
    b = Bench(ctx, reps, a.timing, image, a.stat)
    print(f"# skinviewer accuracy vs time -- {describe(ctx)}")
    print(f"# {'quick' if a.quick else 'default'} run: per-pass {a.stat} of {reps} forced frames after one warm-up, "
          f"image {image}^2, requested timing mode: {a.timing}")
    if "1" in a.parts:
        part1(b, sizes, main_n, fits_k)
    if "2" in a.parts:
        part2(b, edge_n, scales, (0, 1, 2, 4, 8))
    if "3" in a.parts:
        part3(b, main_n)
    modes = sorted(b.modes)
    print(f"\n# timing mode of every figure above: {', '.join(modes)} -- "
          + "; ".join(f"{m}: {TIMING_NOTES[m]}" for m in modes))
    print(f"# run time {time.perf_counter() - t_start:.0f} s")
    b.r.release()
    ctx.release()
    return 0


if __name__ == "__main__":
    sys.exit(main())
