"""Issue 34, the cold start: before this machine has a calibration the viewer's first image is the
technique's cheapest preview rung as declared (techniques/preview.cheapest), then the user's settings;
the start-up screen says which it is making. Structure, not timing: the times are
benchmarks/bench_startup.py's."""
from __future__ import annotations

import numpy as np
import pytest
from helpers import splash_app

from skinviewer.ground.settings import Settings, with_values
from skinviewer.techniques.preview import FINAL, LADDERS, cheapest, ladder
from skinviewer.ui.governor import Governor


@pytest.mark.parametrize("technique", sorted(LADDERS))
def test_the_cheapest_rung_is_a_preview_of_the_ladder_and_refines_to_the_users_settings(technique):
    s = with_values(Settings(), {"technique": technique})
    rung = cheapest(s)
    rungs = ladder(s)
    assert rung in rungs and not rung.final
    assert rung.scale < 1.0  # a smaller view (and the technique's own caps: its declared cheapest)
    assert rung.label == rungs[rungs.index(rung)].label
    g = Governor("interactive", 100.0, calibration=None)
    g.start_at(rung)
    assert g.rung_for(s, False, False, False) == rung  # its frame not complete yet: still the preview
    assert g.rung_for(s, False, False, True) == FINAL  # complete: the user's settings
    assert not g.refining and g.rung_for(s, False, False, True) == FINAL


def test_a_user_setting_below_the_cheapest_rung_is_never_raised():
    s = with_values(Settings(), {"technique": "deon", "deon.irradiance_size": 256, "deon.tsm_size": 256})
    rung = cheapest(s)
    assert "deon.irradiance_size" not in rung.changes and "deon.tsm_size" not in rung.changes
    s = with_values(Settings(), {"technique": "burley", "burley.samples": 4})
    assert "burley.samples" not in cheapest(s).changes


def test_a_cold_start_without_calibration_shows_the_cheapest_preview_first(tmp_path, monkeypatch):
    """create_app as the viewer starts (its start-up screen in the view), no calibration: the first
    complete image is the cheapest rung's (a ¼ view), the start-up screen named it while it was made,
    the next complete image is the user's settings -- the image an ungoverned start shows."""
    monkeypatch.setenv("SKINVIEWER_CACHE", str(tmp_path))  # no calibration in this cache
    app = splash_app((480, 320))
    from skinviewer.ui.app import destroy_app
    from skinviewer.ui.splash import StartupView
    try:
        f = app.frame
        assert f.load_calibration(auto=False) is not None and f.governor.calibration is None
        view = app.ui.window(StartupView)
        sp = view.splash
        app.ui_frame()
        assert view.phase()[0].startswith("preparing the first frame")
        f.scheduler.note_change()
        f.start_with_preview()
        f.set_frame_budget(1e-3)  # one pass a frame: the screen stays while the preview is made
        app.step(1)
        assert view.phase()[0].startswith("the first preview (view ¼")
        assert "passes" in view.phase()[1] or f.report.complete
        full = tuple(f.layout.view_fb[2:])  # the view's pixels (the render size at the user's settings)
        for _ in range(200):
            if f.report is not None and f.report.complete:
                break
            app.step(1)
        assert f.report.complete and f._variant.startswith("preview")  # the first image: the preview
        assert "image" in app._marked and "final" not in app._marked
        assert f.graph().read("image").shape[1] <= full[0] // 4 + 1  # a ¼ view
        app.step(1)  # (a frame complete past the budget is presented the next frame)
        assert view.splash is None and f._variant.startswith("preview")  # the preview has the view
        assert any(t.startswith("the first preview (view ¼") for _, t in sp.lines)  # the screen said so
        from skinviewer.ui.splash import TEXT_W, plain
        assert plain(view.phase()[0]).isascii()  # what the screen's font can draw (it drew boxes for ¼ and ²)
        img = sp._image(size=(TEXT_W, 2000))
        assert img.shape[1] <= TEXT_W and img.shape[0] > 124 + 24 * len(sp.lines)  # the long line wrapped
        for _ in range(200):
            app.step(1)
            if f.report.complete and not f._variant:
                break
        assert f.report.complete and f._variant == "" and "final" in app._marked
        final = f.graph().read("image").copy()
        assert final.shape[:2] == (full[1], full[0])
        app.step(1)
        assert f._cold_start is None and not f._governing  # from now on the usual (ungoverned) path
        from skinviewer.engine.renderer import Renderer
        fresh = Renderer(app.ctx)  # an ungoverned render of the same settings
        try:
            assert fresh.render(app.state.settings).complete
            assert np.array_equal(final, fresh.read(app.state.settings, "image"))  # bit for bit
        finally:
            fresh.release()
    finally:
        destroy_app(app)
