"""d'Eon's forced full frame, pass by pass (issue 27): sync timing (a glFinish after every pass), 640² view,
the default maps, medians of N frames after a warm-up. Compare two trees by running it in each:

    xvfb-run -a -s "-screen 0 1280x800x24" python3 benchmarks/bench_full_frame.py [N]
"""
from __future__ import annotations

import os
import statistics
import sys
import time
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's package

from skinviewer.engine.renderer import Renderer  # noqa: E402
from skinviewer.ground.settings import Settings, with_values  # noqa: E402
from skinviewer.kernel.gl import headless_context  # noqa: E402


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    s = with_values(Settings(), {"technique": "deon", "render.width": 640, "render.height": 640,
                                 "render.timing": "sync"})
    r = Renderer(headless_context())
    r.render(s, force=True)  # warm-up: compile, build the scene, allocate
    per: dict[str, list[float]] = defaultdict(list)
    walls = []
    for _ in range(n):
        r.ctx.finish()
        t0 = time.perf_counter()
        rep = r.render(s, force=True)
        r.ctx.finish()
        walls.append((time.perf_counter() - t0) * 1000.0)
        for p in rep.passes:
            if p.ms is not None:
                per[p.name].append(p.ms)
    med = {k: statistics.median(v) for k, v in per.items()}
    print(f"# {Path(__file__).resolve().parents[1]}: d'Eon forced full frame, 640² view, default maps, sync, "
          f"medians of {n}; load {os.getloadavg()[0]:.1f}")
    print(f"wall {statistics.median(walls):.1f} ms, sum of passes {sum(med.values()):.1f} ms")
    for k, v in sorted(med.items(), key=lambda kv: -kv[1])[:14]:
        print(f"  {k:28s} {v:8.1f}")


if __name__ == "__main__":
    main()
