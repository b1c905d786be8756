"""The error against the ground truth of every preview rung (techniques/preview.py), for the
governor's status line and the Accuracy window: writes the shipped table
skinviewer/techniques/preview_errors.json (``engine/calibration.attach_errors`` reads it).

    python benchmarks/bench_governor_errors.py [--size 160] [--out skinviewer/techniques/preview_errors.json]
    python benchmarks/bench_governor_errors.py --techniques deon   # one technique's rows (the others kept)

The default head, the default settings (1024² maps) but the image size; the truth is
``skinviewer reference`` of the same settings (engine/reference, its cache). A rung on a smaller view
is rendered at its size and enlarged bilinearly to the truth's (what the viewer shows stretched).
Error: the mean over channels of the relative RMS (physics/metrics.image_error). Beside it, under
the key ``uncertainty`` (same rung keys), the ruler's uncertainty of that figure: the mean over
channels of ``ImageError.rms_u``, how far the figure can move while the truth moves within its
per-pixel uncertainty (engine/reference.coarse_uncertainty, issue 30), so a status line can read
"6.1 % ± 0.4". ``truth_version``: the truth's VERSION (engine/reference) the table was measured
against; the governor marks figures of an older truth."""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from scipy.ndimage import zoom

from skinviewer import techniques
from skinviewer.engine.bench import compare_mask, linear_image
from skinviewer.engine.calibration import rung_key, rung_settings
from skinviewer.engine.reference import compute_reference
from skinviewer.engine.renderer import Renderer
from skinviewer.ground.files import atomic_write_text
from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel.gl import describe, headless_context
from skinviewer.physics.metrics import image_error
from skinviewer.techniques.preview import ladder

ROOT = Path(__file__).resolve().parents[1]


def enlarge(a: np.ndarray, shape: tuple[int, int], order: int) -> np.ndarray:
    f = (shape[0] / a.shape[0], shape[1] / a.shape[1]) + ((1,) if a.ndim == 3 else ())
    out = zoom(a, f, order=order)
    return out[: shape[0], : shape[1]]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=160)
    ap.add_argument("--out", default=str(ROOT / "skinviewer" / "techniques" / "preview_errors.json"))
    ap.add_argument("--techniques", default=",".join(techniques.names()))
    args = ap.parse_args()
    base = with_values(Settings(), {"render.width": args.size, "render.height": args.size})
    ref = compute_reference(base)
    truth_version = int(ref.meta["version"])
    print(f"truth version {truth_version} ({'cached' if ref.meta.get('cached') else 'computed'})", flush=True)
    ctx = headless_context()
    r = Renderer(ctx)
    errors: dict[str, float] = {}
    uncertainty: dict[str, float] = {}
    rows = []
    for name in args.techniques.split(","):
        s = with_values(base, {"technique": name})
        for rung in ladder(s):
            rs = rung_settings(s, rung)
            r.render_settled(rs)
            img, cov = linear_image(r, rs)
            if img.shape[:2] != ref.lit.shape[:2]:
                img = enlarge(img, ref.lit.shape[:2], 1)
                cov = enlarge(cov.astype(np.uint8), ref.lit.shape[:2], 0) > 0
            e = image_error(img, ref.lit, compare_mask(ref.mask, cov), exposure=base.render.exposure,
                            uncertainty=ref.uncertainty)
            err = float(np.mean(e.rms))
            errors[rung_key(name, rung)] = err
            if e.rms_u is not None:
                uncertainty[rung_key(name, rung)] = float(np.mean(e.rms_u))
            rows.append((name, rung.label, err))
            print(f"{name:<10} {rung.label:<50} {err:8.2%} ± {uncertainty.get(rung_key(name, rung), float('nan')):.2%}",
                  flush=True)
        r.trim()
    measured = set(args.techniques.split(","))
    try:  # the techniques not measured now keep their figures (--techniques deon: d'Eon's rows only)
        old = json.loads(Path(args.out).read_text(encoding="utf-8"))
        # rows of another size or truth are not mixed with this run's (the table states one truth version)
        if old.get("size") == [args.size, args.size] and old.get("truth_version") == truth_version:
            keep = {k for k in old.get("errors", {}) if json.loads(k)[0] not in measured}
            errors = {**{k: old["errors"][k] for k in keep}, **errors}
            uncertainty = {**{k: v for k, v in old.get("uncertainty", {}).items() if k in keep}, **uncertainty}
    except (OSError, ValueError, KeyError):
        pass  # no table yet (or unreadable): this run's rows alone
    data = {"what": "mean relative RMS against the ground truth of each preview rung (benchmarks/bench_governor_errors.py)",
            "scene": "head (default settings, 1024² maps)", "size": [args.size, args.size],
            "renderer": describe(ctx), "date": time.strftime("%Y-%m-%d"),
            "truth_version": truth_version, "errors": errors,
            "uncertainty_what": "the ground truth's own uncertainty of each error figure: mean over channels of "
                                "ImageError.rms_u (issue 30); the error is known to +- this",
            "uncertainty": uncertainty}
    atomic_write_text(args.out, json.dumps(data, indent=1, ensure_ascii=False) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
