"""Issue 32: the viewer does not wait for the environment's visibility bake. A Renderer with
env_bake_background bakes in a thread, draws the unoccluded transfer meanwhile, says so, and swaps
the bake in; the swapped-in image equals a render that waited for the bake (the CLI's way)."""
import threading

import numpy as np
from helpers import small_settings

from skinviewer.engine.renderer import Renderer
from skinviewer.ground.settings import with_values
from skinviewer.physics import environment as env


def _env_settings(technique: str = "deon"):
    s = small_settings(technique=technique, size=48)
    key = s.lights[0].model_dump()
    # 12 rays: a bake no other test caches
    return with_values(s, {"lights": [key, {"kind": "environment", "environment": "studio", "ao_rays": 12,
                                            "cast_shadow": False}]})


def test_background_bake_does_not_block_and_swaps_in_the_same_image(gl_ctx, monkeypatch, tmp_path):
    monkeypatch.setenv("SKINVIEWER_CACHE", str(tmp_path))  # nothing baked yet
    gate = threading.Event()
    real = env.bake_transfer

    def gated(*a, **kw):  # the bake cannot finish before the test lets it: a render that waited would hang
        assert gate.wait(120)
        return real(*a, **kw)

    monkeypatch.setattr(env, "bake_transfer", gated)
    s = _env_settings()
    r = Renderer(gl_ctx, env_bake_background=True)
    try:
        r.render(s)  # returns while the bake is held
        gpu = r.scene.gpu
        assert "baking environment visibility" in gpu.env_bake_status()
        standin = r.graph(s.technique).read("deon_irradiance").copy()
        gen = gpu.env_generation
        report = r.render(s)
        assert not report.ran  # nothing new until the bake is in
        gate.set()
        assert gpu.env_wait(120)
        assert gpu.env_generation == gen + 1 and gpu.env_bake_status() == ""
        report = r.render(s)
        assert "deon_final" in report.ran  # the lit passes re-ran with the bake
        swapped_irr = r.graph(s.technique).read("deon_irradiance")
        swapped = r.image(s)
    finally:
        r.release()
    assert np.abs(standin - swapped_irr).max() > 1e-3  # the stand-in was unoccluded: the bake darkens
    sync = Renderer(gl_ctx)  # the CLI's way: waits for the bake (now in the disk cache)
    try:
        sync.render(s)
        assert np.array_equal(sync.image(s), swapped)
        assert np.array_equal(sync.graph(s.technique).read("deon_irradiance"), swapped_irr)
    finally:
        sync.release()


def test_headless_render_waits_for_the_bake(gl_ctx, monkeypatch, tmp_path):
    monkeypatch.setenv("SKINVIEWER_CACHE", str(tmp_path))
    s = _env_settings("phong")
    r = Renderer(gl_ctx)
    try:
        r.render(s)
        gpu = r.scene.gpu
        assert gpu.env_bake_status() == "" and not gpu._env_jobs  # baked in the call, no thread
        assert gpu.env_bake_seconds[(0, 12)] > 0.0
    finally:
        r.release()


def test_a_failed_background_bake_is_one_line_and_keeps_the_stand_in(gl_ctx, monkeypatch, tmp_path):
    monkeypatch.setenv("SKINVIEWER_CACHE", str(tmp_path))

    def broken(*a, **kw):
        raise MemoryError("out of memory")

    monkeypatch.setattr(env, "bake_transfer", broken)
    s = _env_settings("phong")
    r = Renderer(gl_ctx, env_bake_background=True)
    try:
        r.render(s)
        gpu = r.scene.gpu
        assert gpu.env_wait(60)
        assert gpu.env_bake_status() == "environment visibility bake failed: MemoryError: out of memory"
        r.render(s)  # still renders (unoccluded)
    finally:
        r.release()
