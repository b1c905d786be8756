"""Issue 27, session 10: the graph's fast path for frames whose passes are mostly cached
(kernel/graph.FAST_CACHED): the last compile reused (order, live set, prune reasons), a kept key checked by
its stamp instead of being made again, a memoised scene rule's answer recalled when nothing it read
changed, the NaN/Inf scans drawn into kept targets. It must skip exactly what would have been skipped: over
camera, light, slider, coverage, scene, technique and preview changes and a cancelled banded frame, every
frame's report (status, reason, draws, NaN flags), bands in progress and image are those of the path off."""
from __future__ import annotations

import math
from collections import Counter

import moderngl
import numpy as np
import pytest

from skinviewer.engine.renderer import Renderer
from skinviewer.ground.settings import Settings, with_values
from skinviewer.kernel import graph as graph_mod
from skinviewer.kernel.pass_api import Reflection


def _small(size: int, **extra) -> Settings:
    return with_values(Settings(), {"technique": "deon", "render.width": size, "render.height": size,
                                    "shadow.map_size": 64, "deon.tsm_size": 64, "deon.irradiance_size": 256,
                                    **extra})


def _events(s: Settings) -> list[tuple[str, Settings, dict]]:
    """(what, settings, render keywords): the frames of the sequence, in order."""
    d = s.lights[0].direction
    cam = [with_values(s, {"camera.yaw": s.camera.yaw + a}) for a in (5.0, 10.0, 15.0, 20.0)]
    lit = with_values(cam[1], {"lights.0.direction": (d[0] + 0.3, d[1], d[2])})
    auto = with_values(lit, {"deon.irradiance_size_mode": "auto", "shadow.map_size_mode": "auto"})
    zoom = with_values(auto, {"camera.fov_y": 8.0})
    plane = with_values(lit, {"scene.name": "stretch-plane"})
    phong = with_values(lit, {"technique": "phong"})
    return [
        ("first", s, {}), ("camera", cam[0], {}), ("camera again", cam[1], {}), ("light", lit, {}),
        ("slider", with_values(lit, {"deon.mix": 0.7}), {}), ("slider back", lit, {}),
        # a banded frame left part-way, then cancelled by a camera move, then finished without a budget
        ("banded", cam[2], {"budget_ms": 1e-9}), ("cancelled", cam[3], {"budget_ms": 1e-9}),
        ("finished", cam[3], {}), ("after the cancel", cam[2], {}),
        ("coverage rules", auto, {}), ("zoom", zoom, {}), ("zoom, orbit", with_values(zoom, {"camera.yaw": 40.0}), {}),
        ("preview", with_values(lit, {"lights.0.intensity": 2.0}), {"variant": "preview", "interactive": True}),
        ("after the preview", with_values(lit, {"lights.0.intensity": 2.0}), {}),
        ("scene", plane, {}), ("scene, orbit", with_values(plane, {"camera.yaw": 30.0}), {}), ("scene back", lit, {}),
        ("technique", phong, {}), ("technique, orbit", with_values(phong, {"camera.yaw": 30.0}), {}),
        ("technique back", lit, {}), ("orbit", with_values(lit, {"camera.yaw": 50.0}), {}),
    ]


def _record(r: Renderer, s: Settings, kw: dict) -> tuple:
    rep = r.render(s, **kw)
    g = r.graph(s.technique, kw.get("variant", ""))
    passes = [(p.name, p.status, p.reason, p.draws, list(p.nonfinite), list(p.inputs), p.outputs, p.note)
              for p in rep.passes]
    image = g.read("image").tobytes() if rep.complete else b""
    return passes, list(g.cancelled), dict(g.in_progress), image


def _run(gl_ctx, monkeypatch, fast: bool, s: Settings) -> list[tuple]:
    monkeypatch.setattr(graph_mod, "FAST_CACHED", fast)
    r = Renderer(gl_ctx)
    try:
        return [_record(r, es, kw) for _, es, kw in _events(s)]
    finally:
        r.release()


@pytest.mark.parametrize("size,extra", [(32, {"deon.subpixel_kernel_px": 0.0}), (64, {})],
                         ids=["whole chain", "kernel rule on the view"])
def test_the_fast_path_skips_exactly_what_the_graph_skipped(gl_ctx, monkeypatch, size, extra):
    """Frame by frame, the fast path on and off: the same passes ran, cached, pruned and deferred for the
    same reasons with the same draws and NaN flags, the same bands in progress and cancelled, the same
    image bit for bit. Bands are a fixed 4 and the own-time stop off, so that timing decides nothing."""
    monkeypatch.setattr(graph_mod.RenderGraph, "_tile_count", lambda self, p, r, budget: 4)
    monkeypatch.setattr(graph_mod, "STARVE_MIN_MS", math.inf)
    s = _small(size, **extra)
    slow, fast = _run(gl_ctx, monkeypatch, False, s), _run(gl_ctx, monkeypatch, True, s)
    names = [what for what, _, _ in _events(s)]
    assert any(c for _, c, _, _ in slow), "the sequence cancels a banded pass"
    assert any(p for _, _, p, _ in slow), "the sequence leaves a pass part-way"
    for what, a, b in zip(names, slow, fast):
        assert a[:3] == b[:3], what
        assert a[3] == b[3], f"{what}: the image differs"


class _Counts:
    """Calls of what a cached frame should not need: compiles, prune reasons, cache keys, framebuffers
    made, scene rules asked (by key)."""

    def __init__(self, monkeypatch):
        self.n: Counter[str] = Counter()
        self.asked: Counter[str] = Counter()
        self.on = False
        for name in ("order_passes", "prune_reason"):
            monkeypatch.setattr(graph_mod, name, self._count(getattr(graph_mod, name), name))
        monkeypatch.setattr(graph_mod.RenderGraph, "_key", self._count(graph_mod.RenderGraph._key, "key"))
        monkeypatch.setattr(moderngl.Context, "framebuffer", self._count(moderngl.Context.framebuffer, "framebuffer"))
        memo, counts = Reflection.memo, self

        def asked(r, key, rule):
            if counts.on and not r._recorders and r._frame_memo is not None and key not in r._frame_memo:
                counts.asked[str(key[0] if isinstance(key, tuple) else key)] += 1
            return memo(r, key, rule)
        monkeypatch.setattr(Reflection, "memo", asked)

    def _count(self, fn, name):
        counts = self

        def wrapped(*a, **k):
            if counts.on:
                counts.n[name] += 1
            return fn(*a, **k)
        return wrapped


def test_a_camera_orbit_touches_only_what_the_camera_can_change(gl_ctx, monkeypatch):
    """d'Eon's camera-only frame with the fast path: no compile and no prune reason (its 51 passes keep
    their reflections), a cache key made only for the view-dependent passes that run, no framebuffer
    made for the NaN/Inf scans, and of the scene rules only the one that reads the camera asked again (the
    TSM's light: is a thin part it is behind in view); the path off does all of it."""
    counts = _Counts(monkeypatch)
    s = _small(64)
    r = Renderer(gl_ctx)
    try:
        got = {}
        for fast in (True, False):
            monkeypatch.setattr(graph_mod, "FAST_CACHED", fast)
            for k in range(3):  # settle: keys kept, scan targets made, the rules' answers recorded
                r.render(with_values(s, {"camera.yaw": s.camera.yaw + k}))
            counts.n.clear()
            counts.asked.clear()
            counts.on = True
            rep = r.render(with_values(s, {"camera.yaw": s.camera.yaw + 7.0}))
            counts.on = False
            got[fast] = (Counter(counts.n), Counter(counts.asked), rep.ran)
    finally:
        r.release()
    on, off = got[True], got[False]
    # the view pass and the light part on a software rasterizer, the one-pass final on a GPU (deon.SPLIT_FINAL)
    assert on[2] == off[2] and on[2][-2:] == ["deon_final", "output"] and set(on[2]) <= {"deon_final_view",
                                                                                          "deon_final", "output"}
    assert on[0]["order_passes"] == on[0]["prune_reason"] == on[0]["framebuffer"] == 0, on[0]
    assert on[0]["key"] == len(on[2])
    assert set(on[1]) == {"deon.tsm_light_index"}, on[1]
    assert off[0]["order_passes"] == 1 and off[0]["prune_reason"] >= 30 and off[0]["framebuffer"] >= 1
    assert off[0]["key"] > 15 and len(off[1]) > 5


def test_a_recalled_rule_answers_as_asking_it_again(gl_ctx, monkeypatch):
    """Moving the camera in and out under the coverage rules changes the map sizes (hysteresis in the
    shape state) and the kernel-under-a-pixel rule's answer: every reflection the fast path keeps or
    recalls equals the one the path off makes, frame by frame."""
    s = _small(64, **{"deon.irradiance_size_mode": "auto", "shadow.map_size_mode": "auto",
                      "deon.irradiance_size": 1024, "deon.subpixel_kernel_px": 1.0})

    def refl(fast: bool) -> list:
        monkeypatch.setattr(graph_mod, "FAST_CACHED", fast)
        r = Renderer(gl_ctx)
        out = []
        try:
            v = r.view(s)
            d0 = float(np.linalg.norm(v.eye - r.scene.gpu.center))
            for k, far in enumerate((1.0, 1.0, 0.4, 0.4, 0.25, 3.0, 12.0, 12.0, 1.0)):
                r.render(with_values(s, {"camera.distance": d0 * far, "camera.yaw": s.camera.yaw + k}))
                g = r.graph("deon")
                out.append({n: (list(x.declared), list(x.notes), dict(x.dropped), x.skip_reason, dict(x._plan),
                                list(x.inputs), dict(x.outputs), list(x.programs)) for n, x in g._last_refl.items()})
        finally:
            r.release()
        return out
    slow, fast = refl(False), refl(True)
    assert len({repr(sorted(x["deon_irradiance"][6].items())) for x in slow}) > 1, "the map size changes"
    assert len({x["deon_blur_5"][3] for x in slow}) > 1, "the kernel rule's answer changes"
    for k, (a, b) in enumerate(zip(slow, fast)):
        assert a == b, f"frame {k}"
