"""Issue 34: the start's CPU work off the main thread (ui/warm.py), the scene's arrays made before its
upload (kernel/gpu_scene.prepare_gpu_arrays), and a first frame spread over several under the frame
budget (kernel/graph: a freshly allocated pass may be deferred). Structure, not timing: the times are
benchmarks/bench_startup.py's."""
from __future__ import annotations

import numpy as np
from helpers import small_settings, splash_app

from skinviewer.ground.settings import with_values


def test_the_start_worker_makes_what_the_first_frame_would_and_the_frame_reuses_it(renderer, monkeypatch):
    """warm_scene fills the scene's caches (open-border test, rays to the light, the rho_dt table); the
    first render then calls none of the mesh analyses again and gives the image of a cold render."""
    from skinviewer.physics import specular
    from skinviewer.scene import mesh as mesh_mod
    from skinviewer.ui.warm import warm_scene
    s = small_settings("backlit-ear", "deon", size=64)
    cold = renderer.render(s)
    assert cold.complete
    image_cold = renderer.read(s, "image").copy()
    from skinviewer.engine.renderer import Renderer
    fresh = Renderer(renderer.ctx)  # a new scene object: its caches empty
    fresh.ensure_scene(s)
    specular._rho_tables.cache_clear()
    assert warm_scene(fresh, s) == []
    gpu = fresh.scene.gpu
    assert "has_open_border" in vars(gpu)  # the open-border test, made (a cached property)
    assert any(isinstance(k, tuple) and k[0] == "thick" for k in gpu.caches.rules)
    assert specular._rho_tables.cache_info().currsize >= 1
    calls = []
    real_border = mesh_mod.border_half_edges
    monkeypatch.setattr(mesh_mod, "border_half_edges", lambda *a: calls.append("border") or real_border(*a))
    real_integrals = specular._rho_integrals
    monkeypatch.setattr(specular, "_rho_integrals", lambda *a, **k: calls.append("rho") or real_integrals(*a, **k))
    try:
        rep = fresh.render(s)
        assert rep.complete and calls == []  # all of it made by the worker
        assert np.array_equal(fresh.read(s, "image"), image_cold)
    finally:
        fresh.release()


def test_the_scene_arrays_made_ahead_are_the_ones_uploaded(renderer):
    """prepare_gpu_arrays (the start's worker) gives the bytes the GpuScene uploads, and the copies go
    once uploaded."""
    from skinviewer.kernel.gpu_scene import prepare_gpu_arrays, prepared_gpu_arrays
    from skinviewer.scene.scenes import build_scene
    mesh = build_scene("shadow-edge").mesh
    arrays = prepare_gpu_arrays(mesh)
    assert prepare_gpu_arrays(mesh) is arrays  # made once
    assert arrays["vertices"] == mesh.interleaved().tobytes()
    assert arrays["albedo"].dtype == np.float16
    s = small_settings("shadow-edge", "phong", size=32)
    gpu = renderer.ensure_scene(s).gpu
    assert gpu.vbo.read() == gpu.mesh.interleaved().tobytes()
    assert prepared_gpu_arrays(gpu.mesh) is None  # uploaded: the copies are gone


def test_a_first_frame_is_spread_over_several_under_a_budget(renderer):
    """The first frame of a technique (every output newly allocated) runs one pass per call under a
    spent budget, as any other frame: it used to run all of its passes at once (seconds on a first
    start, the viewer frozen meanwhile). The image is the one of an unbudgeted render."""
    s = small_settings("shadow-edge", "deon", size=48)
    calls, ran = 0, []
    for _ in range(500):
        rep = renderer.render(s, budget_ms=1e-6)
        calls += 1
        ran += rep.ran
        if rep.complete:
            break
        assert len(rep.ran) <= 1 and rep.deferred
    assert rep.complete and calls >= 4 and calls >= len(set(ran))
    spread = renderer.read(s, "image").copy()
    assert renderer.render(with_values(s, {})).ran == []  # all cached now
    renderer.render(s, force=True)  # every pass in one frame
    assert np.array_equal(spread, renderer.read(s, "image"))


def test_the_viewer_start_warms_in_a_worker_and_the_first_render_waits_for_it():
    """create_app with its start-up screen starts the worker (app.warm); the panel frames run while it
    works; the first render joins it (never both on the scene's caches at once)."""
    app = splash_app((320, 240))
    from skinviewer.ui.app import destroy_app
    try:
        assert app.warm is not None
        app.ui_frame()  # the panel, while the worker may still run
        assert app.frame.report is None
        app.frame.set_frame_budget(None)
        app.step(1)
        assert app.warm is None and app.frame.report is not None and app.frame.report.complete
        gpu = app.renderer.scene.gpu
        assert gpu.caches.rules or "has_open_border" in vars(gpu)  # the worker's caches
    finally:
        destroy_app(app)
