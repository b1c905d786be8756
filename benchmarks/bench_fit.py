"""Fit timing: is a shared-variance Gaussian fit fast enough to refit while a UI slider moves?

    python benchmarks/bench_fit.py [--repeat N]

Times fit_gaussians (shared RGB variances, cold: all deterministic starts; warm: one start from the
previous variances, what a slider drag does) on a prepared grid, k = 2..6, several Jensen 2001
materials; prints the median milliseconds per fit and the worst channel error (seed 001 eq. 3.1).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from skinviewer.physics import profiles as P  # noqa: E402
from skinviewer.physics.fitting import fit_gaussians, make_grid  # noqa: E402

MATERIALS = ("Skin1", "Skin2", "Marble", "Ketchup", "Spectralon", "Wholemilk")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args()
    print(f"{'material':<11} {'k':>2} {'grid ms':>8} {'cold ms':>8} {'cold min':>8} {'warm ms':>8} {'max err %':>10}")
    worst = 0.0
    for name in MATERIALS:
        model = P.MATERIALS[name].dipole()
        for k in range(2, 7):
            t = time.perf_counter()
            grid = make_grid(model)
            grid_ms = 1000 * (time.perf_counter() - t)
            cold, warm = [], []
            fit = None
            for _ in range(a.repeat):
                t = time.perf_counter()
                fit = fit_gaussians(grid, k)
                cold.append(1000 * (time.perf_counter() - t))
                t = time.perf_counter()
                fit_gaussians(grid, k, init=fit.variances * 1.02, max_starts=1)
                warm.append(1000 * (time.perf_counter() - t))
            c, w = statistics.median(cold), statistics.median(warm)
            worst = max(worst, c)
            print(f"{name:<11} {k:>2} {grid_ms:8.1f} {c:8.1f} {min(cold):8.1f} {w:8.1f} {100 * fit.errors.max():10.4f}")
    print(f"slowest cold median: {worst:.1f} ms (target: well under 300 ms)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
