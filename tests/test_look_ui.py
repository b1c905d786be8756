"""The look-first panel: Look (technique, skin in the artist model, specular, translucency) on top,
Quality & cost next, engine internals under Advanced; one name per technique; a light shows only the
fields of its kind."""
from __future__ import annotations

import os

import numpy as np
import pytest

from skinviewer import techniques
from skinviewer.ground.settings import LightSettings, Settings, with_values

imgui_bundle = pytest.importorskip("imgui_bundle")  # the panel's modules import the viewer's imgui


def test_light_fields_follow_the_kind():
    from skinviewer.ui.sections.scene import LIGHT_SKIP
    fields = set(LightSettings.model_fields)
    assert set(LIGHT_SKIP) == set(LightSettings.model_fields["kind"].annotation.__args__)
    for skip in LIGHT_SKIP.values():
        assert set(skip) <= fields
    assert {"position", "beam_radius"} <= set(LIGHT_SKIP["directional"])
    assert "direction" in LIGHT_SKIP["point"] and "position" not in LIGHT_SKIP["point"]
    env = {"environment", "layout", "yaw", "sh_order", "occlusion", "ao_rays", "transfer_order"}  # an environment light's own fields
    assert set(LIGHT_SKIP["beam"]) == env  # a beam uses every analytic field
    assert env <= set(LIGHT_SKIP["directional"]) and env <= set(LIGHT_SKIP["point"])
    assert not env & set(LIGHT_SKIP["environment"]) and {"direction", "position"} <= set(LIGHT_SKIP["environment"])


def test_quality_and_look_tables_name_real_settings():
    from skinviewer.ui.sections.look import OWN_LOOK, QUALITY, SPECULAR, TRANSLUCENCY
    s = Settings()
    assert set(QUALITY) == set(techniques.names())
    for table in (OWN_LOOK, SPECULAR, TRANSLUCENCY):
        for group, fields in table.values():
            for f in fields:
                assert f in type(getattr(s, group)).model_fields, f"{group}.{f}"
    for groups in QUALITY.values():
        for group, fields in groups:
            for f in fields:
                assert f in type(getattr(s, group)).model_fields, f"{group}.{f}"


@pytest.fixture(scope="module")
def app():
    if not os.environ.get("DISPLAY"):
        pytest.skip("no DISPLAY")
    pytest.importorskip("imgui_bundle")
    from skinviewer.scene.scenes import scene_overrides
    from skinviewer.ui.app import create_app, destroy_app
    s = with_values(Settings(), {"scene.name": "shadow-edge", **scene_overrides("shadow-edge"),
                                 "shadow.map_size": 128, "deon.irradiance_size": 256, "deon.tsm_size": 128,
                                 "render.width": 96, "render.height": 96})
    try:
        a = create_app(s, size=(960, 600), vsync=False)
    except RuntimeError as exc:
        pytest.skip(f"cannot open a window: {exc}")
    a.frame.set_frame_budget(None)
    a.step(1)
    yield a
    destroy_app(a)


def test_look_section_drives_the_table_and_plots_it(app):
    from skinviewer.physics import artist
    from skinviewer.ui.panel import ADVANCED, SECTIONS, Panel
    from skinviewer.ui.sections.look import LookSection
    from skinviewer.ui.sections.shading import DeonSection
    panel = app.ui.window(Panel)
    assert SECTIONS[1] is LookSection and DeonSection in ADVANCED  # look first, the raw table under Advanced
    app.state.set_technique("deon")
    app.step(1)
    look = panel.section(LookSection)
    assert look.plot_rect is not None  # the live profile plot drew
    assert not panel.advanced_open  # Advanced starts collapsed
    # what the scatter radius widget sends: the look drives, the table follows
    assert app.state.apply({"look.scatter_color": [0.5, 0.3, 0.2], "look.scatter_radius": [3.0, 1.0, 0.5]}, "look")
    s = app.state.settings
    assert s.look.source == "look"
    v = np.array([g.variance for g in s.deon.gaussians])
    w = np.array([g.weights for g in s.deon.gaussians])
    np.testing.assert_allclose(artist.estimate_radius(v, w, (0.5, 0.3, 0.2)), (3.0, 1.0, 0.5), rtol=1e-5)
    app.step(1)
    assert app.frame.render_error in (None, "")
    # the raw table edited under Advanced takes over
    assert app.state.apply({"deon.gaussians.0.variance": 0.002}, "gaussians")
    assert app.state.settings.look.source == "table"


def test_ab_is_marked_on_the_image_and_in_the_readouts(app):
    from skinviewer.ui.compare_overlay import CompareOverlay
    from skinviewer.ui.status_bar import StatusBar
    st = app.state
    st.set_technique("phong")
    st.capture_slot("A")
    st.set_technique("deon")
    st.capture_slot("B")
    cmp = st.compare
    try:
        cmp.set_mode("split")
        app.step(1)
        tags = [t for t, _ in app.ui.window(CompareOverlay).tags]
        assert tags == ["A: phong (captured)", "B: deon (captured)"]
        (_, ra), (_, rb) = app.ui.window(CompareOverlay).tags
        assert ra[0] + ra[2] <= rb[0]  # A left of the divider, B right
        bar = " ".join(t for t, _ in app.ui.window(StatusBar).fields())
        assert "left A: phong" in bar and "right B: deon" in bar
        # toggle: the live state is deon (B's technique) while the view shows A: every readout says A
        cmp.set_mode("toggle")
        cmp.set_show_b(False)
        app.step(1)
        assert app.ui.window(CompareOverlay).tags[0][0].startswith("A: phong")
        assert "showing A: phong" in " ".join(t for t, _ in app.ui.window(StatusBar).fields())
        st.flip_compare()
        assert cmp.shown() == "showing B: deon (captured)"
        cmp.set_mode("off")
        app.step(1)
        assert app.ui.window(CompareOverlay).tags == []
        assert st.settings.technique in [t for t, _ in app.ui.window(StatusBar).fields()]
    finally:
        cmp.set_mode("off")


def test_save_as_asks_for_a_name_and_ctrl_s_then_saves_it(app, tmp_path, monkeypatch):
    import json
    monkeypatch.setenv("SKINVIEWER_USER_PRESETS", str(tmp_path / "user"))
    st = app.state
    p = st.presets
    p.set_path(None)
    try:
        assert st.apply({"render.exposure": 1.25})
        assert not st.save_preset()  # Ctrl+S with no named preset: asks, writes nothing
        assert p.naming and not (tmp_path / "user").exists()
        app.step(1)  # the popup draws
        assert st.save_preset_named("warm skin")
        target = tmp_path / "user" / "warm skin.json"
        assert target.is_file() and p.path == str(target) and not p.naming
        assert "camera" not in json.loads(target.read_text())  # cameras only when asked
        assert st.apply({"render.exposure": 1.5})
        assert st.save_preset()  # Ctrl+S: the named preset, no question
        assert json.loads(target.read_text())["render"]["exposure"] == 1.5
        st.request_save_as()  # Ctrl+Shift+S always asks, suggesting the current name
        assert p.naming and p.name_text == "warm skin"
        p.close_naming()
        assert not st.save_preset_named("   ") and st.message[1]
    finally:
        p.close_naming()
        p.set_path(None)


def test_camera_moves_are_not_unsaved_changes_unless_opted_in(app, tmp_path):
    import json
    st = app.state
    p = st.presets
    assert p.save(st.settings, str(tmp_path / "base.json"))
    try:
        assert st.apply({"camera.yaw": st.settings.camera.yaw + 40.0}, "camera (orbit)")
        assert not p.dirty(st.settings)
        p.set_track_camera(True)
        assert p.dirty(st.settings)
        assert p.save(st.settings, str(tmp_path / "with_camera.json"))
        assert "camera" in json.loads((tmp_path / "with_camera.json").read_text())
        p.set_track_camera(False)
        # a preset saved without a camera keeps the current view when loaded
        yaw = st.settings.camera.yaw
        assert st.load_preset(str(tmp_path / "base.json")) and st.settings.camera.yaw == yaw
    finally:
        p.set_track_camera(False)
        p.set_path(None)


def test_windows_fit_a_960x600_window_without_overlapping(app):
    from skinviewer.ui.passes_window import PassesWindow
    app.step(1)
    ww, wh = app.wnd.size
    assert (ww, wh) == (960, 600)
    px, _py, pw, _ph = app.ui.window(PassesWindow)._rect
    panel_w = app.state.view.panel_width
    # the accuracy window: the other window at the top of the 3D view
    ax, _ay, aw, _ah = next(r for r in app.ui.rects if r[0] > panel_w and r[1] < 40 and abs(r[0] - px) > 1)
    assert ax + aw <= px and px + pw <= ww  # side by side, their title bars apart, inside the window
