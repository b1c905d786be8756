"""``skinviewer reference``: the ground-truth image of the current settings (engine.reference), and
``skinviewer bench``: every technique over its quality knobs against it (engine.bench)."""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from skinviewer.cli.args import (
    CliError,
    add_scene_args,
    check_outputs,
    image_output,
    number,
    settings_from_args,
)
from skinviewer.ground.files import save_exr, save_image, save_npy
from skinviewer.ground.settings import Settings, save_preset


def add_parsers(sub) -> None:
    p = sub.add_parser("reference", help="render the ground truth (brute-force diffusion over the surface)")
    add_scene_args(p)
    p.add_argument("--out", required=True, help="output image: .png, .jpg, .tif or .bmp (exposure, background, sRGB "
                   "like `render`), or .exr (the linear image)")
    p.add_argument("--npy", help="also the linear image as float32 .npy")
    p.add_argument("--exr", help="also the linear image as OpenEXR")
    _reference_args(p)
    p.set_defaults(func=cmd_reference)

    b = sub.add_parser("bench", help="sweep every technique over its quality knobs against the ground truth")
    add_scene_args(b)
    b.add_argument("--out", required=True, help="output folder (results.json, results.md, pareto.png, heatmaps/)")
    b.add_argument("--quick", action="store_true", help="a few configurations per technique")
    b.add_argument("--techniques", help="comma-separated subset of the registry")
    b.add_argument("--runs", type=number(3, 1000, integer=True), default=3,
                   help="timed frames per configuration (median; >= 3)")
    b.add_argument("--budget-ms", type=number(0, 1e7, above=True), help="print the most accurate configuration within this full-frame time")
    b.add_argument("--preset-out", help="with --budget-ms: write that configuration as a preset")
    _reference_args(b)
    b.set_defaults(func=cmd_bench)


def _reference_args(p) -> None:
    g = p.add_argument_group("ground truth")
    g.add_argument("--h", type=number(0, 100, above=True), default=None,
                   help="source element edge in mm (default 0.5)")
    g.add_argument("--max-seconds", type=number(0, 1e7, above=True), default=600.0,
                   help="refuse a reference whose estimated time exceeds this (default 600)")
    g.add_argument("--no-cache", action="store_true", help="recompute even when a cached reference exists")
    g.add_argument("--profile", default="gaussians", metavar="MODEL[:MATERIAL]",
                   help="diffusion profile of the truth: gaussians (the settings' deon.gaussians, default), "
                        "dipole[:Skin1], burley[:Skin1] (searchlight, diffuse mean free path) or "
                        "multipole[:MATERIAL] (default: the three-layer skin example); models are integrated "
                        "as 32 fixed-variance Gaussians fitted to r R(r) (fit error printed), weights normalised")


def _progress():
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
    return Progress(TextColumn("{task.description:<28}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"),
                    TimeElapsedColumn(), transient=False)


def reference_with_progress(s: Settings, args):
    from skinviewer.engine.reference import (
        DEFAULT_H_MM,
        ReferenceTooSlow,
        compute_reference,
    )
    h = args.h if args.h else DEFAULT_H_MM
    if not h > 0:
        raise CliError("--h must be a positive number of millimetres")
    with _progress() as prog:
        tasks: dict[str, int] = {}

        def report(stage: str, f: float) -> None:
            if stage not in tasks:
                tasks[stage] = prog.add_task(f"reference: {stage}", total=1.0)
            prog.update(tasks[stage], completed=f)

        profile = _profile(args)
        try:
            return compute_reference(s, h_mm=h, use_cache=not args.no_cache, max_seconds=args.max_seconds,
                                     progress=report, profile=profile)
        except ReferenceTooSlow as exc:
            raise CliError(f"{exc}; use a smaller --size, a larger --h or raise --max-seconds") from None


def _profile(args):
    from skinviewer.engine.reference import PROFILE_MODELS, model_profile
    spec = (args.profile or "gaussians").strip()
    model, _, material = spec.partition(":")
    if model not in PROFILE_MODELS:
        raise CliError(f"--profile: unknown model {model!r} (have: {', '.join(PROFILE_MODELS)})")
    if model == "gaussians":
        return None
    try:
        v, w, err = model_profile(model, material or None)
    except KeyError as exc:
        raise CliError(f"--profile: {exc.args[0]}") from None
    print(f"profile {spec}: {len(v)} Gaussians, fit error (eq. 3.1) R/G/B "
          + " / ".join(f"{100 * e:.3f}" for e in err) + " %")
    return v, w


def display_png(s: Settings, lit: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """As the output pass: exposure, background where nothing was hit, sRGB, 8 bits."""
    from skinviewer.physics.color import srgb_to_linear
    from skinviewer.physics.metrics import display_encode
    bg = np.asarray(srgb_to_linear(np.asarray(s.render.background, np.float64)))
    img = np.where(mask[..., None], lit * s.render.exposure, bg[None, None, :])
    return (display_encode(img) * 255 + 0.5).astype(np.uint8)


def cmd_reference(args) -> int:
    s = settings_from_args(args)
    image_output(args.out, "--out")
    image_output(args.exr, "--exr", display=False)
    if args.npy and not str(args.npy).lower().endswith(".npy"):
        raise CliError(f"--npy {args.npy}: writes NumPy .npy; name the file .npy")
    check_outputs({"--out": args.out, "--npy": args.npy, "--exr": args.exr}, {"--preset": args.preset}, s)
    ref = reference_with_progress(s, args)
    if str(args.out).lower().endswith(".exr"):  # the linear image, not display bytes under an .exr name
        save_exr(args.out, ref.lit)
    else:
        save_image(args.out, display_png(s, ref.lit, ref.mask))
    u = ref.uncertainty
    if args.npy:
        save_npy(args.npy, ref.lit)
        if u is not None:
            save_npy(uncertainty_path(args.npy), u)
    if args.exr:
        save_exr(args.exr, ref.lit, extra=None if u is None else {"uncertainty": u})
    m = ref.meta
    t = m.get("seconds", {}).get("total", 0.0)
    print(f"wrote {args.out} ({s.render.width}x{s.render.height}, ground truth, {m['pixels']} pixels, "
          f"{m['elements']} source elements of {m['h_mm']} mm, "
          + ("from the cache" if m.get("cached") else f"{t:.1f} s") + ")")
    for line in m.get("plan", []):
        print(f"  {line}")
    for note in m.get("notes", []):
        print(f"note: {note}", file=sys.stderr)
    if u is not None:
        mk = ref.mask & (ref.lit.sum(-1) > 0)
        rel = u[mk] / np.maximum(ref.lit[mk], 1e-3 * np.maximum(ref.lit[mk].mean(0), 1e-12))
        print("  uncertainty of the image, relative (median / p99 R G B %): "
              + " / ".join(f"{100 * c:.2f}" for c in np.median(rel, 0)) + ", "
              + " / ".join(f"{100 * c:.2f}" for c in np.percentile(rel, 99, 0))
              + (f"; written to {uncertainty_path(args.npy)}" if args.npy else "")
              + (f"; EXR channels uncertainty.R/G/B in {args.exr}" if args.exr else ""))
    return 0


def uncertainty_path(npy: str) -> str:
    """ref.npy -> ref.uncertainty.npy (the per-pixel uncertainty beside the image)."""
    p = Path(npy)
    return str(p.with_name(p.stem + ".uncertainty" + (p.suffix or ".npy")))


def cmd_bench(args) -> int:
    from skinviewer import techniques
    from skinviewer.engine.bench import (
        best_within,
        config_settings,
        load_results,
        run_bench,
        ties_of,
    )

    s = settings_from_args(args)
    if args.size is None:
        from skinviewer.ground.settings import with_values
        s = with_values(s, {"render.width": 256, "render.height": 256})
    if args.runs < 3:
        raise CliError("--runs must be at least 3 (the median of >= 3 frames)")
    names = None
    if args.techniques:
        names = [n.strip() for n in args.techniques.split(",") if n.strip()]
        for n in names:
            techniques.get(n)
    if args.preset_out and args.budget_ms is None:
        raise CliError("--preset-out needs --budget-ms")
    check_outputs({"--out/": args.out, "--preset-out": args.preset_out}, {"--preset": args.preset}, s)
    if Path(args.out).exists() and not Path(args.out).is_dir():
        raise CliError(f"--out {args.out} is a file; bench writes a folder")
    ref = reference_with_progress(s, args)
    out = Path(args.out)
    with _progress() as prog:
        task = prog.add_task("bench", total=1)

        def report(label: str, n: int, total: int) -> None:
            prog.update(task, description=f"bench: {label}"[:28], completed=n, total=total)

        data = run_bench(s, out, quick=args.quick, names=names, reference=ref, runs=args.runs, progress=report)
        prog.update(task, completed=len(data["results"]), description="bench: done")
    _, results = load_results(out / "results.json")
    failed = [r for r in results if r.error]
    print(f"wrote {out}/results.json, results.md, pareto.png, heatmaps/ ({len(results)} configurations"
          + (f", {len(failed)} failed" if failed else "") + ")")
    for r in sorted((r for r in results if r.pareto), key=lambda r: r.ms):
        u = f" ± {100 * r.rms_mean_u:.2f}" if r.rms_mean_u is not None else ""
        print(f"  Pareto: {r.name:<28} {r.ms:8.1f} ms  RMS {100 * r.err:5.2f}{u} %  DSSIM {r.dssim:.4f}")
    if args.budget_ms is not None:
        best = best_within(results, args.budget_ms)
        if best is None:
            print(f"no configuration fits {args.budget_ms:g} ms", file=sys.stderr)
            return 1
        u = f" ± {100 * best.rms_mean_u:.2f}" if best.rms_mean_u is not None else ""
        print(f"best within {args.budget_ms:g} ms: {best.name} ({best.full_ms:.1f} ms, RMS "
              f"{100 * best.err:.2f}{u} %, p99 {100 * (max(best.p99) if best.p99 else math.nan):.1f} %, DSSIM {best.dssim:.4f})")
        ties = [o for o in ties_of(best, results) if o.full_ms is not None and o.full_ms <= args.budget_ms]
        if ties:
            print("  tied within the ground truth's uncertainty (the fastest is chosen): "
                  + ", ".join(o.name for o in ties))
        if args.preset_out:
            save_preset(config_settings(s, best.technique, best.changes), args.preset_out)
            print(f"wrote preset {args.preset_out}")
    return 0


__all__ = ["add_parsers", "argparse"]
