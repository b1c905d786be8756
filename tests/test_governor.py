"""The quality governor (issue 27): its pick on the calibration it holds, refinement up to the
user's settings (never backwards while still, the last step the ungoverned render bit for bit),
off = today's behaviour, and the calibration cache (missing, stale or corrupt: rebuilt)."""
from __future__ import annotations

import json
import random

import numpy as np
import pytest

from skinviewer.engine import calibration
from skinviewer.engine.calibration import Calibration, Entry, rung_key, signature
from skinviewer.ground.settings import Settings, with_values
from skinviewer.techniques.preview import FINAL, Rung, ladder
from skinviewer.ui.governor import Governor
from tests.helpers import edge_viewer, small_settings


def fake_calibration(technique: str, s: Settings, seed: int = 0, errors: bool = True) -> Calibration:
    """Rungs of ``s``'s ladder with random costs (FINAL the dearest) and errors (FINAL the least)."""
    rnd = random.Random(seed)
    entries = []
    for r in ladder(s):
        light = 1000.0 if r.final else rnd.uniform(5.0, 900.0)
        entries.append(Entry(technique, r.label, dict(r.changes), r.scale, light, light * rnd.uniform(0.1, 1.0),
                             (0.01 if r.final else rnd.uniform(0.02, 0.3)) if errors else None))
    return Calibration("test renderer", "small", (640, 640), {technique: entries}, signature=signature([technique]))


@pytest.mark.parametrize("technique", ["deon", "gosselin", "burley2", "separable", "phong"])
def test_the_pick_never_costs_more_than_the_budget_on_the_calibration_held(technique):
    s = with_values(Settings(), {"technique": technique})
    for seed in range(30):
        for errors in (True, False):
            cal = fake_calibration(technique, s, seed, errors)
            g = Governor("interactive", random.Random(seed).uniform(1.0, 1200.0), cal)
            for camera in (False, True):
                p = g.pick(s, camera)
                cheapest = min(g.cost(technique, r, camera) for r in ladder(s)
                                if not camera or r.changes == {})
                assert g.room() == pytest.approx(0.85 * g.budget_ms)  # a margin under the budget
                if cheapest <= g.room():
                    assert p.ms <= g.room() and not p.note
                    # and it is the most accurate of those that fit
                    fits = [r for r in ladder(s) if g.cost(technique, r, camera) <= g.room()
                            and (not camera or r.changes == {})]
                    if errors:
                        assert p.error == min(cal.entry(technique, r).error for r in fits)
                else:
                    assert p.ms == cheapest and "nothing fits" in p.note


def test_the_costs_seen_here_replace_the_calibration_and_scale_the_rest():
    """A calibration made on a busier day (every cost 10x what this machine takes now): once a few
    frames were seen, the pick is what fits as the machine is now, not as it was calibrated."""
    s = with_values(Settings(), {"technique": "deon"})
    cal = fake_calibration("deon", s, seed=3)
    g = Governor("interactive", 120.0, cal)  # room: 0.85 x 120 = 102 ms
    rungs = ladder(s)
    assert g.scale("deon") == 1.0 and g.cost("deon", rungs[0], False) == cal.entry("deon", rungs[0]).light_ms
    g.observe("deon", rungs[0], False, cal.entry("deon", rungs[0]).light_ms / 10.0)
    g.observe("deon", FINAL, False, 100.0)  # FINAL was calibrated at 1000 ms
    assert g.scale("deon") == pytest.approx(0.1)
    assert g.cost("deon", FINAL, False) == 100.0  # seen: its own figure
    for r in rungs[1:-1]:  # not seen: calibrated x the scale the seen ones show
        assert g.cost("deon", r, False) == pytest.approx(0.1 * cal.entry("deon", r).light_ms)
    assert g.pick(s).rung == FINAL  # the user's settings fit the budget as the machine is now
    # a running mean: one slow frame moves the figure half way, it does not replace it
    g.observe("deon", FINAL, False, 300.0)
    assert g.cost("deon", FINAL, False) == pytest.approx(200.0)
    # what is no measurement is ignored
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        g.observe("deon", FINAL, False, bad)
    assert g.cost("deon", FINAL, False) == pytest.approx(200.0)
    # what a displayed frame costs besides rendering comes out of the budget
    g.observe("deon", FINAL, False, 90.0)  # running mean (200 + 90) / 2 = 145 ms: over 100
    g.budget_ms = 180.0  # room 153
    assert g.pick(s).rung == FINAL
    g.overhead_ms = 30.0  # room 0.85 x (180 - 30) = 127.5 < 145: a preview now
    assert g.pick(s).rung != FINAL and g.pick(s).ms <= 127.5
    g.overhead_ms, g.budget_ms = 0.0, 100.0
    # a technique never seen borrows every technique's ratio
    s2 = with_values(Settings(), {"technique": "phong"})
    cal.entries["phong"] = fake_calibration("phong", s2, seed=4).entries["phong"]
    assert g.scale("phong") == pytest.approx(g.scale("deon"))


def test_a_budget_of_zero_or_less_says_so_and_shows_the_cheapest():
    s = with_values(Settings(), {"technique": "deon"})
    cal = fake_calibration("deon", s)
    for budget in (0.0, -5.0):
        g = Governor("interactive", budget, cal)
        p = g.pick(s)
        assert p.ms == min(e.light_ms for e in cal.entries["deon"])
        assert "not positive" in p.note and "cheapest" in p.note


def test_refinement_steps_up_to_the_users_settings_and_never_back_while_still():
    s = with_values(Settings(), {"technique": "deon"})
    cal = fake_calibration("deon", s, seed=3)
    g = Governor("interactive", 200.0, cal)
    first = g.rung_for(s, interacting=True, camera=False, last_complete=True)
    assert not first.final and g.status(s).startswith("preview: ")
    e = cal.entry("deon", first)
    assert f", {100 * e.error:.1f} % from the truth" in g.status(s)
    e.uncertainty = 0.0186  # the ruler's own uncertainty goes beside its figure
    assert f", {100 * e.error:.1f} % ± 1.9 from the truth" in g.status(s)
    errors = [cal.entry("deon", first).error]
    shown = [first]
    for complete in [False, True, False, True, True, True, True]:
        r = g.rung_for(s, interacting=False, camera=False, last_complete=complete)
        if r != shown[-1]:
            errors.append(cal.entry("deon", r).error)
            shown.append(r)
        if not complete:  # an unfinished frame is never left for another rung
            assert r == shown[-1]
    assert shown[-1] == FINAL and not g.refining
    assert errors == sorted(errors, reverse=True)  # never backwards
    assert len(shown) <= 3  # at most one step between the preview and the user's settings
    assert g.settings_for(s, FINAL) is s  # the user's settings themselves: the ungoverned render
    assert g.status(s) == ""


def test_off_is_todays_behaviour_and_fixed_budget_holds_the_pick():
    s = with_values(Settings(), {"technique": "deon"})
    cal = fake_calibration("deon", s, seed=1)
    g = Governor("off", 200.0, cal)
    assert g.rung_for(s, True, False, True) == FINAL and g.settings_for(s, FINAL) is s and g.status(s) == ""
    g.configure("fixed-budget")
    r = g.rung_for(s, False, False, True)
    assert not r.final and g.rung_for(s, False, False, True) == r and "fixed" in g.status(s)
    with pytest.raises(ValueError):
        g.configure("sometimes")


def test_a_camera_drag_keeps_the_texture_space_work_on_screen():
    s = with_values(Settings(), {"technique": "deon"})
    g = Governor("interactive", 1e9, fake_calibration("deon", s))
    assert g.pick(s, camera=True).rung.changes == {}
    g = Governor("interactive", 1.0, fake_calibration("deon", s))
    assert g.pick(s, camera=True).rung.changes == {}  # nothing fits: still no texture-space re-render


def test_ladders_cap_never_raise_and_end_with_the_users_settings():
    from skinviewer import techniques
    for name in techniques.names():
        s = with_values(Settings(), {"technique": name, "deon.irradiance_size": 256})
        rungs = ladder(s)
        assert rungs[-1] == FINAL and len({rung_key(name, r) for r in rungs}) == len(rungs)
        assert all(r.changes.get("deon.irradiance_size", 256) <= 256 for r in rungs)


# -- the calibration cache -----------------------------------------------------------------------
@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SKINVIEWER_CACHE", str(tmp_path))
    return tmp_path


def test_calibration_round_trips_and_bad_files_are_rebuilt_never_trusted(cache):
    s = with_values(Settings(), {"technique": "phong"})
    cal = fake_calibration("phong", s)
    cal.renderer = "GPU X"
    cal, why = calibration.load("GPU X", "small")
    assert cal is None and "no calibration" in why
    cal = fake_calibration("phong", s)
    cal.renderer = "GPU X"
    path = calibration.save(cal)
    back, why = calibration.load("GPU X", "small")
    assert why == "" and back.entries["phong"][0].light_ms == cal.entries["phong"][0].light_ms
    assert calibration.load("GPU Y", "small")[0] is None  # per renderer string
    assert calibration.load("GPU X", "large")[0] is None  # and mesh size class
    good = path.read_text()
    for bad, words in (("{ not json", "unreadable"), (good.replace('"version": 1', '"version": 0'), "another version"),
                       (good.replace(rung_key("phong", FINAL).replace('"', '\\"'), "x"), "other preview ladders"),
                       (json.dumps({**json.loads(good), "entries": {"phong": [{"technique": "phong"}]}}), "unreadable")):
        path.write_text(bad)
        got, why = calibration.load("GPU X", "small")
        assert got is None and words in why, why
    # two techniques, one of whose ladders changed: that one is measured again, the other kept
    two = fake_calibration("phong", s)
    two.renderer = "GPU X"
    sd = with_values(Settings(), {"technique": "deon"})
    two.entries["deon"] = fake_calibration("deon", sd).entries["deon"]
    two.signature = signature(["deon", "phong"])
    two.signature["deon"] = ["a ladder of yesterday"]
    calibration.save(two)
    got, why = calibration.load("GPU X", "small")
    assert sorted(got.entries) == ["phong"] and "deon made for other preview ladders" in why, why
    path.write_text(good)
    # a negative or NaN time is not trusted either
    d = json.loads(good)
    d["entries"]["phong"][0]["light_ms"] = float("nan")
    path.write_text(json.dumps(d))
    assert calibration.load("GPU X", "small")[0] is None


def test_a_shipped_gpu_calibration_is_used_for_its_renderer_until_the_machine_has_its_own(cache, tmp_path, monkeypatch):
    # issue 31: benchmarks/gpu/run.sh's calibration, shipped in skinviewer/techniques/calibrations/
    s = with_values(Settings(), {"technique": "phong"})
    cal = fake_calibration("phong", s)
    cal.renderer = "NVIDIA Test GPU/PCIe/SSE2"
    folder = tmp_path / "shipped"
    folder.mkdir()
    (folder / "nvidia-test.json").write_text(json.dumps(cal.to_json()))
    (folder / "broken.json").write_text("{ not json")  # skipped, never trusted
    monkeypatch.setattr(calibration, "SHIPPED", folder)
    got, why = calibration.load(cal.renderer, "small")
    assert why == "" and got is not None and got.entries["phong"][0].light_ms == cal.entries["phong"][0].light_ms
    assert calibration.load("another GPU", "small")[0] is None  # only for exactly that renderer
    assert calibration.load(cal.renderer, "large")[0] is None  # and mesh size class
    own = fake_calibration("phong", s)
    own.renderer = cal.renderer
    own.entries["phong"][0].light_ms = 1234.5
    calibration.save(own)  # this machine's own measurement wins
    assert calibration.load(cal.renderer, "small")[0].entries["phong"][0].light_ms == 1234.5
    # a shipped file made for other preview ladders (the code changed) is ignored, technique by technique
    d = cal.to_json()
    d["signature"] = {"phong": ["x"]}
    (folder / "nvidia-test.json").write_text(json.dumps(d))
    assert calibration.shipped(cal.renderer, "small", folder) is None
    sd = with_values(Settings(), {"technique": "deon"})
    d = cal.to_json()
    d["entries"]["deon"] = fake_calibration("deon", sd).to_json()["entries"]["deon"]
    d["signature"] = {**signature(["phong", "deon"]), "deon": ["x"]}
    (folder / "nvidia-test.json").write_text(json.dumps(d))
    assert sorted(calibration.shipped(cal.renderer, "small", folder).entries) == ["phong"]


def test_calibrate_measures_every_rung_and_rebuilds_a_corrupt_file(cache, gl_ctx):
    from skinviewer.engine.renderer import Renderer
    base = small_settings("shadow-edge", "phong")
    r = Renderer(gl_ctx)
    try:
        renderer = calibration.renderer_name(gl_ctx)
        path = calibration.calibration_path(renderer, "small")
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("garbage")
        assert calibration.load(renderer, "small")[0] is None
        cal = calibration.calibrate(r, base, ["phong"], runs=1)
        calibration.save(cal)
        back, why = calibration.load(renderer, cal.mesh_class)
        assert why == "" and [e.label for e in back.entries["phong"]] == [x.label for x in ladder(with_values(Settings(), {"technique": "phong"}))]
        assert all(e.light_ms > 0 and e.camera_ms > 0 for e in back.entries["phong"])
        assert not list(path.parent.glob("*.tmp*"))  # the atomic write left nothing behind
    finally:
        r.release()


def test_governed_refinement_converges_to_exactly_the_ungoverned_image(renderer):
    """Previews of the rungs, then the refinement's last step (the user's settings): the image is
    the one a fresh renderer makes of the user's settings, bit for bit."""
    from skinviewer.engine.calibration import rung_settings
    from skinviewer.engine.renderer import Renderer
    s = small_settings("head", "deon", size=64)
    g = Governor("interactive", 1e9, fake_calibration("deon", s, seed=5))
    for rung in ladder(s)[:-1]:  # what the drag showed, in the same graphs and pool, as the viewer renders
        renderer.render(rung_settings(s, rung), interactive=True)  # a preview: binned TSM rule, no NaN check
    renderer.render(g.settings_for(s, FINAL))
    got = renderer.image(s)
    fresh = Renderer(renderer.ctx)
    try:
        fresh.render(s)
        want = fresh.image(s)
    finally:
        fresh.release()
    assert np.array_equal(got, want)


# -- in the viewer's frame loop (Xvfb) ----------------------------------------------------------
@pytest.fixture(scope="module")
def viewer():
    yield from edge_viewer()


def _still(app, max_frames=200):
    """Input stopped: step until the governor has refined to the user's settings and the frame is complete."""
    app.frame.scheduler.changed_at = -1e9  # the last edit is long past (no 0.35 s wait in a test)
    for _ in range(max_frames):
        app.step(1)
        if not app.frame.governor.refining and app.frame.report is not None and app.frame.report.complete:
            return
    raise AssertionError("never refined")


def test_the_viewer_previews_while_dragging_and_refines_to_the_ungoverned_image(viewer):
    app = viewer
    s = app.state.settings
    cal = fake_calibration("deon", s, seed=2)
    # the user's settings cost 1000 ms, every preview less: a 950 ms budget previews a light drag
    app.frame.governor.calibration = cal
    assert app.state.apply({"render.governor_budget_ms": 950.0})
    _still(app)
    app.frame.governor._seen.clear()  # the fake calibration's costs decide (not what frames cost here)
    app.frame.governor.observe = lambda *a, **k: None
    full = (app.state.settings.render.width, app.state.settings.render.height)
    app.frame.set_frame_budget(None)  # one complete frame a step: each step's image is its pick's
    app.frame.set_dragging(True)
    try:
        for k in range(3):
            assert app.state.apply({"lights.0.direction": [0.2 + 0.1 * k, 0.3, 1.0]}, "lights.0 (key light drag)")
            app.step(1)
            status = app.frame.governor_status
            assert status.startswith("preview: "), status
            shown = app.frame.governor.shown
            assert not shown.final and app.frame.governor.cost("deon", shown, False) <= 950.0
            g = app.frame.graph()  # the preview's own graph (its maps stay cached there)
            assert (g is app.renderer.graph("deon")) == (not shown.changes)
            for path, value in shown.changes.items():  # the graph rendered the preview's knobs
                if path == "deon.irradiance_size":
                    assert g.resources()["deon_irradiance"].size == (value, value)
    finally:
        app.frame.set_dragging(False)
        app.frame.set_frame_budget(100.0)
        del app.frame.governor.observe
    _still(app)
    assert app.frame.governor_status == ""
    assert (app.state.settings.render.width, app.state.settings.render.height) == full
    live = app.state.settings
    got = app.renderer.image(live)
    app.renderer.render(live, force=True)  # the ungoverned render of the same settings, every pass re-run
    assert np.array_equal(got, app.renderer.image(live))


def test_governor_off_in_the_viewer_is_todays_frame(viewer):
    app = viewer
    app.frame.governor.calibration = fake_calibration("deon", app.state.settings, seed=2)
    assert app.state.apply({"render.governor": "off", "render.governor_budget_ms": 1.0})
    try:
        app.frame.set_dragging(True)
        assert app.state.apply({"lights.0.direction": [0.5, 0.1, 1.0]}, "lights.0 (key light drag)")
        app.step(1)
        assert app.frame.governor.shown.final and app.frame.governor_status == ""
        # the user's settings rendered: the irradiance at the user's size
        assert app.frame.graph() is app.renderer.graph("deon")
        assert app.renderer.graph("deon").resources()["deon_irradiance"].size == (512, 512)
    finally:
        app.frame.set_dragging(False)
        app.state.apply({"render.governor": "interactive", "render.governor_budget_ms": 100.0})


def test_the_shipped_gpu_calibrations_parse_and_fit_todays_ladders():
    # benchmarks/gpu/run.sh's calibrate step; a ladder change makes a shipped file stale: re-run the GPU
    # check (or delete the file), since load() would silently ignore it
    files = sorted(calibration.SHIPPED.glob("*.json"))
    assert files, "no shipped calibration"
    for p in files:
        cal = Calibration.from_json(json.loads(p.read_text()))
        assert cal.version == calibration.VERSION, p.name
        # a technique whose ladder changed since the GPU run is dropped at load (measured on that GPU
        # when first governed); re-run the GPU check's calibrate step to ship it again
        got = calibration.shipped(cal.renderer, cal.mesh_class)
        assert got is not None and got.entries, f"{p.name}: no technique fits today's ladders"
        assert got.signature == signature(sorted(got.entries))
        assert {"phong", "gosselin", "ssss", "separable", "burley", "burley2"} <= set(got.entries), sorted(got.entries)


def test_letting_go_of_a_drag_starts_the_refinement_at_once(viewer):
    """No rest wait after a mouse release: the next frame already steps up towards the user's settings."""
    app = viewer
    cal = fake_calibration("deon", app.state.settings, seed=2)
    app.frame.governor.set_calibration(cal)
    assert app.state.apply({"render.governor_budget_ms": 950.0})
    _still(app)
    app.frame.governor._seen.clear()  # the fake calibration's costs decide (FINAL 1000 ms: a preview)
    app.frame.set_dragging(True)
    assert app.state.apply({"lights.0.direction": [0.25, 0.3, 1.0]}, "lights.0 (key light drag)")
    app.step(1)
    assert not app.frame.governor.shown.final
    app.frame.set_dragging(False)  # released a moment after the last change: within the rest time
    app.step(1)
    assert not app.frame._interacting and (app.frame.governor.refining or app.frame.governor.shown.final)
    # an edit without a held widget (a typed value) still waits for the rest time
    assert app.state.apply({"lights.0.direction": [0.3, 0.3, 1.0]}, "lights.0.direction")
    app.step(1)
    assert app.frame._interacting
    _still(app)


def _deon_preview_governed(app):
    """d'Eon governed by a fake calibration under a 950 ms budget, the view still: a preview is picked
    from the calibration's costs (none seen yet)."""
    app.frame.governor.set_calibration(fake_calibration("deon", app.state.settings, seed=2))
    assert app.state.apply({"render.governor_budget_ms": 950.0})
    _still(app)
    app.frame.governor._seen.clear()


def test_a_drag_finishes_each_preview_frame_instead_of_cancelling_it(viewer):
    """A preview that takes several frames (under a small frame budget) is finished before the newest
    drag position is taken: a drag changing the light every frame still gets complete images."""
    app = viewer
    _deon_preview_governed(app)
    app.frame.set_frame_budget(40.0)  # the preview's passes in row bands, a few frames each
    try:
        app.frame.set_dragging(True)
        completed = partial = 0
        for k in range(1500):
            assert app.state.apply({"lights.0.direction": [0.2 + 0.001 * k, 0.3, 1.0]}, "lights.0 (key light drag)")
            app.step(1)
            rep = app.frame.report
            completed += bool(rep is not None and rep.complete and rep.ran)
            partial += bool(rep is not None and not rep.complete)
            if completed >= 2:
                break
        assert partial, "no preview frame was spread over frames: nothing was tested"
        assert completed >= 2, "the drag never showed a complete preview"
    finally:
        app.frame.set_dragging(False)
        app.frame.set_frame_budget(100.0)
    _still(app)


def test_the_error_table_s_uncertainty_reaches_the_calibration(tmp_path, monkeypatch):
    """preview_errors.json's 'uncertainty' (the ruler's, per rung) is attached beside each error."""
    s = with_values(Settings(), {"technique": "deon"})
    cal = fake_calibration("deon", s, errors=False)
    keys = [e.key for e in cal.entries["deon"]]
    table = tmp_path / "errors.json"
    table.write_text(json.dumps({"errors": {k: 0.05 for k in keys}, "uncertainty": {keys[0]: 0.02}}))
    monkeypatch.setattr(calibration, "ERRORS_TABLE", table)
    monkeypatch.setattr(calibration, "_bench_errors", lambda path: {})
    calibration.attach_errors(cal)
    es = cal.entries["deon"]
    assert es[0].error == 0.05 and es[0].uncertainty == 0.02
    assert all(e.error == 0.05 and e.uncertainty is None for e in es[1:])
    # a file of today's calibration (no 'uncertainty' in its entries) still loads
    d = cal.to_json()
    for e in d["entries"]["deon"]:
        e.pop("uncertainty")
    assert Calibration.from_json(d).entries["deon"][0].uncertainty is None


def test_figures_of_an_older_truth_are_said_in_the_calibration_and_the_status(tmp_path, monkeypatch):
    """preview_errors.json records the truth's VERSION it was measured with (issue 30: every figure carries
    its ruler): a table of an older truth, or one that does not say, is named in one line and in the
    governor's status beside the figure; a table of today's truth, and a bench of it, are not."""
    from skinviewer.engine.reference import VERSION
    s = with_values(Settings(), {"technique": "deon"})
    keys = [e.key for e in fake_calibration("deon", s, errors=False).entries["deon"]]
    table = tmp_path / "errors.json"
    monkeypatch.setattr(calibration, "ERRORS_TABLE", table)
    monkeypatch.setattr(calibration, "_bench_errors", lambda path: {})

    def governed(version):
        doc = {"errors": {k: 0.05 for k in keys}, "uncertainty": {k: 0.02 for k in keys}}
        if version is not None:
            doc["truth_version"] = version
        table.write_text(json.dumps(doc))
        cal = fake_calibration("deon", s, errors=False)
        calibration.attach_errors(cal)
        g = Governor("interactive", 200.0, cal)
        assert not g.rung_for(s, interacting=True, camera=False, last_complete=True).final
        return cal, g.status(s)

    cal, status = governed(VERSION - 2)
    assert all(e.truth_version == VERSION - 2 for e in cal.entries["deon"])
    line = calibration.stale_truth(cal)
    assert f"{len(keys)} from the shipped table (truth version {VERSION - 2})" in line and f"version {VERSION})" in line
    assert f"5.0 % ± 2.0 from the truth (truth version {VERSION - 2}, now {VERSION})" in status
    cal, status = governed(None)  # a table made before it recorded its truth
    assert "truth version not recorded" in calibration.stale_truth(cal) and "(truth version not recorded" in status
    cal, status = governed(VERSION)
    assert calibration.stale_truth(cal) == "" and "5.0 % ± 2.0 from the truth" in status and "(truth" not in status
    # a bench's figures carry its results' truth version (results.json's "reference": the truth's meta)
    monkeypatch.setattr(calibration, "_bench_errors", lambda path: {k: (0.04, 0.01, "bench b", VERSION - 1) for k in keys})
    cal = fake_calibration("deon", s, errors=False)
    calibration.attach_errors(cal)
    assert "from the bench b (truth version" in calibration.stale_truth(cal)


def test_a_bench_s_figures_carry_the_truth_version_of_its_results(tmp_path):
    """_bench_errors reads the truth's version from the results' "reference" (engine/bench writes ref.meta)."""
    rung = ladder(with_values(Settings(), {"technique": "deon"}))[0]
    record = {"technique": "deon", "label": rung.label, "changes": dict(rung.changes), "rms": [0.25] * 3,
              "rms_u": [0.5] * 3}
    path = tmp_path / "results.json"
    path.write_text(json.dumps({"reference": {"version": 7}, "results": [record]}))
    got = calibration._bench_errors(path)
    assert got[rung_key("deon", Rung(rung.label, dict(rung.changes), 1.0))] == (0.25, 0.5, f"bench {path}", 7)


def test_a_cached_calibration_takes_the_error_table_s_newest_figures(cache, monkeypatch):
    """The costs in the cache are this machine's; the errors come from the table at load, so a rung
    whose figure was measured after the calibration (d'Eon's cheapest) shows it."""
    s = with_values(Settings(), {"technique": "deon"})
    cal = fake_calibration("deon", s, errors=False)
    cal.renderer = "GPU X"
    calibration.save(cal)
    keys = [e.key for e in cal.entries["deon"]]
    table = cache / "errors.json"
    table.write_text(json.dumps({"errors": {keys[0]: 0.177}, "uncertainty": {keys[0]: 0.019}}))
    monkeypatch.setattr(calibration, "ERRORS_TABLE", table)
    monkeypatch.setattr(calibration, "_bench_errors", lambda path: {})
    got, msg = calibration.load("GPU X", "small")
    assert got is not None and msg == ""
    assert got.entries["deon"][0].error == 0.177 and got.entries["deon"][0].uncertainty == 0.019
    assert all(e.error is None for e in got.entries["deon"][1:])


def test_set_render_governor_off_on_the_command_line():
    """`--set render.governor=off` (the parser reads off / on as false / true) means what it says."""
    from skinviewer.ground.settings import parse_value
    for text, want in (("off", "off"), ("on", "interactive"), ("fixed-budget", "fixed-budget")):
        assert with_values(Settings(), {"render.governor": parse_value(text)}).render.governor == want


def test_closing_the_viewer_stops_and_joins_a_background_calibration():
    """A calibration still measuring in its thread (its own GL context) when the window closes is
    cancelled and joined before the renderer goes: a thread left running GL at exit aborted the
    process ("terminate called without an active exception")."""
    import threading
    from types import SimpleNamespace

    from skinviewer.ui.frame import FrameController
    stop = threading.Event()
    worker = threading.Thread(target=lambda: stop.wait(30.0), daemon=True)
    worker.start()
    cal = SimpleNamespace(thread=worker, cancel=stop.set)
    cal.running = True
    order: list[str] = []
    stub = SimpleNamespace(calibrating=cal, collector=SimpleNamespace(release=lambda: None),
                           view=SimpleNamespace(release=lambda: order.append("view")),
                           renderer=SimpleNamespace(release=lambda: order.append(f"renderer {worker.is_alive()}")))
    FrameController.release(stub)
    assert not worker.is_alive() and order == ["view", "renderer False"]


def test_letting_go_abandons_the_drag_s_unfinished_preview_for_the_refinement():
    """The first still frame steps up at once, even when the drag's preview frame is part-way (the
    refinement redoes that work; finishing it cost a preview frame of release -> final); a refinement
    step's own unfinished frame is never left while still."""
    s = with_values(Settings(), {"technique": "deon"})
    cal = fake_calibration("deon", s, seed=3)
    g = Governor("interactive", 200.0, cal)
    first = g.rung_for(s, interacting=True, camera=False, last_complete=False)
    assert not first.final and g.refining
    step = g.rung_for(s, interacting=False, camera=False, last_complete=False)  # released, preview part-way
    assert step != first  # abandoned for the refinement's first step
    for _ in range(3):  # that step's frame is finished before the next
        assert g.rung_for(s, interacting=False, camera=False, last_complete=False) == step
    # and the same rule as before while the drag goes on: an interaction frame is the pick
    assert g.rung_for(s, interacting=True, camera=False, last_complete=False) == first


def test_a_drag_holds_full_garbage_collections_and_still_hands_them_back(viewer):
    """While the user drags, the frame loop collects only Python's young generations (a full
    collection took 33 ms of a drag's frame); once the view is still and final (for the collector's
    idle time: 0 here) the automatic collector is on again and the start-up objects are frozen
    (ui/collector.py)."""
    import gc
    app = viewer
    app.frame.collector.idle_s = 0.0
    _still(app)
    app.step(1)
    assert gc.isenabled() and app.frame.collector.frozen_for == app.renderer.scene.key
    full = app.frame.collector.collections.count(2)
    app.frame.set_dragging(True)
    try:
        for k in range(3):
            assert app.state.apply({"lights.0.direction": [0.2 + 0.05 * k, 0.3, 1.0]}, "lights.0 (key light drag)")
            app.step(1)
            assert not gc.isenabled() and app.frame.collector.held
        assert app.frame.collector.collections.count(2) == full  # no full collection during the drag
    finally:
        app.frame.set_dragging(False)
    _still(app)
    app.step(1)
    assert gc.isenabled() and not app.frame.collector.held


def test_a_released_drag_s_part_way_preview_leaves_no_stale_image(viewer):
    """Letting go while the drag's preview frame is part-way (bands under a small frame budget): the
    refinement starts at once, the preview's passes are not reported as the final frame's, and the
    refined image is the ungoverned render of the same settings bit for bit."""
    app = viewer
    _deon_preview_governed(app)
    app.frame.set_frame_budget(40.0)
    try:
        app.frame.set_dragging(True)
        part_way = False
        for k in range(400):
            assert app.state.apply({"lights.0.direction": [0.3 + 0.001 * k, 0.25, 1.0]}, "lights.0 (key light drag)")
            app.step(1)
            rep = app.frame.report
            if rep is not None and not rep.complete and app.frame._partial_ran:
                part_way = True
                break
        assert part_way, "no preview frame was left part-way: nothing was tested"
        preview = app.frame.governor.shown
        assert not preview.final
        app.frame.set_dragging(False)
        app.step(1)
        assert app.frame.governor.shown != preview  # abandoned, not finished
        rep = app.frame.report
        if rep is not None and not rep.complete:  # the preview's passes are not this frame's
            assert [id(p) for p in app.frame._partial_ran] == [id(p) for p in rep.passes if p.status == "ran"]
        _still(app, max_frames=2000)
    finally:
        app.frame.set_dragging(False)
        app.frame.set_frame_budget(100.0)
    live = app.state.settings
    got = app.renderer.image(live)
    app.renderer.render(live, force=True)
    assert np.array_equal(got, app.renderer.image(live))
