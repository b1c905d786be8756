"""The look-first panel: Look (technique, skin in the artist model, specular, translucency) on top,
Quality & cost next, engine internals under Advanced; one name per technique; a light shows only the
fields of its kind."""
from __future__ import annotations

import os

import numpy as np
import pytest

from skinviewer import techniques
from skinviewer.core.settings import LightSettings, Settings, with_values


def test_light_fields_follow_the_kind():
    from skinviewer.ui.sections.scene import LIGHT_SKIP
    fields = set(LightSettings.model_fields)
    assert set(LIGHT_SKIP) == set(LightSettings.model_fields["kind"].annotation.__args__)
    for kind, skip in LIGHT_SKIP.items():
        assert set(skip) <= fields
    assert {"position", "beam_radius"} <= set(LIGHT_SKIP["directional"])
    assert "direction" in LIGHT_SKIP["point"] and "position" not in LIGHT_SKIP["point"]
    assert LIGHT_SKIP["beam"] == ()


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
