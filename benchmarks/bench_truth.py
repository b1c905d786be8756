"""The viewer's progressive ground truth (engine.reference.TruthSession): time to the first figure, to
each refinement, to a relative-RMS figure within +-0.5 % (bootstrap standard error of the pixels done,
engine.reference.sampled_rms, of a d'Eon render of the same view), an orbit that re-uses the sources,
and the one-shot compute_reference of the same view, side by side in one run.

    python3 -m benchmarks.bench_truth [--scene head] [--size 256] [--yaw 20] [--orbit-only [--field none,1,0.5]]

--orbit-only: one session per lattice spacing (x sigma) of --field (none: every pixel gathers the whole diffusion,
as before the lattice), each the first truth of the view and then the orbit, side by side in one run.
"""
from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from skinviewer.engine import reference as R
from skinviewer.ground.settings import Settings, with_values
from skinviewer.scene.scenes import scene_overrides


def _render_lit(s: Settings) -> np.ndarray:
    from skinviewer.engine.renderer import Renderer
    from skinviewer.kernel.gl import headless_context
    r = Renderer(headless_context())
    r.render_settled(s)
    lit = r.read(s, "lit")[::-1]
    return np.asarray(lit[..., :3], np.float64), lit[..., 3] > 0.5


def run(scene: str, size: int, yaw: float, technique: str, orbit_only: bool = False) -> dict:
    s = with_values(Settings(), {"scene.name": scene, **scene_overrides(scene), "render.width": size,
                                 "render.height": size, "technique": technique})
    img, cover = _render_lit(s)
    out: dict = {"scene": scene, "size": size, "technique": technique, "stages": []}
    ses = R.TruthSession()
    t0 = time.perf_counter()
    within = None
    for p in ses.progressive(s):
        rms, se = R.sampled_rms(img, p.reference, cover)
        row = {"stage": p.stage, "s": round(time.perf_counter() - t0, 2), "pixels": round(p.fraction, 3),
               "rms_pct": [round(100 * x, 3) for x in rms], "se_pct": [round(100 * x, 3) for x in se]}
        out["stages"].append(row)
        print(row, flush=True)
        if within is None and "coarse" not in p.stage and np.all(100 * se <= 0.5):
            within = row["s"]
    out["to_within_0.5pct_s"] = within
    final = p.reference
    s2 = with_values(s, {"camera.yaw": s.camera.yaw + yaw})
    # the same orbit twice in one run: first with the diffusion's whole-surface structures (cluster
    # levels, KD-tree, edge frames, source grids) made again, as every view did before (issue 34),
    # then re-using them; the whole-surface sources (E A) are kept in both
    key = R.sources_key(s, ses.h_mm)
    kept = ses._structures[key]
    ses._structures[key] = {}
    t = time.perf_counter()
    *_, q0 = ses.progressive(s2)
    out["orbit_rebuilding_structures_s"] = round(time.perf_counter() - t, 2)
    out["orbit_rebuilt"] = ses.structures_built(s2)
    ses._structures[key] = kept
    ses.recent.clear()
    before = ses.structures_built(s2)
    t = time.perf_counter()
    *_, q = ses.progressive(s2)  # every stage, the last kept
    out["orbit_reusing_s"] = round(time.perf_counter() - t, 2)
    after = ses.structures_built(s2)
    out["orbit_reusing_built"] = {k: after.get(k, 0) - before.get(k, 0) for k in after}
    out["orbit_identical_to_rebuilding"] = bool(np.array_equal(q.reference.lit, q0.reference.lit))
    print({k: v for k, v in out.items() if k.startswith("orbit")}, flush=True)
    if orbit_only:
        return out
    t = time.perf_counter()
    fresh = R.TruthSession()
    *_, q2 = fresh.progressive(s2)
    out["orbit_fresh_s"] = round(time.perf_counter() - t, 2)
    out["orbit_identical"] = bool(np.array_equal(q.reference.lit, q2.reference.lit))
    t = time.perf_counter()
    one = R.compute_reference(s, use_cache=False)
    out["compute_reference_s"] = round(time.perf_counter() - t, 2)
    m = one.mask & final.mask
    out["session_vs_compute_reference_rel_rms_pct"] = [
        round(100 * x, 4) for x in np.sqrt(((final.lit - one.lit)[m] ** 2).sum(0) / (one.lit[m] ** 2).sum(0))]
    return out


def _orbit(s: Settings, s2: Settings, img2: np.ndarray, cover2: np.ndarray, field_h: float | None,
           img: np.ndarray | None = None, cover: np.ndarray | None = None) -> dict:
    """One session: the first truth of ``s`` (all stages: each stage's time and, given ``img``, the
    technique's figure with its standard error), then the orbit to ``s2``; the orbit's time, what it
    evaluated, and the technique's figure against the orbit's truth."""
    ses = R.TruthSession(field_ratio=field_h)
    t = time.perf_counter()
    first_stages, within = [], None
    for part in ses.progressive(s):
        row = {"stage": part.stage, "s": round(time.perf_counter() - t, 2), "pixels": round(part.fraction, 3)}
        if img is not None and cover is not None:
            rms, se = R.sampled_rms(img, part.reference, cover)
            row.update(rms_pct=[round(100 * x, 3) for x in rms], se_pct=[round(100 * x, 3) for x in se])
            if within is None and "coarse" not in part.stage and np.all(100 * se <= 0.5):
                within = row["s"]
        first_stages.append(row)
    out: dict = {"field_ratio": field_h, "first_view_s": round(time.perf_counter() - t, 2),
                 "first_view_stages": first_stages, "first_view_to_within_0.5pct_s": within}
    n0 = ses.fields_evaluated(s)
    t = time.perf_counter()
    stages = []
    for q in ses.progressive(s2):
        stages.append((q.stage, round(time.perf_counter() - t, 2)))
    out["orbit_s"] = round(time.perf_counter() - t, 2)
    out["orbit_stages_s"] = stages
    out["lattice_points_first_view"] = n0
    out["lattice_points_orbit"] = ses.fields_evaluated(s2) - n0
    out["orbit_pixels"] = int(q.reference.mask.sum())
    rms, _ = R.sampled_rms(img2, q.reference, cover2)
    out["deon_rms_pct_orbit_view"] = [round(100 * x, 3) for x in rms]
    if q.reference.uncertainty is not None:  # the lattices' stated uncertainty of that figure (RMS: rms(u))
        from skinviewer.physics.metrics import image_error
        m = q.reference.mask & cover2
        e = image_error(img2, q.reference.lit, m, uncertainty=q.reference.uncertainty)
        out["deon_rms_u_pct_orbit_view"] = [round(100 * x, 3) for x in e.rms_u]
    out["_ref"] = q.reference
    return out


def run_orbits(scene: str, size: int, yaw: float, technique: str, field_hs: list[float | None]) -> dict:
    """The orbit with each lattice spacing in ``field_hs`` (None: every pixel gathers the whole
    diffusion, as before issue 34's lattice), side by side in one run: times, lattice points
    evaluated, d'Eon's figure against each truth of the orbit's view, and each truth against the first."""
    s = with_values(Settings(), {"scene.name": scene, **scene_overrides(scene), "render.width": size,
                                 "render.height": size, "technique": technique})
    s2 = with_values(s, {"camera.yaw": s.camera.yaw + yaw})
    img2, cover2 = _render_lit(s2)
    img, cover = _render_lit(s)
    rows = []
    for h in field_hs:
        r = _orbit(s, s2, img2, cover2, h, img, cover)
        rows.append(r)
        print({k: v for k, v in r.items() if not k.startswith("_")}, flush=True)
    ref0 = rows[0]["_ref"]
    for r in rows:
        m = ref0.mask & r["_ref"].mask
        d = np.sqrt(((r["_ref"].lit - ref0.lit)[m] ** 2).sum(0) / np.maximum((ref0.lit[m] ** 2).sum(0), 1e-30))
        r["truth_vs_first_row_rel_rms_pct"] = [round(100 * x, 3) for x in d]
        del r["_ref"]
    return {"scene": scene, "size": size, "yaw": yaw, "technique": technique, "rows": rows}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", default="head")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--yaw", type=float, default=20.0)
    ap.add_argument("--technique", default="deon")
    ap.add_argument("--orbit-only", action="store_true", help="stop after the orbit (no fresh session, no "
                    "compute_reference of the first view)")
    ap.add_argument("--field", default="none,1", metavar="H,...",
                    help="with --orbit-only: the truth session's lattice spacings (over sigma) to compare, 'none' = every "
                         "pixel gathers the whole diffusion (before issue 34's lattices); default none,1")
    a = ap.parse_args(argv)
    if a.orbit_only:
        hs = [None if x.strip().lower() == "none" else float(x) for x in a.field.split(",") if x.strip()]
        print(json.dumps(run_orbits(a.scene, a.size, a.yaw, a.technique, hs), indent=1))
        return 0
    print(json.dumps(run(a.scene, a.size, a.yaw, a.technique, a.orbit_only), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
