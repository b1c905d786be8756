"""The viewer's Accuracy window: ground truth in a worker (the UI keeps stepping), the image's error
figures, the heat-map view modes, cancelling, and the Pareto chart's configurations applied."""
from __future__ import annotations

import json
import time

import numpy as np
import pytest
from helpers import viewer_app

pytestmark = pytest.mark.viewer


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    yield from viewer_app(tmp_path_factory, "laser", (300, 200))


def _acc(app):
    from skinviewer.ui.accuracy_window import AccuracyWindow
    return next(w for w in app.ui.windows if isinstance(w, AccuracyWindow))  # a registered window


def _wait(app, timeout=120.0):
    t0 = time.monotonic()
    frames = 0
    while _acc(app).job is not None and time.monotonic() - t0 < timeout:
        app.step()
        frames += 1
    assert _acc(app).job is None, "the ground truth did not finish"
    return frames


def test_ground_truth_in_a_worker_then_error_figures_and_heat_map(app):
    acc = _acc(app)
    acc.start()
    assert acc.job is not None
    frames = _wait(app)
    assert frames >= 1  # the UI kept stepping while the worker ran
    assert acc.current, acc.status
    app.step()
    e = acc.error
    assert e is not None and all(np.isfinite(e.rms)) and 0.0 <= e.dssim <= 1.0
    # the figures are image_error of the image on screen (the lit target) against the truth, computed
    # here on the same images; and they are not the truth against itself (all zero)
    from skinviewer.engine.bench import compare_mask
    from skinviewer.physics.metrics import image_error
    st = app.state.settings
    lit = app.frame.renderer.read(st, "lit")[::-1]
    img = np.asarray(lit[..., :3], np.float64)
    ref = acc.reference
    assert img.shape == ref.lit.shape
    m = compare_mask(ref.mask, lit[..., 3] > 0.5)
    assert m.sum() > 100
    want = image_error(img, ref.lit, m, exposure=st.render.exposure, uncertainty=ref.uncertainty)
    assert e == want, (e, want)
    # the session's truth states its surface lattices' interpolation error, and the figures carry it
    assert ref.uncertainty is not None and e.rms_u is not None and all(np.isfinite(e.rms_u))
    assert min(e.rms) > 1e-3 and e.dssim > 1e-5, e  # d'Eon at 256^2 maps is not the truth
    assert not np.allclose(img[m], ref.lit[m])
    acc.view_mode = 1
    app.step()
    assert acc.heat_tex is not None and acc.heat_tex.size == (app.state.settings.render.width, app.state.settings.render.height)
    acc.view_mode = 2
    app.step()
    acc.view_mode = 0
    # a new view makes the truth stale
    app.state.apply({"camera.yaw": 10.0})
    app.step()
    assert not acc.current


def test_cancel(app):
    acc = _acc(app)
    app.state.apply({"camera.yaw": 20.0})
    acc.start()
    acc.cancel()
    _wait(app)
    assert acc.status in ("cancelled",) or acc.current


def test_the_truth_follows_the_view_refining_and_reusing_its_sources(app):
    """Once asked, the truth follows the view: an orbit restarts it without a new surface irradiance
    (the session's sources), its stages arrive one by one (figures and heat map refine), and each
    stage's figures are of the pixels done so far."""
    acc = _acc(app)
    acc.start()
    _wait(app)
    assert acc.current and acc.follow
    builds = acc.session.builds
    seen = []
    app.state.apply({"camera.yaw": 40.0})
    t0 = time.monotonic()
    while not acc.current and time.monotonic() - t0 < 120:
        app.step()
        if acc.partial is not None and acc.partial.stage not in seen:
            seen.append(acc.partial.stage)
    while acc.job is not None and time.monotonic() - t0 < 120:
        app.step()
        if acc.partial is not None and acc.partial.stage not in seen:
            seen.append(acc.partial.stage)
    assert acc.current and acc.partial.final
    assert acc.session.builds == builds  # the orbit re-used the diffusion's sources
    assert not any("coarse" in st for st in seen)
    app.step()
    assert acc.error is not None and acc.rms_se is not None and np.all(acc.rms_se[1] == 0)
    acc.cancel()
    assert not acc.follow


def test_pareto_point_applies_its_configuration(app, tmp_path):
    from skinviewer.engine.bench import Result
    rows = [Result("deon", "irr512", {"deon.irradiance_size": 512}, full_ms=50.0, rms=[0.02] * 3, p99=[0.1] * 3,
                   dssim=0.01).to_json(),
            Result("gosselin", "map512 it2", {"gosselin.light_map_size": 512, "gosselin.iterations": 2},
                   full_ms=30.0, rms=[0.05] * 3, p99=[0.2] * 3, dssim=0.02).to_json()]
    path = tmp_path / "results.json"
    path.write_text(json.dumps({"scene": "laser", "results": rows}))
    acc = _acc(app)
    assert acc.load_results(str(path))
    assert sum(r.pareto for r in acc.results) == 2
    deon, gos = acc.results
    app.state.apply({"technique": "deon", "deon.irradiance_size": 512})
    assert acc.matches(deon) and not acc.matches(gos)
    acc.apply(gos)
    assert app.state.settings.technique == "gosselin" and app.state.settings.gosselin.iterations == 2
    assert acc.matches(gos)
    app.step()
    assert not acc.load_results(str(tmp_path / "missing.json"))
    assert "cannot read" in acc.results_msg
