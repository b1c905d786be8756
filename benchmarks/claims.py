"""Re-run the README's cheap numeric claims and report drift (issue 36). Not part of CI's time budget
(about a minute or two on llvmpipe); each claim names what the README says, what this machine measures
now and the drift. A figure's measuring code is the tests' own where a test guards it.

    python benchmarks/claims.py               # every claim
    python benchmarks/claims.py ear memory    # some of them (ids: --list)
    python benchmarks/claims.py --json out.json

Exit status 0 always (a report, not a test); a claim whose drift exceeds its stated tolerance is marked
DRIFT. Memory is counted by skinviewer.engine.memory (everything a renderer holds), as bench_frames.py
does in its "fresh" state: one technique alone in a new renderer after its first full frame and a
camera move."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))  # the tests' own measuring helpers


def _renderer():
    from skinviewer.engine.renderer import Renderer
    from skinviewer.kernel.gl import headless_context
    ctx = headless_context()
    return ctx, Renderer(ctx)


def claim_ear(ctx, r):
    """README: backlit-ear at 2/3/4 mm vs sum_i w_i exp(-d^2/2v_i) (eq. 33), red."""
    from helpers import backlit_ear_deviation
    dev = backlit_ear_deviation(r)
    return [(f"backlit-ear red at {d:g} mm, vs eq. 33", 100 * float(v[0]), "%") for d, v in dev.items()]


def claim_laser(ctx, r):
    """README: the laser error (l1 radial, red) at 256^2 and 512^2 maps (default surface gather)."""
    import analytic_judge as A
    from helpers import small_settings

    from skinviewer.passes.deon import DIFFUSE
    from skinviewer.physics.diffusion import IRRADIANCE
    from skinviewer.scene.scenes import build_scene
    m = build_scene("laser").mesh
    out = []
    for n in (256, 512):
        s = small_settings("laser", "deon", 32, **{"deon.irradiance_size": n, "deon.energy_conservation": False})
        r.render(s)
        g = r.graph("deon")
        D, E = (g.read(x)[..., :3].astype(np.float64) for x in (DIFFUSE, IRRADIANCE))
        X, Y, area = A.plane_coords(m.positions, m.uvs, m.mm_per_unit, n)
        gs = s.deon.gaussians
        err = A.laser_errors(D, E, X, Y, area, [x.variance for x in gs], [x.weights for x in gs])["l1"]
        out.append((f"laser l1 error, red, {n}^2 maps", 100 * float(np.asarray(err)[0]), "%"))
    return out


def claim_memory(ctx, r):
    """README: memory held (256^2 image, head): Phong / Gosselin / d'Eon at 512^2 maps; d'Eon at 1024^2."""
    from skinviewer.engine.memory import renderer_memory
    from skinviewer.engine.renderer import Renderer
    from skinviewer.ground.settings import Settings, with_values
    from skinviewer.scene.scenes import scene_overrides

    def held(tech, maps):
        s = with_values(Settings(), {"scene.name": "head", **scene_overrides("head"), "technique": tech,
                                     "render.width": 256, "render.height": 256, "shadow.map_size": maps,
                                     "gosselin.light_map_size": maps, "deon.irradiance_size": maps,
                                     "deon.tsm_size": maps})
        rf = Renderer(ctx)
        try:
            rf.render(s, force=True)
            rf.render(with_values(s, {"camera.yaw": s.camera.yaw + 5.0}))
            rf.render(s)
            ctx.finish()
            return sum(renderer_memory(rf).values()) / 2**20
        finally:
            rf.release()
            rf.shaders.release()
    return [("Phong, 512^2 maps", held("phong", 512), "MiB"), ("Gosselin, 512^2 maps", held("gosselin", 512), "MiB"),
            ("d'Eon, 512^2 maps", held("deon", 512), "MiB"), ("d'Eon, 1024^2 maps (the default)", held("deon", 1024), "MiB")]


def claim_lit_plane(ctx, r):
    """README: d'Eon agrees within 1 % inside a lit plane (test_bench's comparison: 48^2, 512^2 maps)."""
    from test_bench import _plane

    from skinviewer.engine.bench import compare_mask, linear_image
    from skinviewer.engine.reference import compute_reference
    from skinviewer.ground.settings import with_values
    from skinviewer.physics.metrics import rel_rms
    s = with_values(_plane(48), {"deon.irradiance_size": 512})
    ref = compute_reference(s)
    r.render(s)
    img, cov = linear_image(r, s)
    m = compare_mask(ref.mask, cov)
    inner = m & (np.abs(ref.position[..., :2]) < 6.0).all(-1)
    return [("d'Eon inside a lit plane, max channel RMS", 100 * float(rel_rms(img, ref.lit, inner).max()), "%")]


# id -> (function, README's figures (same order as the function's rows), allowed drift, where in README)
CLAIMS = {
    "ear": (claim_ear, [3.4, 3.2, 1.7], 0.5, "fidelity list: 'backlit-ear at 2/3/4 mm'"),
    "laser": (claim_laser, [0.2, 0.2], 0.1, "fidelity list: 'the laser error (l1, red)'"),
    "memory": (claim_memory, [28.5, 71.8, 150.4, 509.5], 2.0, "performance: 'Memory (everything a renderer holds ...)'"),
    "lit-plane": (claim_lit_plane, [1.0], None, "ground truth: 'd'Eon agrees within 1 % inside a lit plane' (a bound)"),
}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ids", nargs="*", help="claims to re-run (default: all)")
    ap.add_argument("--list", action="store_true")
    ap.add_argument("--json", type=Path)
    a = ap.parse_args(argv)
    if a.list:
        for k, (_, vals, tol, where) in CLAIMS.items():
            print(f"{k:<10} README {vals}  (drift allowed {tol})  {where}")
        return 0
    ids = a.ids or list(CLAIMS)
    bad = [i for i in ids if i not in CLAIMS]
    if bad:
        print(f"unknown claim(s): {', '.join(bad)}; --list shows them", file=sys.stderr)
        return 2
    from skinviewer.kernel.gl import describe
    ctx, r = _renderer()
    print(f"# README claims re-measured on {describe(ctx)}")
    print(f"{'claim':<48} {'README':>8} {'now':>9} {'drift':>8}  status")
    rows = []
    for i in ids:
        fn, said, tol, where = CLAIMS[i]
        for (name, value, unit), readme in zip(fn(ctx, r), said):
            drift = value - readme
            if tol is None:  # a bound ("within x")
                status = "ok (bound)" if abs(value) <= readme else "DRIFT (bound broken)"
            else:
                status = "ok" if abs(drift) <= tol else "DRIFT"
            rows.append({"claim": i, "figure": name, "readme": readme, "now": round(value, 3), "unit": unit,
                         "drift": round(drift, 3), "status": status})
            print(f"{name:<48} {readme:8.2f} {value:9.2f} {drift:+8.2f}  {status} ({unit})")
    r.release()
    ctx.release()
    if a.json:
        a.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
