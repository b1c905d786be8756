"""Cost of the numpy lookup tables the GPU passes upload: the rho_dt table (seed 000 eq. 30-31),
cold and on an F0 / rho_s edit, and the Beckmann texture (seed 002 listing 14-2).

    python benchmarks/bench_luts.py
"""
from __future__ import annotations

import statistics
import time

from skinviewer.physics import specular as S


def ms(fn, n=5):
    out = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        out.append((time.perf_counter() - t0) * 1000)
    return statistics.median(out)


def main():
    def cold():
        S._rho_tables.cache_clear()
        S.rho_dt_table(0.028, 0.18)

    S.rho_dt_table(0.028, 0.18)
    edits = iter(range(10**6))
    rows = [("rho_dt 32x32, cold", ms(cold, 3)),
            ("rho_dt 32x32, F0/rho_s edit", ms(lambda: S.rho_dt_table(0.02 + 1e-6 * next(edits), 0.18), 20)),
            ("beckmann LUT 512^2", ms(lambda: S.beckmann_lut(512), 3))]
    print(f"{'table':<32} {'median ms':>10}")
    for name, t in rows:
        print(f"{name:<32} {t:10.3f}")


if __name__ == "__main__":
    main()
