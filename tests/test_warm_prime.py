"""Issue 27, no frozen first frame: a driver finishes a program at its first draw (llvmpipe JIT-compiles
it there), so the viewer's idle frames *draw* the preview variants the next drag renders
(ui/warm.Primer), not only link them. Counts, not times: the times are
benchmarks/bench_interaction.py --prime both --cold-shaders."""
from __future__ import annotations

import numpy as np
import pytest

from skinviewer.ground.settings import Settings, with_values
from skinviewer.ui.warm import Primer, preview_variant, rung_frame_settings
from tests.helpers import edge_viewer
from tests.test_governor import fake_calibration


def test_the_shader_library_counts_each_program_s_first_draw_once(renderer, monkeypatch):
    """first_draw counts a program the first time it is drawn (not when linked), once; a variant only
    compiled (ShaderLibrary.warm) is not drawn; timed first draws are logged with their ms."""
    from tests.helpers import small_settings
    lib = renderer.shaders
    s = small_settings("backlit-ear", "phong", size=32)
    renderer.render(s)
    n = lib.first_draws
    renderer.render(s, force=True)  # the same programs again: no first draw
    assert lib.first_draws == n
    lib.warm([("output", {"TONE_MAP": 0, "BG_ENV": 0, "BG_LEVEL": 3})])
    assert not lib.drawn("output", {"TONE_MAP": 0, "BG_ENV": 0, "BG_LEVEL": 3})  # linked, never drawn
    assert lib.first_draws == n
    prog = lib.get("output", {"TONE_MAP": 0, "BG_ENV": 0, "BG_LEVEL": 3})
    monkeypatch.setattr(lib, "time_first_draws", True)
    t0 = lib.first_draw(prog)
    assert t0 is not None and lib.first_draws == n + 1
    lib.first_draw_done(prog, t0)
    assert lib.first_draw_log[-1][0] == "output" and lib.first_draw_log[-1][2] >= 0.0
    assert lib.first_draw(prog) is None and lib.first_draws == n + 1  # once
    assert lib.drawn("output", {"TONE_MAP": 0, "BG_ENV": 0, "BG_LEVEL": 3})


def test_a_primed_rung_is_rendered_in_the_graph_and_at_the_size_the_drag_uses():
    from skinviewer.techniques.preview import FINAL, ladder
    s = with_values(Settings(), {"technique": "deon"})
    rung = next(r for r in ladder(s) if r.changes and r.scale < 1.0)
    t = rung_frame_settings(s, rung, (640, 676))
    assert (t.render.width, t.render.height) == (int(640 * rung.scale), int(676 * rung.scale))
    for path, value in rung.changes.items():
        assert eval(f"t.{path}") == value  # noqa: S307 (a dotted settings path of the ladder)
    assert preview_variant(FINAL) == "" and preview_variant(rung).startswith("preview ")


@pytest.fixture(scope="module")
def fresh_viewer():
    """A viewer of its own (its own GL context and shader library: no preview variant drawn yet)."""
    yield from edge_viewer()


def _cheapest_fits(s: Settings):
    """A calibration in which only the ladder's cheapest rung (a ¼ view, 256² maps, separable blurs, hard
    shadows: variants of its own) fits a 950 ms budget, and no refinement step is cheap enough."""
    from dataclasses import replace

    from skinviewer.techniques.preview import cheapest
    cal = fake_calibration("deon", s, seed=2)
    low = cheapest(s)
    cal.entries["deon"] = [replace(e, light_ms=10.0 if e.label == low.label else (1000.0 if not e.changes and e.scale == 1.0
                                                                                  else 500.0 + 9.0 * i),
                                   camera_ms=10.0) for i, e in enumerate(cal.entries["deon"])]
    return cal


def _final(app, max_frames=300):
    app.frame.scheduler.changed_at = -1e9  # the last edit is long past
    for _ in range(max_frames):
        app.step(1)
        if not app.frame.governor.refining and app.frame.report is not None and app.frame.report.complete:
            return
    raise AssertionError("never refined")


def _light_drag(app, frames: int) -> list:
    """A light drag, one complete frame a step (no frame budget): the rungs shown."""
    shown = []
    app.frame.set_frame_budget(None)
    app.frame.set_dragging(True)
    try:
        for k in range(frames):
            assert app.state.apply({"lights.0.direction": [0.2 + 0.07 * k, 0.3, 1.0]}, "lights.0 (key light drag)")
            app.step(1)
            shown.append(app.frame.governor.shown)
    finally:
        app.frame.set_dragging(False)
        app.frame.set_frame_budget(100.0)
    return shown


def test_idle_frames_draw_the_variants_the_next_light_drag_renders(fresh_viewer):
    """After the idle frames' priming, a governed light drag draws no program for the first time
    (first_draws stays put), though its preview runs variants the user's settings never drew; the
    image on screen is not touched by the priming, and the refined image is still the ungoverned one."""
    app = fresh_viewer
    fr = app.frame
    fr.governor.set_calibration(_cheapest_fits(app.state.settings))
    assert app.state.apply({"render.governor_budget_ms": 450.0})  # only the cheapest fits
    fr.primer.enabled = False
    _final(app)
    fr.governor._seen.clear()  # the fake calibration's costs decide
    fr.governor.observe = lambda *a, **k: None
    live = app.state.settings
    on_screen = app.renderer.image(live).copy()
    lib = app.renderer.shaders
    targets = fr.primer.targets(fr.governor, live)
    assert targets and all(r.changes for r, _ in targets), "the pick is not a preview graph: nothing to test"
    drawn_before = {k for k, e in lib._entries.items() if e.drawn}
    fr.primer.enabled = True
    for _ in range(200):  # idle frames until primed (each a slice under the frame budget)
        app.step(1)
        if not fr.primer.pending(fr.governor, live):
            break
    assert fr.primer.frames > 0 and not fr.primer.pending(fr.governor, live) and not fr.primer.error
    assert app.state.settings is live and fr.governor.shown.final  # still: no preview was shown
    assert np.array_equal(app.renderer.image(live), on_screen)  # the user's graph untouched
    # the variants the preview needs that the user's settings never drew: now drawn
    main = {(n, tuple(sorted(dict(d).items()))) for p in app.renderer.graph("deon")._last_refl.values()
            for n, d in p.programs}
    preview = app.renderer.graph("deon", preview_variant(targets[0][0]))
    own = [(n, dict(d)) for p in preview._last_refl.values() for n, d in p.programs
           if (n, tuple(sorted(dict(d).items()))) not in main]
    assert own, "the preview uses no variant of its own: the priming was not needed"
    assert all(lib.drawn(n, d) for n, d in own)
    key = (lambda n, d: (n, tuple(sorted((str(k), str(v)) for k, v in d.items()))))
    assert not any(key(n, d) in drawn_before for n, d in own)  # drawn by the priming, not before it
    n = lib.first_draws
    try:
        shown = _light_drag(app, 3)
    finally:
        del fr.governor.observe
    assert all(r == targets[0][0] for r in shown)
    assert lib.first_draws == n, "the drag drew a program for the first time (a JIT in a drag frame)"
    _final(app)
    # an edit that changes a variant of your settings' graph (the output's tone map) changes the
    # preview's too: primed again before the next drag, which again draws nothing for the first time
    fr.governor._seen.clear()  # the fake calibration's costs decide again
    fr.governor.observe = lambda *a, **k: None
    main_before = app.renderer.graph("deon").programs()
    primings = fr.primer.frames
    assert app.state.apply({"render.tone_map": "linear"}, "render.tone_map")
    _final(app)
    assert app.renderer.graph("deon").programs() != main_before
    assert fr.primer.pending(fr.governor, app.state.settings) or fr.primer.frames > primings
    for _ in range(200):
        app.step(1)
        if not fr.primer.pending(fr.governor, app.state.settings):
            break
    assert not fr.primer.pending(fr.governor, app.state.settings)
    n = lib.first_draws
    try:
        shown = _light_drag(app, 2)
    finally:
        del fr.governor.observe
    assert not shown[0].final and lib.first_draws == n
    _final(app)
    got = app.renderer.image(app.state.settings)
    app.renderer.render(app.state.settings, force=True)
    assert np.array_equal(got, app.renderer.image(app.state.settings))


def test_the_primer_says_nothing_to_do_without_a_calibration_or_for_the_user_s_own_graph(renderer):
    from skinviewer.ui.governor import Governor
    s = with_values(Settings(), {"technique": "deon"})
    p = Primer(renderer)
    assert p.targets(Governor(), s) == []  # no calibration: the viewer renders your settings
    g = Governor(budget_ms=1e9)  # everything fits: the pick is your settings, nothing to prime
    g.set_calibration(fake_calibration("deon", s, seed=1))
    assert p.targets(g, s) == [] and p.step(g, s, (64, 64), 50.0) is False


def test_the_live_names_of_a_program_are_those_moderngl_lists_made_once(renderer):
    """ExecuteContext._check asks ShaderLibrary.members (a set made once per program) instead of
    ``name in prog`` (moderngl walks every member each time); the same names, and a new set after a
    program is replaced."""
    lib = renderer.shaders
    prog = lib.get("output", {"TONE_MAP": 1, "BG_ENV": 0, "BG_LEVEL": 1})
    names = lib.members(prog)
    assert names == frozenset(prog) and lib.members(prog) is names
    assert all(n in names for n in prog) and "no_such_uniform" not in names
