"""Export fits: how long the Burley fit of each profile takes, and what it loses, side by side.

    python benchmarks/bench_exchange.py [--repeat N]

For each profile (d'Eon's six Gaussians, the profile lab's dipole / multipole / Burley models) the
table gives the median milliseconds of ``fit_burley`` (grid included) and of a whole
``skinviewer export`` per target (fit + conversion + writing; MaterialX includes its validation),
and the per-channel loss of r R(r) the export prints.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from skinviewer.engine import exchange as X  # noqa: E402
from skinviewer.ground.settings import Settings  # noqa: E402
from skinviewer.physics import engines as E  # noqa: E402
from skinviewer.physics.profiles import deon_skin_profile  # noqa: E402

PROFILES = {"d'Eon 6 Gaussians": lambda: deon_skin_profile, "dipole Skin1": lambda: X.model_profile("dipole:Skin1").profile,
            "dipole Marble": lambda: X.model_profile("dipole:Marble").profile,
            "multipole 3-layer": lambda: X.model_profile("multipole").profile,
            "Burley Skin1": lambda: X.model_profile("burley:Skin1").profile}


def _ms(fn, repeat: int) -> float:
    t = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        t.append(1000 * (time.perf_counter() - t0))
    return statistics.median(t)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args()
    print(f"{'profile':<20} {'fit ms':>7}  {'loss of r R(r) R/G/B %':<24}")
    for name, make in PROFILES.items():
        prof = make()
        fit = E.fit_burley(prof)
        print(f"{name:<20} {_ms(lambda: E.fit_burley(prof), a.repeat):7.1f}  "  # noqa: B023 (called at once)
              + " / ".join(f"{100 * e:5.1f}" for e in fit.error))
    print(f"\n{'target':<10} {'export ms':>9}   (default settings: d'Eon's Gaussians)")
    with tempfile.TemporaryDirectory() as d:
        for t in E.TARGETS:
            out = Path(d) / f"x{X.SUFFIX[t]}"
            print(f"{t:<10} {_ms(lambda: X.export(Settings(), t, out), a.repeat):9.1f}")  # noqa: B023 (called at once)
    return 0


if __name__ == "__main__":
    sys.exit(main())
