"""`skinviewer bench`: every configuration timed and compared with the ground truth, failures
recorded, the Pareto front and the budget pick. Tiny sizes (the numbers are not asserted, only
their consistency)."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from skinviewer import techniques
from skinviewer.engine.bench import (
    Result,
    best_within,
    load_results,
    pareto_front,
    results_markdown,
    run_bench,
    ties_of,
)
from skinviewer.engine.reference import compute_reference
from skinviewer.ground.settings import Settings, load_preset, with_values
from skinviewer.scene.scenes import scene_overrides
from skinviewer.techniques.base import Technique


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SKINVIEWER_CACHE", str(tmp_path / "cache"))


def _plane(size: int = 40) -> Settings:
    """The laser slab under a uniform light: texture-space diffusion is exact away from its rim."""
    return with_values(Settings(), {"scene.name": "laser", **scene_overrides("laser"), "render.width": size,
                                    "render.height": size, "shadow.map_size": 256, "deon.tsm_size": 256,
                                    "lights": [{"kind": "directional", "direction": [0.2, 0.1, 1.0],
                                                "intensity": 1.5}]})


def test_pareto_and_budget():
    rs = [Result("a", "fast", {}, full_ms=10, rms=[0.3] * 3), Result("a", "slow", {}, full_ms=100, rms=[0.05] * 3),
          Result("b", "worse", {}, full_ms=120, rms=[0.2] * 3), Result("b", "mid", {}, full_ms=50, rms=[0.1] * 3),
          Result("b", "bad", {}, error="boom")]
    pareto_front(rs)
    assert [r.label for r in rs if r.pareto] == ["fast", "slow", "mid"]
    assert best_within(rs, 60).label == "mid"
    assert best_within(rs, 5) is None


def test_differences_within_the_truths_uncertainty_are_ties():
    """Mean RMS 5.0 vs 5.2 % with the truth's uncertainty +- 0.15 %: a tie, so the faster one is
    picked within a budget and the slower one is off the Pareto front; 5.0 vs 6.0 % is ranked."""
    u = [0.0015] * 3
    fast = Result("a", "fast", {}, full_ms=10, rms=[0.052] * 3, rms_u=u)
    slow = Result("a", "slow", {}, full_ms=20, rms=[0.050] * 3, rms_u=u)
    worse = Result("b", "worse", {}, full_ms=5, rms=[0.060] * 3, rms_u=u)
    rs = [fast, slow, worse]
    pareto_front(rs)
    assert [r.label for r in rs if r.pareto] == ["fast", "worse"]
    assert best_within(rs, 30) is fast and ties_of(fast, rs) == [slow]
    exact = [Result("a", "fast", {}, full_ms=10, rms=[0.052] * 3), Result("a", "slow", {}, full_ms=20, rms=[0.050] * 3)]
    pareto_front(exact)
    assert all(r.pareto for r in exact) and best_within(exact, 30).label == "slow"  # no uncertainty: ranked
    md = results_markdown({"scene": "x", "size": [8, 8], "timing": "t", "metrics": {"dssim": "d"},
                           "reference": {"uncertainty": "note"},
                           "results": [dict(r.to_json(), dssim=0.01, dssim_u=0.001, p99=[0.1] * 3, p99_u=[0.01] * 3,
                                            camera_ms=1.0) for r in rs]})
    assert "5.2 / 5.2 / 5.2 ± 0.1 / 0.1 / 0.1" in md and "0.0100 ± 0.0010" in md and "| a slow |" in md


def test_bench_records_failures_and_writes_everything(tmp_path, monkeypatch, gl_ctx):
    bad = Technique("broken", "a configuration that cannot be built", techniques.REGISTRY["phong"].build,
                    lambda quick: [("ok", {}), ("invalid", {"shadow.map_size": 3})])
    monkeypatch.setitem(techniques.REGISTRY, "broken", bad)
    s = _plane()
    ref = compute_reference(s)
    out = tmp_path / "bench"
    # the fake technique is not a valid `technique` value: both of its configurations fail, and say why
    data = run_bench(s, out, quick=True, names=["phong", "broken"], reference=ref, ctx=gl_ctx)
    res = {(r["technique"], r["label"]): r for r in data["results"]}
    assert res[("broken", "invalid")]["error"] and res[("broken", "ok")]["error"]
    good = [r for r in data["results"] if r["error"] is None]
    assert len(good) == len(techniques.REGISTRY["phong"].sweep(True))
    for r in good:
        assert len(r["full_runs"]) >= 3 and len(r["camera_runs"]) >= 3
        assert r["camera_ms"] < r["full_ms"]  # texture-space passes stay cached when only the camera moves
        assert all(np.isfinite(r["rms"])) and 0 <= r["dssim"] <= 1
        assert (out / r["heatmap"]).is_file() and (out / r["heatmap"]).with_suffix(".exr").is_file()
    assert any(r["pareto"] for r in good)
    assert (out / "pareto.png").stat().st_size > 1000
    md = (out / "results.md").read_text()
    assert "Pareto" in md and "failed" in md
    meta, rs = load_results(out / "results.json")
    assert meta["reference"]["elements"] > 0 and len(rs) == len(data["results"])
    # every figure carries the truth's uncertainty
    for r in rs:
        if r.error is None:
            assert len(r.rms_u) == 3 and len(r.p99_u) == 3 and r.dssim_u is not None and min(r.rms_u) > 0
    assert " ± " in md and "tied with" in md
    # the pairwise ranking names only real configurations, never both ways, and is kept in results.json
    names = {r.name for r in rs}
    for r in rs:
        assert set(r.more_accurate_than) <= names and r.name not in r.more_accurate_than
        for o in rs:
            assert not (o.name in r.more_accurate_than and r.name in o.more_accurate_than)


def test_the_pairwise_test_ranks_what_the_figures_bounds_call_a_tie():
    """5.0 vs 5.2 % +- 0.15 % is a tie by the figures' bounds; when the images themselves show the
    more accurate one is so under every truth within the uncertainty (bench.rank_pairwise), it is
    ranked: the slower, more accurate configuration is back on the Pareto front and is the budget's
    pick, and results.md no longer lists the pair as tied."""
    from skinviewer.engine.bench import rank_pairwise
    rng = np.random.default_rng(1)
    ref = rng.uniform(0.2, 1.0, (16, 16, 3))
    u, m = 0.0015 * ref, np.ones((16, 16), bool)
    fast = Result("a", "fast", {}, full_ms=10, rms=[0.052] * 3, rms_u=[0.0015] * 3)
    slow = Result("a", "slow", {}, full_ms=20, rms=[0.050] * 3, rms_u=[0.0015] * 3)
    other = Result("b", "other", {}, full_ms=30, rms=[0.051] * 3, rms_u=[0.0015] * 3)
    noise = rng.choice([-1.0, 1.0], ref.shape)
    imgs = {"fast": ref * (1 + 0.052 * noise), "slow": ref * (1 + 0.050 * noise),
            "other": ref * (1 + 0.051 * rng.choice([-1.0, 1.0], ref.shape))}
    m2 = m.copy()
    m2[0, 0] = False
    n = rank_pairwise([(fast, imgs["fast"], m), (slow, imgs["slow"], m), (other, imgs["other"], m2)], ref, u)
    assert n >= 1 and slow.more_accurate_than == ["a fast"] and not fast.more_accurate_than
    assert not other.more_accurate_than  # other pixels (a different mask): not compared pairwise
    rs = [fast, slow]
    pareto_front(rs)
    assert all(r.pareto for r in rs) and best_within(rs, 30) is slow and ties_of(fast, rs) == []
    _, back = load_results_from([r.to_json() for r in rs])
    assert back[1].more_accurate_than == ["a fast"]


def load_results_from(records):
    import tempfile
    from pathlib import Path
    with tempfile.TemporaryDirectory() as d:
        f = Path(d) / "results.json"
        f.write_text(json.dumps({"results": records}))
        return load_results(f)


def test_bench_cli_budget_preset(tmp_path):
    # its own process: the command makes and releases a headless GL context, which must not take
    # the session's context down with it
    out = tmp_path / "b"
    preset = tmp_path / "best.json"
    p = subprocess.run([sys.executable, "-m", "skinviewer", "bench", "--scene", "laser", "--size", "32x32", "--quick",
                        "--techniques", "phong", "--out", str(out), "--budget-ms", "1e6", "--preset-out", str(preset)],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    assert "best within" in p.stdout
    best = load_preset(preset)
    assert best.technique == "phong" and best.scene.name == "laser"
    data = json.loads((out / "results.json").read_text())
    assert data["results"][0]["error"] is None


def test_deon_on_a_lit_plane_is_close_to_the_truth(renderer):
    """The same equations on both sides: d'Eon's texture-space diffusion on a uniformly lit plane
    (exact away from the rim) agrees with the truth; Phong (no diffusion, its own lighting model)
    does not. Compared by the bench's own code."""
    from skinviewer.engine.bench import compare_mask, linear_image
    from skinviewer.physics.metrics import rel_rms
    s = with_values(_plane(48), {"deon.irradiance_size": 512})
    ref = compute_reference(s)
    errs = {}
    for t in ("deon", "phong"):
        st = with_values(s, {"technique": t})
        renderer.render(st)
        img, cov = linear_image(renderer, st)
        m = compare_mask(ref.mask, cov)
        inner = m & (np.abs(ref.position[..., :2]) < 6.0).all(-1)  # 6 mm inside the slab's rim
        errs[t] = rel_rms(img, ref.lit, m)
        errs[t + " inside"] = rel_rms(img, ref.lit, inner)
    # away from the open rim d'Eon agrees within 0.2 %: irradiance, mix, rho_dt, specular. Measured
    # 0.04 / 0.04 / 0.04 % inside (llvmpipe, 48^2 image, 512^2 maps) and 0.32 / 0.04 / 0.04 % with the rim
    # since issue 30 item 5 (deon.open_border = reflect; 1.9 % red before, when every blur step dropped the
    # light past the rim); the bounds are ~4x and ~3x those, below the 1.4 % effect issue 36 found this
    # test guarding, far below Phong's 23-28 %
    assert errs["deon inside"].max() < 0.002, errs
    assert errs["deon"].max() < 0.01, errs
    assert errs["deon"].mean() < errs["phong"].mean(), errs
