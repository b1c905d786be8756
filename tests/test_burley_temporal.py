"""Temporal reuse of the Burley estimate on a still view (burley2.temporal, passes/burley.BurleyTemporalPass):
each frame a new rotation seed, a per-pixel running mean of N frames, refinement that stops by itself, and a
restart on any change, camera included."""
from __future__ import annotations

import numpy as np
import pytest
from helpers import small_settings

from skinviewer.ground.settings import with_values
from skinviewer.passes import burley as PB

N = 8
N_CONVERGE = 16  # beyond pools neighbours' samples: the own-sample mean it converges to needs ~16 frames


@pytest.fixture
def beyond():
    return small_settings(technique="burley2", size=96, **{"burley2.mode": "beyond", "burley.budget": False})


def _temporal(rep):
    return next(p for p in rep.passes if p.name == PB.TEMPORAL)


def _rel_rms(a, b, mask):
    return float(np.sqrt(((a[mask] - b[mask]) ** 2).mean()) / b[mask].mean())


def test_off_prunes_the_pass_and_never_refines(renderer, beyond):
    rep = renderer.render(beyond)
    assert _temporal(rep).status == "pruned" and not renderer.graph("burley2").refining
    assert renderer.render(beyond).ran == []


def test_still_view_refines_n_frames_then_idles_and_converges(renderer, gl_ctx, beyond):
    from skinviewer.scene.mesh import framing_distance
    renderer.render(beyond)
    fd = framing_distance(renderer.scene.gpu.radius, beyond.camera.fov_y)
    # a close-up: wide kernels, where the estimate's noise (not its bias) is the error
    s = with_values(beyond, {"burley2.temporal": N_CONVERGE, "camera.distance": 0.3 * fd})
    first = renderer.render(s)
    assert "restarted" in _temporal(first).note
    one = renderer.read(s, PB.TEMPORAL).copy()
    assert np.array_equal(one, renderer.read(s, PB.BLURRED))  # frame 1: the plain estimate
    mask = one[..., 3] > 0.5
    for k in range(2, N_CONVERGE + 1):
        rep = renderer.render(s)
        # only the sampling re-runs: lighting, shadows and the scene stay cached
        assert set(rep.ran) == {"burley_blur", "burley_reuse", "burley_temporal", "ss_combine", "output",
                                "burley_count"}
        assert _temporal(rep).figures["frames"] == k
    assert renderer.render(s).ran == [] and renderer.render(s).ran == []  # converged: idle
    mean = renderer.read(s, PB.TEMPORAL)
    assert np.all(np.isfinite(mean)) and np.all(mean[mask][:, :3] >= 0)
    # converged, what is shown is the mean of each pixel's own samples (no pooled, 1-px-shifted ones)
    own = [renderer.read(s, h)[..., :3] for h in PB.HISTORY_OWN]
    assert any(np.array_equal(mean[mask][:, :3], o[mask]) for o in own)
    assert not any(np.array_equal(mean[mask][:, :3], renderer.read(s, h)[..., :3][mask]) for h in PB.HISTORY)
    # against a converged image of the same frame (64 samples x 32 frames, no reuse): the mean of N frames
    # is closer than one frame (independent seeds: the noise falls; it ends on the own samples' mean,
    # without the pooling's bias)
    from skinviewer.engine.renderer import Renderer
    ref_r = Renderer(gl_ctx)
    ref_s = with_values(s, {"burley2.mode": "thesis", "burley2.base": 64, "burley2.threshold": 1.0,
                            "burley2.temporal": 32})
    while ref_r.render(ref_s).ran:
        pass
    ref = ref_r.read(ref_s, PB.TEMPORAL)[..., :3]
    ref_r.release()
    e1, en = _rel_rms(one[..., :3], ref, mask), _rel_rms(mean[..., :3], ref, mask)
    assert en < 0.75 * e1, (e1, en)
    # no energy from nowhere: the mean's total matches one frame's within 1 %
    np.testing.assert_allclose(mean[mask][:, :3].sum(0), one[mask][:, :3].sum(0), rtol=0.01)


@pytest.mark.parametrize("change", [{"lights.0.intensity": 1.5}, {"camera.yaw": 12.0},
                                    {"burley.mfp": (3.0, 1.2, 0.7)}, {"burley.budget": True}])
def test_any_change_restarts_the_mean(renderer, beyond, change):
    s = with_values(beyond, {"burley2.temporal": N})
    for _ in range(N):
        renderer.render(s)
    s2 = with_values(s, change)
    rep = renderer.render(s2)
    assert "restarted" in _temporal(rep).note and _temporal(rep).figures["frames"] == 1
    # nothing of the old view or lighting is left in the mean
    assert np.array_equal(renderer.read(s2, PB.TEMPORAL), renderer.read(s2, PB.BLURRED))
    assert renderer.graph("burley2").refining
