"""What accuracy costs in time: every technique of the registry over its quality knobs
(``Technique.sweep``), each configuration timed (sync timing, median of >= 3 frames, full frame and
camera-only frame) and compared with the ground truth (core.reference) by the metrics of
physics.metrics (relative RMS, p99 relative error, DSSIM). Used by ``skinviewer bench`` and the
viewer's Accuracy window (results.json, Pareto front, configurations as settings)."""
from __future__ import annotations

import json
import statistics
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from skinviewer import techniques
from skinviewer.core.files import atomic_write_text, save_exr, save_png
from skinviewer.core.settings import Settings, with_values
from skinviewer.physics.metrics import DSSIM_SETUP, image_error, rel_error_map

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
    pareto: bool = False
    heatmap: str | None = None
    error: str | None = None
    full_runs: list[float] = field(default_factory=list)
    camera_runs: list[float] = field(default_factory=list)

    @property
    def rms_mean(self) -> float | None:
        return None if self.rms is None else float(np.mean(self.rms))

    @property
    def name(self) -> str:
        return f"{self.technique} {self.label}"

    def to_json(self) -> dict:
        d = asdict(self)
        d["rms_mean"] = self.rms_mean
        return d


def config_settings(base: Settings, technique: str, changes: dict[str, Any]) -> Settings:
    """The settings of one configuration: the base with its technique and knob values."""
    return with_values(base, {"technique": technique, **changes})


def linear_image(renderer, s: Settings) -> tuple[np.ndarray, np.ndarray]:
    """The technique's linear lit image (H, W, 3) and its coverage (alpha > 0.5), top row first."""
    lit = renderer.read(s, "lit")[::-1]
    return np.asarray(lit[..., :3], np.float64), lit[..., 3] > 0.5


def compare_mask(ref_mask: np.ndarray, coverage: np.ndarray) -> np.ndarray:
    """Pixels both cover, less a one-pixel rim (silhouette samples differ between ray and raster)."""
    from scipy.ndimage import binary_erosion
    return binary_erosion(ref_mask & coverage, iterations=1)


def heat_rgb(err: np.ndarray, vmax: float = HEAT_MAX) -> np.ndarray:
    """Mean relative error over channels -> uint8 RGB (magma), 0 .. vmax."""
    from matplotlib import colormaps
    e = np.clip(np.asarray(err, np.float64).mean(-1) / vmax, 0.0, 1.0)
    return (colormaps["magma"](e)[..., :3] * 255 + 0.5).astype(np.uint8)


def pareto_front(results: list[Result]) -> None:
    """Mark the configurations no other one beats in both full-frame time and mean relative RMS."""
    ok = [r for r in results if r.error is None and r.full_ms is not None and r.rms is not None]
    for r in ok:
        r.pareto = not any((o.full_ms <= r.full_ms and o.rms_mean <= r.rms_mean)
                           and (o.full_ms < r.full_ms or o.rms_mean < r.rms_mean) for o in ok)


def best_within(results: list[Result], budget_ms: float) -> Result | None:
    ok = [r for r in results if r.error is None and r.full_ms is not None and r.full_ms <= budget_ms]
    return min(ok, key=lambda r: r.rms_mean) if ok else None


def _nudge(s: Settings, k: int) -> Settings:
    """A camera a fraction of a degree away: only view-dependent passes re-run."""
    return with_values(s, {"camera.yaw": s.camera.yaw + (0.25 if k % 2 == 0 else -0.25)})


def measure(renderer, s: Settings, runs: int = RUNS) -> tuple[list[float], list[float]]:
    """Sync-timed full frames (force: every pass re-runs) and camera-only frames."""
    full, cam = [], []
    for _ in range(runs):
        full.append(renderer.render(s, force=True, timing="sync").total_ms)
    for k in range(runs):
        cam.append(renderer.render(_nudge(s, k), timing="sync").total_ms)
    renderer.render_settled(s, timing="sync")  # back at the measured camera (refined, if progressive)
    return full, cam


def environment_sweep(base: Settings, quick: bool, names: list[str] | None = None) -> list[tuple[str, str, dict]]:
    """With an environment light (issue 32): d'Eon with its SH order and ambient-occlusion bake swept
    (order 0 / 1 against the default 2; no occlusion, fewer and more rays per vertex)."""
    from skinviewer.passes.rules import environment_light
    hit = environment_light(base.lights)
    if hit is None or (names is not None and "deon" not in names):
        return []
    i, light = hit
    orders = [o for o in (0, 1) if o != light.sh_order]
    rays = [16] if quick else [16, 256]
    return ([("deon", f"env sh{o}", {f"lights.{i}.sh_order": o}) for o in orders]
            + [("deon", "env no AO", {f"lights.{i}.occlusion": False})]
            + [("deon", f"env AO {n} rays", {f"lights.{i}.ao_rays": n}) for n in rays if n != light.ao_rays])


def run_bench(base: Settings, out: Path, quick: bool = False, names: list[str] | None = None,
              reference=None, runs: int = RUNS,
              progress: Callable[[str, int, int], None] | None = None, ctx=None) -> dict:
    """Sweep, measure, compare; write results.json, results.md, pareto.png and heatmaps/.
    ``ctx``: a moderngl context to render with (default: a new headless one, released after)."""
    from skinviewer.core.gl import headless_context
    from skinviewer.core.renderer import Renderer

    out = Path(out)
    (out / "heatmaps").mkdir(parents=True, exist_ok=True)
    configs = [(t.name, label, ch) for t in techniques.REGISTRY.values() if names is None or t.name in names
               for label, ch in t.sweep(quick)]
    configs += environment_sweep(base, quick, names)
    ref = reference
    results: list[Result] = []
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
                e = image_error(img, ref.lit, m, exposure=base.render.exposure)
                res.rms, res.p99, res.dssim = list(e.rms), list(e.p99), e.dssim
                emap = rel_error_map(img, ref.lit, m)
                stem = f"{tech}_{label}".replace(" ", "_").replace("/", "-")
                save_png(out / "heatmaps" / f"{stem}.png", heat_rgb(emap))
                save_exr(out / "heatmaps" / f"{stem}.exr", emap.astype(np.float32))
                res.heatmap = f"heatmaps/{stem}.png"
            except Exception as exc:  # one failing configuration is recorded; the sweep goes on
                res.error = f"{type(exc).__name__}: {exc}"
            results.append(res)
            r.trim()
    finally:
        r.release()
        if own_ctx:
            ctx.release()
    pareto_front(results)
    data = {
        "scene": base.scene.mesh or base.scene.name,
        "size": [base.render.width, base.render.height],
        "camera": base.camera.model_dump(mode="json"),
        "timing": "sync (glFinish + wall clock per pass), median of %d frames" % runs,
        "metrics": {"rms": "relative RMS per channel over compared pixels", "p99": "99th percentile of the "
                    "per-pixel relative error per channel", "dssim": DSSIM_SETUP},
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
    from skinviewer.core.paths import cache_dir
    atomic_write_text(cache_dir() / LAST_BENCH, str(Path(results_json).resolve()) + "\n")


def last_bench() -> str:
    from skinviewer.core.paths import cache_dir
    try:
        return (cache_dir() / LAST_BENCH).read_text(encoding="utf-8").strip()
    except OSError:
        return ""


def load_results(path: str | Path) -> tuple[dict, list[Result]]:
    data = json.loads(Path(path).read_text(encoding="utf-8"))
    keys = set(Result.__dataclass_fields__)
    return data, [Result(**{k: v for k, v in d.items() if k in keys}) for d in data.get("results", [])]


def _pct(v) -> str:
    return " / ".join(f"{100 * c:.1f}" for c in v) if v is not None else "-"


def results_markdown(data: dict) -> str:
    _, results = None, [Result(**{k: v for k, v in d.items() if k in Result.__dataclass_fields__})
                        for d in data["results"]]
    ref = data["reference"]
    lines = [f"# Accuracy vs time: {data['scene']}, {data['size'][0]}x{data['size'][1]}", "",
             f"Reference: brute-force diffusion over the surface, {ref.get('elements')} source elements of "
             f"{ref.get('h_mm')} mm, {ref.get('pixels')} pixels, {ref.get('seconds', {}).get('total', 0):.1f} s "
             f"(cached: {ref.get('cached')}). Timing: {data['timing']}.", "",
             "Errors against the ground truth over the pixels both images cover (less a 1-pixel rim): relative "
             "RMS and p99 relative error per channel (R / G / B, %), DSSIM (" + data["metrics"]["dssim"] + ").", "",
             "| | technique | configuration | full ms | camera-only ms | RMS % | p99 % | DSSIM |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    order = sorted(results, key=lambda r: (r.technique, r.full_ms if r.full_ms is not None else 1e30))
    for r in order:
        if r.error:
            lines.append(f"| | {r.technique} | {r.label} | failed: {r.error} | | | | |")
            continue
        mark = "**Pareto**" if r.pareto else ""
        lines.append(f"| {mark} | {r.technique} | {r.label} | {r.full_ms:.0f} | {r.camera_ms:.0f} | "
                     f"{_pct(r.rms)} | {_pct(r.p99)} | {r.dssim:.4f} |")
    front = sorted((r for r in results if r.pareto), key=lambda r: r.full_ms)
    lines += ["", "Pareto front (faster to more accurate): " + ", ".join(
        f"{r.name} ({r.full_ms:.0f} ms, {100 * r.rms_mean:.1f} %)" for r in front), ""]
    return "\n".join(lines)


COLORS = {"phong": "tab:gray", "gosselin": "tab:blue", "deon": "tab:red"}


def pareto_plot(results: list[Result], path: Path, title: str = "") -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in results if r.error is None and r.full_ms is not None]
    fig, ax = plt.subplots(figsize=(8, 5.5), dpi=110)
    cycle = iter(plt.rcParams["axes.prop_cycle"].by_key()["color"][3:])
    for tech in dict.fromkeys(r.technique for r in ok):
        pts = [r for r in ok if r.technique == tech]
        col = COLORS.get(tech) or next(cycle, "k")
        ax.scatter([r.full_ms for r in pts], [100 * r.rms_mean for r in pts], color=col, label=tech, zorder=3)
        for r in pts:
            ax.annotate(r.label, (r.full_ms, 100 * r.rms_mean), fontsize=7, xytext=(3, 3),
                        textcoords="offset points")
    front = sorted((r for r in ok if r.pareto), key=lambda r: r.full_ms)
    if front:
        ax.step([r.full_ms for r in front], [100 * r.rms_mean for r in front], where="post", color="k",
                lw=1.2, ls="--", label="Pareto front", zorder=2)
    ax.set_xscale("log")
    ax.set_xlabel("full frame ms (sync timing, median)")
    ax.set_ylabel("relative RMS error vs ground truth, mean of R/G/B (%)")
    ax.set_title(f"Accuracy vs time {title}")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    from io import BytesIO
    buf = BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    from skinviewer.core.files import atomic_write_bytes
    atomic_write_bytes(path, buf.getvalue())
