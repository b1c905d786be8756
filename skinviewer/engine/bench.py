"""What accuracy costs in time: every technique of the registry over its quality knobs
(``Technique.sweep``), each configuration timed (sync timing, median of >= 3 frames, full frame and
camera-only frame) and compared with the ground truth (engine.reference) by the metrics of
physics.metrics (relative RMS, p99 relative error, DSSIM). Used by ``skinviewer bench`` and the
viewer's Accuracy window (results.json, Pareto front, configurations as settings)."""
from __future__ import annotations

import json
import math
import statistics
import time
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import moderngl
import numpy as np
from numpy.typing import ArrayLike, NDArray

from skinviewer import techniques
from skinviewer.ground.files import atomic_write_text, save_exr, save_png
from skinviewer.ground.settings import Settings, with_values
from skinviewer.physics.metrics import (
    DSSIM_SETUP,
    certainly_better,
    image_error,
    rel_error_map,
    tied,
    with_u,
)

if TYPE_CHECKING:
    from skinviewer.engine.reference import Reference
    from skinviewer.engine.renderer import Renderer

RUNS = 3
LAST_BENCH = "last_bench.txt"  # in cache_dir(): the results.json of the last bench (the viewer's chart)
HEAT_MAX = 0.5  # heat maps: relative error 0 -> black, >= 50 % -> white (magma)


@dataclass
class Result:
    technique: str
    label: str
    changes: dict[str, Any]
    full_ms: float | None = None
    camera_ms: float | None = None
    rms: list[float] | None = None
    p99: list[float] | None = None
    dssim: float | None = None
    rms_u: list[float] | None = None   # the ground truth's uncertainty of each figure (metrics.figure_uncertainty)
    p99_u: list[float] | None = None
    dssim_u: float | None = None
    pareto: bool = False
    heatmap: str | None = None
    error: str | None = None
    full_runs: list[float] = field(default_factory=list)
    camera_runs: list[float] = field(default_factory=list)
    # the configurations this one is more accurate than in every channel under every truth within the
    # ruler's uncertainty (metrics.certainly_better, the images compared pairwise): ranked, never a tie
    more_accurate_than: list[str] = field(default_factory=list)

    @property
    def rms_mean(self) -> float | None:
        return None if self.rms is None else float(np.mean(self.rms))

    @property
    def rms_mean_u(self) -> float | None:
        """The uncertainty of rms_mean (the mean of the channels' bounds)."""
        return None if self.rms_u is None else float(np.mean(self.rms_u))

    @property
    def name(self) -> str:
        return f"{self.technique} {self.label}"

    @property
    def ms(self) -> float:
        """Full-frame ms of a measured configuration (inf when it was not measured)."""
        return math.inf if self.full_ms is None else self.full_ms

    @property
    def err(self) -> float:
        """Mean relative RMS of a measured configuration (inf when it was not measured)."""
        return math.inf if self.rms is None else float(np.mean(self.rms))

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        d["rms_mean"] = self.rms_mean
        d["rms_mean_u"] = self.rms_mean_u
        return d


def config_settings(base: Settings, technique: str, changes: dict[str, Any]) -> Settings:
    """The settings of one configuration: the base with its technique and knob values."""
    return with_values(base, {"technique": technique, **changes})


def linear_image(renderer: Renderer, s: Settings) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """The technique's linear lit image (H, W, 3) and its coverage (alpha > 0.5), top row first."""
    lit = renderer.read(s, "lit")[::-1]
    return np.asarray(lit[..., :3], np.float64), lit[..., 3] > 0.5


def compare_mask(ref_mask: NDArray[np.bool_], coverage: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Pixels both cover, less a one-pixel rim (silhouette samples differ between ray and raster)."""
    from scipy.ndimage import binary_erosion
    out: NDArray[np.bool_] = binary_erosion(ref_mask & coverage, iterations=1)
    return out


def heat_rgb(err: ArrayLike, vmax: float = HEAT_MAX) -> NDArray[np.uint8]:
    """Mean relative error over channels -> uint8 RGB (magma), 0 .. vmax."""
    from matplotlib import colormaps
    e = np.clip(np.asarray(err, np.float64).mean(-1) / vmax, 0.0, 1.0)
    out: NDArray[np.uint8] = (colormaps["magma"](e)[..., :3] * 255 + 0.5).astype(np.uint8)
    return out


def same_accuracy(a: Result, b: Result) -> bool:
    """A tie, never ranked: neither is more accurate than the other under every truth within the
    ruler's uncertainty by the pairwise test (``more_accurate_than``), and their mean relative RMS are
    within the sum of their figures' uncertainties."""
    if b.name in a.more_accurate_than or a.name in b.more_accurate_than:
        return False
    return tied(a.err, a.rms_mean_u, b.err, b.rms_mean_u)


def rank_pairwise(kept: list[tuple[Result, NDArray[np.float64], NDArray[np.bool_]]], ref_lit: ArrayLike,
                  u: ArrayLike | None) -> int:
    """Fill ``more_accurate_than`` of each result from the images themselves: a is more accurate than
    b when metrics.certainly_better holds in every channel (so the mean RMS is lower under every truth
    within u). Only pairs compared over the same pixels (equal masks) are tested. Returns how many
    ordered pairs were certified."""
    if u is None:
        return 0
    n = 0
    for i, (ra, ia, ma) in enumerate(kept):
        for rb, ib, mb in kept[i + 1:]:
            if not np.array_equal(ma, mb):
                continue
            if certainly_better(ia, ib, np.asarray(ref_lit), np.asarray(u), ma).all():
                ra.more_accurate_than.append(rb.name)
                n += 1
            elif certainly_better(ib, ia, np.asarray(ref_lit), np.asarray(u), ma).all():
                rb.more_accurate_than.append(ra.name)
                n += 1
    return n


def pareto_front(results: list[Result]) -> None:
    """Mark the configurations no other one beats in both full-frame time and mean relative RMS; two
    errors within the truth's uncertainty are a tie (then the faster one beats the slower)."""
    ok = [r for r in results if r.error is None and r.full_ms is not None and r.rms is not None]

    def beats(o: Result, r: Result) -> bool:
        tie = same_accuracy(o, r)
        as_good = tie or o.err <= r.err
        better = (not tie and o.err < r.err) or o.ms < r.ms
        return o is not r and o.ms <= r.ms and as_good and better
    for r in ok:
        r.pareto = not any(beats(o, r) for o in ok)


def best_within(results: list[Result], budget_ms: float) -> Result | None:
    """The most accurate configuration within the budget; among those tied with it (within the
    truth's uncertainty), the fastest."""
    ok = [r for r in results if r.error is None and r.full_ms is not None and r.full_ms <= budget_ms
          and r.rms is not None]
    if not ok:
        return None
    best = min(ok, key=lambda r: r.err)
    return min((r for r in ok if same_accuracy(r, best)), key=lambda r: (r.ms, r.err))


def ties_of(r: Result, results: list[Result]) -> list[Result]:
    """The other configurations whose mean RMS is within the truth's uncertainty of r's."""
    return [o for o in results if o is not r and o.error is None and o.rms is not None and same_accuracy(o, r)]


def _nudge(s: Settings, k: int) -> Settings:
    """A camera a fraction of a degree away: only view-dependent passes re-run."""
    return with_values(s, {"camera.yaw": s.camera.yaw + (0.25 if k % 2 == 0 else -0.25)})


def measure(renderer: Renderer, s: Settings, runs: int = RUNS) -> tuple[list[float], list[float]]:
    """Sync-timed full frames (force: every pass re-runs) and camera-only frames."""
    full, cam = [], []
    for _ in range(runs):
        full.append(renderer.render(s, force=True, timing="sync").total_ms)
    for k in range(runs):
        cam.append(renderer.render(_nudge(s, k), timing="sync").total_ms)
    renderer.render_settled(s, timing="sync")  # back at the measured camera (refined, if progressive)
    return full, cam


def environment_sweep(base: Settings, quick: bool, names: list[str] | None = None) -> list[tuple[str, str, dict[str, Any]]]:
    """With an environment light (issue 32): d'Eon with its diffuse visibility swept: the SH transfer
    vectors' order (2 against the default 4; 0: AO x SH irradiance at the bent normal), no occlusion,
    fewer and more rays per vertex in the bake."""
    from skinviewer.passes.rules import environment_light
    hit = environment_light(base.lights)
    if hit is None or (names is not None and "deon" not in names):
        return []
    i, light = hit
    orders = [o for o in (2, 0) if o != light.transfer_order]
    rays = [64] if quick else [64, 1024]
    return ([("deon", f"env transfer order {o}" if o else "env AO x SH", {f"lights.{i}.transfer_order": o})
             for o in orders]
            + [("deon", "env no occlusion", {f"lights.{i}.occlusion": False})]
            + [("deon", f"env {n} rays", {f"lights.{i}.ao_rays": n}) for n in rays if n != light.ao_rays])


def run_bench(base: Settings, out: Path, quick: bool = False, names: list[str] | None = None,
              reference: Reference | None = None, runs: int = RUNS,
              progress: Callable[[str, int, int], None] | None = None,
              ctx: moderngl.Context | None = None) -> dict[str, Any]:
    """Sweep, measure, compare; write results.json, results.md, pareto.png and heatmaps/.
    ``ctx``: a moderngl context to render with (default: a new headless one, released after)."""
    from skinviewer.engine.renderer import Renderer
    from skinviewer.kernel.gl import headless_context

    out = Path(out)
    (out / "heatmaps").mkdir(parents=True, exist_ok=True)
    configs = [(t.name, label, ch) for t in techniques.REGISTRY.values() if names is None or t.name in names
               for label, ch in t.sweep(quick)]
    configs += environment_sweep(base, quick, names)
    if reference is None:
        raise ValueError("run_bench needs the ground truth to compare with (engine.reference.compute_reference)")
    ref = reference
    results: list[Result] = []
    kept: list[tuple[Result, NDArray[np.float64], NDArray[np.bool_]]] = []  # images for the pairwise ranking

    own_ctx = ctx is None
    ctx = ctx or headless_context()
    r = Renderer(ctx)
    try:
        for n, (tech, label, changes) in enumerate(configs):
            if progress is not None:
                progress(f"{tech} {label}", n, len(configs))
            res = Result(tech, label, changes)
            try:
                s = config_settings(base, tech, changes)
                r.render(s, timing="sync")  # warm up: programs compiled, textures allocated
                res.full_runs, res.camera_runs = measure(r, s, runs)
                res.full_ms = statistics.median(res.full_runs)
                res.camera_ms = statistics.median(res.camera_runs)
                img, cov = linear_image(r, s)
                m = compare_mask(ref.mask, cov)
                e = image_error(img, ref.lit, m, exposure=base.render.exposure,
                                uncertainty=getattr(ref, "uncertainty", None))
                res.rms, res.p99, res.dssim = list(e.rms), list(e.p99), e.dssim
                if e.rms_u is not None and e.p99_u is not None:
                    res.rms_u, res.p99_u, res.dssim_u = list(e.rms_u), list(e.p99_u), e.dssim_u
                emap = rel_error_map(img, ref.lit, m)
                stem = f"{tech}_{label}".replace(" ", "_").replace("/", "-")
                save_png(out / "heatmaps" / f"{stem}.png", heat_rgb(emap))
                save_exr(out / "heatmaps" / f"{stem}.exr", emap.astype(np.float32))
                res.heatmap = f"heatmaps/{stem}.png"
                kept.append((res, img, m))  # the exact image its figures were taken of
            except Exception as exc:  # one failing configuration is recorded; the sweep goes on
                res.error = f"{type(exc).__name__}: {exc}"
            results.append(res)
            r.trim()
    finally:
        r.release()
        if own_ctx:
            ctx.release()
    rank_pairwise(kept, ref.lit, getattr(ref, "uncertainty", None))
    del kept
    pareto_front(results)
    data = {
        "scene": base.scene.mesh or base.scene.name,
        "size": [base.render.width, base.render.height],
        "camera": base.camera.model_dump(mode="json"),
        "timing": f"sync (glFinish + wall clock per pass), median of {runs} frames",
        "metrics": {"rms": "relative RMS per channel over compared pixels", "p99": "99th percentile of the "
                    "per-pixel relative error per channel", "dssim": DSSIM_SETUP,
                    "uncertainty": "*_u: how far the figure moves within the ground truth's per-pixel uncertainty "
                                   "(metrics.figure_uncertainty); a tie when neither image is more accurate in every "
                                   "channel under every truth within it (more_accurate_than, metrics.certainly_better) "
                                   "and the mean RMS are within the sum of the two figures' uncertainties"},
        "reference": ref.meta,
        "base_settings": base.model_dump(mode="json"),
        "date": time.strftime("%Y-%m-%d %H:%M:%S"),
        "results": [x.to_json() for x in results],
    }
    atomic_write_text(out / "results.json", json.dumps(data, indent=2) + "\n")
    atomic_write_text(out / "results.md", results_markdown(data))
    pareto_plot(results, out / "pareto.png", title=f"{data['scene']} {base.render.width}x{base.render.height}")
    remember_bench(out / "results.json")
    return data


def remember_bench(results_json: Path) -> None:
    from skinviewer.ground.paths import cache_dir
    atomic_write_text(cache_dir() / LAST_BENCH, str(Path(results_json).resolve()) + "\n")


MAX_RESULTS_BYTES = 256 * 2**20


def last_bench() -> str:
    """The results.json of the last bench, or "" (a damaged or special file there: "" too; it is
    read through read_regular_file, so a FIFO never blocks the viewer's start)."""
    from skinviewer.ground.files import read_regular_file
    from skinviewer.ground.paths import cache_dir
    try:
        return read_regular_file(cache_dir() / LAST_BENCH, 64 * 2**10).decode("utf-8").strip()
    except (OSError, UnicodeDecodeError):
        return ""


def load_results(path: str | Path) -> tuple[dict[str, Any], list[Result]]:
    """A bench's results.json: ValueError (one line) for anything that is not one (not JSON, not an
    object, results that are not records), OSError when it cannot be read (regular files only)."""
    from skinviewer.ground.files import read_regular_file
    try:
        data = json.loads(read_regular_file(path, MAX_RESULTS_BYTES, what=f"bench results {path}").decode("utf-8"))
    except (UnicodeDecodeError, RecursionError) as exc:
        raise ValueError(f"{path}: not bench results ({type(exc).__name__})") from None
    if not isinstance(data, dict) or not isinstance(data.get("results", []), list) \
            or not all(isinstance(d, dict) for d in data.get("results", [])):
        raise ValueError(f"{path}: not bench results (expected an object with a list of result records)")
    keys = set(Result.__dataclass_fields__)
    return data, [Result(**{k: v for k, v in d.items() if k in keys}) for d in data.get("results", [])]


def _pct(v: Iterable[float] | None, u: Iterable[float] | None = None) -> str:
    return with_u(v, u) if v is not None else "-"


def results_markdown(data: dict[str, Any]) -> str:
    _, results = None, [Result(**{k: v for k, v in d.items() if k in Result.__dataclass_fields__})
                        for d in data["results"]]
    ref = data["reference"]
    lines = [f"# Accuracy vs time: {data['scene']}, {data['size'][0]}x{data['size'][1]}", "",
             f"Reference: brute-force diffusion over the surface, {ref.get('elements')} source elements of "
             f"{ref.get('h_mm')} mm, {ref.get('pixels')} pixels, {ref.get('seconds', {}).get('total', 0):.1f} s "
             f"(cached: {ref.get('cached')}). Timing: {data['timing']}.", "",
             "Errors against the ground truth over the pixels both images cover (less a 1-pixel rim): relative "
             "RMS and p99 relative error per channel (R / G / B, %), DSSIM (" + data["metrics"]["dssim"] + "). "
             "± u: how far the figure moves within the ground truth's own uncertainty (" +
             str(ref.get("uncertainty", "not computed")) + "); configurations whose mean RMS differ by less "
             "than that are ties (column 'tied with'), not ranked, unless one image is more accurate than the "
             "other in every channel under every truth within the uncertainty (the images compared pairwise: "
             "errors both share cancel).", "",
             "| | technique | configuration | full ms | camera-only ms | RMS % | p99 % | DSSIM | tied with |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    order = sorted(results, key=lambda r: (r.technique, r.full_ms if r.full_ms is not None else 1e30))
    for r in order:
        if r.error:
            lines.append(f"| | {r.technique} | {r.label} | failed: {r.error} | | | | | |")
            continue
        mark = "**Pareto**" if r.pareto else ""
        ds = f"{r.dssim:.4f}" + (f" ± {r.dssim_u:.4f}" if r.dssim_u is not None else "")
        ties = ", ".join(o.name for o in ties_of(r, results)) if r.rms_u is not None else ""
        lines.append(f"| {mark} | {r.technique} | {r.label} | {r.full_ms:.0f} | {r.camera_ms:.0f} | "
                     f"{_pct(r.rms, r.rms_u)} | {_pct(r.p99, r.p99_u)} | {ds} | {ties} |")
    front = sorted((r for r in results if r.pareto), key=lambda r: r.ms)
    lines += ["", "Pareto front (faster to more accurate): " + ", ".join(
        f"{r.name} ({r.ms:.0f} ms, {100 * r.err:.1f}"
        + (f" ± {100 * r.rms_mean_u:.1f}" if r.rms_mean_u is not None else "") + " %)" for r in front), ""]
    return "\n".join(lines)


# one colour and marker per technique (every technique distinct: d'Eon and ssss used to share a red)
COLORS = {"phong": "tab:gray", "gosselin": "tab:blue", "deon": "tab:red", "ssss": "tab:orange",
          "separable": "tab:green", "burley": "tab:purple", "burley2": "tab:brown", "penner": "tab:pink"}
MARKERS = {"phong": "s", "gosselin": "D", "deon": "o", "ssss": "^", "separable": "v", "burley": "P",
           "burley2": "X", "penner": "*"}
# the knob abbreviations of the sweeps' labels (techniques/*.py ``sweep``), for the chart's legend
KNOBS = (("irrN", "d'Eon irradiance map N²"), ("NG", "N Gaussians"), ("tsmN", "TSM N²"),
         ("reuseN", "reuse irradiance < N texels"), ("smN", "shadow map N²"), ("pcfN", "PCF radius N"),
         ("mapN", "Gosselin light map N²"), ("itN", "N blur iterations"), ("mm", "mm radii"),
         ("Ng-Tt", "ssss: N Gaussians, T taps"), ("Tt-rotF", "separable: T taps, rotate F"),
         ("n=N", "burley: N samples"), ("B+E @C", "burley2: base+extra @ contrast"),
         ("lutN kK", "penner: N² LUT, curvature xK"))


def _clip_top(ys: list[float]) -> float:
    """The RMS axis top: the bulk of the points (1.5 x the 90th percentile) unless that holds them all."""
    a = np.asarray(ys, dtype=float)
    if a.size == 0:
        return 1.0
    top = min(float(a.max()), 1.5 * float(np.percentile(a, 90, method="lower")))
    return max(top, 1e-6) * 1.08


def pareto_plot(results: list[Result], path: Path, title: str = "") -> None:
    """Accuracy vs time: one colour and marker per technique, the Pareto front, labels on the front and
    each technique's best point placed so they do not collide (adjustText), the RMS axis clipped at the
    bulk of the points (outliers drawn on the top edge with their value), a legend of the knob
    abbreviations."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in results if r.error is None and r.full_ms is not None and r.rms is not None]
    fig, ax = plt.subplots(figsize=(10.5, 7), dpi=110)
    fig.subplots_adjust(left=0.08, right=0.76, top=0.93, bottom=0.1)
    cycle = iter(plt.rcParams["axes.prop_cycle"].by_key()["color"])
    ys_all = [100 * r.err for r in ok]
    top = _clip_top(ys_all)
    texts = []
    front = sorted((r for r in ok if r.pareto), key=lambda r: r.ms)
    for tech in dict.fromkeys(r.technique for r in ok):
        pts = [r for r in ok if r.technique == tech]
        col = COLORS.get(tech) or next(cycle, "k")
        mk = MARKERS.get(tech, "o")
        inside = [r for r in pts if 100 * r.err <= top]
        above = [r for r in pts if 100 * r.err > top]
        ax.scatter([r.ms for r in inside], [100 * r.err for r in inside], color=col, marker=mk, s=36,
                   label=tech, zorder=3, edgecolors="white", linewidths=0.5)
        if above:  # clipped outliers: a marker on the top edge, the value beside it
            ax.scatter([r.ms for r in above], [top * 0.985] * len(above), color=col, marker=r"$\uparrow$",
                       s=80, zorder=3, clip_on=False, label=None if inside else tech)
            for r in above:
                texts.append(ax.text(r.ms, top * 0.95, f"{r.label} {100 * r.err:.0f} %", fontsize=7,
                                     color=col))
        best = min(pts, key=lambda r: r.err)
        for r in inside:
            if r.pareto or r is best:
                texts.append(ax.text(r.ms, 100 * r.err, r.label, fontsize=7.5, color=col))
    if front:
        ax.step([r.ms for r in front], [min(100 * r.err, top) for r in front], where="post", color="k",
                lw=1.2, ls="--", label="Pareto front", zorder=2)
    ax.set_xscale("log")
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    ax.xaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0)))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))  # 100 200 500 (not 3x10^2 colliding)
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_ylim(0.0, top)
    ax.set_xlabel("full frame ms (sync timing, median)")
    ax.set_ylabel("relative RMS error vs ground truth, mean of R/G/B (%)")
    ax.set_title(f"Accuracy vs time {title}".strip())
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, title="technique", title_fontsize=8,
              frameon=False)
    knobs = "\n".join(f"{k:<8} {v}" for k, v in KNOBS)
    fig.text(0.775, 0.50, "labels: the Pareto front and\neach technique's most accurate\n\n" + knobs
             + "\n\nRMS of |image - truth| / truth\nper pixel; p99 over 100 %:\nthe worst 1 % of pixels are\n"
             "off by more than the truth\n(dark pixels, shadow edges)", fontsize=6.5, family="monospace",
             va="top")
    if texts:
        try:
            from adjustText import adjust_text  # label placement without overlaps (pyproject: bench extra)
            adjust_text(texts, ax=ax, arrowprops={"arrowstyle": "-", "color": "0.5", "lw": 0.5}, expand=(1.2, 1.4))
        except ImportError:
            pass  # labels at their points
    from io import BytesIO
    buf = BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    from skinviewer.ground.files import atomic_write_bytes
    atomic_write_bytes(path, buf.getvalue())
