"""Issue 32: the default rig is the studio environment + a key light, at the exposure its luminance
calls for, the three-light rig a preset; the viewer opens on it without waiting for the bake."""
import json
import os
import threading
from pathlib import Path

import numpy as np
import pytest

from skinviewer.ground.settings import Settings, load_preset, three_light_rig, with_values
from skinviewer.passes.rules import environment_light

ROOT = Path(__file__).resolve().parents[1]


def test_the_default_scene_has_an_occluded_environment_and_a_key_light():
    s = Settings()
    hit = environment_light(s.lights)
    assert hit is not None and hit[1].environment == "studio" and hit[1].occlusion and hit[1].intensity > 0
    keys = [x for x in s.lights if x.kind == "directional" and x.enabled and x.intensity > 0]
    assert len(keys) == 1 and keys[0].cast_shadow
    from skinviewer.passes.environment import exposure_from_luminance
    assert exposure_from_luminance(s) == pytest.approx(s.render.exposure, rel=0.01)  # chosen from its luminance


def test_the_default_rig_is_the_studio_preset_scaled_to_the_default_exposure():
    """Same picture as presets/studio-environment.json: radiance x exposure agree within 1 %."""
    p = load_preset(ROOT / "presets" / "studio-environment.json")
    s = Settings()
    env_p, env_s = environment_light(p.lights)[1], environment_light(s.lights)[1]
    key_p = [x for x in p.lights if x.kind == "directional"][0]
    key_s = [x for x in s.lights if x.kind == "directional"][0]
    assert key_s.direction == key_p.direction and key_s.color == key_p.color
    for a, b in ((env_s, env_p), (key_s, key_p)):
        assert a.intensity * s.render.exposure == pytest.approx(b.intensity * p.render.exposure, rel=0.01)


def test_the_three_light_rig_is_a_preset():
    data = json.loads((ROOT / "presets" / "studio-three-lights.json").read_text())
    s = load_preset(ROOT / "presets" / "studio-three-lights.json")
    assert [x.model_dump() for x in s.lights] == [x.model_dump() for x in three_light_rig()]
    assert "render" not in data or "exposure" not in data["render"]  # the default 0.9 is its exposure
    assert environment_light(s.lights) is None


@pytest.mark.skipif(not os.environ.get("DISPLAY"), reason="needs a display (xvfb-run)")
def test_the_viewer_starts_without_waiting_for_the_bake(gl_ctx, monkeypatch, tmp_path):
    """The bake is held until the first frames are drawn: a viewer that waited would hang here.
    The status bar says so; once the bake is in, the view is the waited render's image."""
    pytest.importorskip("imgui_bundle")
    from skinviewer.engine.renderer import Renderer
    from skinviewer.physics import environment as env
    from skinviewer.ui.app import WindowUnavailableError, create_app, destroy_app
    from skinviewer.ui.status_bar import StatusBar
    monkeypatch.setenv("SKINVIEWER_CACHE", str(tmp_path))
    gate = threading.Event()
    real = env.bake_transfer

    def gated(*a, **kw):
        assert gate.wait(120)
        return real(*a, **kw)

    monkeypatch.setattr(env, "bake_transfer", gated)
    s = with_values(Settings(), {"scene.head_detail": 0, "technique": "phong", "render.governor": "off",
                                 "lights.1.ao_rays": 12})  # 12 rays: a bake no other test caches
    try:
        app = create_app(s, size=(360, 240), vsync=False)
    except WindowUnavailableError as exc:
        pytest.skip(f"cannot open a window: {exc}")
    try:
        app.frame.set_frame_budget(None)
        app.step(2)
        assert app.frame.report is not None and app.frame.report.complete  # an image without the bake
        text = " | ".join(t for t, _ in app.ui.window(StatusBar).fields())
        assert "baking environment visibility" in text, text
        gate.set()
        assert app.renderer.scene.gpu.env_wait(120)
        app.step(2)
        text = " | ".join(t for t, _ in app.ui.window(StatusBar).fields())
        assert "baking environment" not in text, text
        shown = app.state.settings
        got = app.renderer.image(shown)
    finally:
        destroy_app(app)
    gl_ctx.__enter__()
    r = Renderer(gl_ctx)  # the CLI's way, from the disk cache the viewer's bake wrote
    try:
        r.render(shown)
        assert np.array_equal(r.image(shown), got)
    finally:
        r.release()


def test_the_prefiltered_environment_comes_from_the_disk_cache(monkeypatch, tmp_path):
    """The default rig's first frame does not pre-filter the studio again at every start (seconds)."""
    from skinviewer.passes import environment as penv
    from skinviewer.physics import environment as env
    monkeypatch.setenv("SKINVIEWER_CACHE", str(tmp_path))
    penv._prefiltered.cache_clear()
    first = penv._prefiltered("studio", "auto")
    from skinviewer.scene.environment import environment_image
    assert np.array_equal(first[..., :3], env.prefilter_specular(environment_image("studio", "auto")))
    penv._prefiltered.cache_clear()

    def no(*a, **kw):
        raise AssertionError("pre-filtered again")

    monkeypatch.setattr(env, "prefilter_specular", no)
    again = penv._prefiltered("studio", "auto")
    assert np.array_equal(first, again)
    penv._prefiltered.cache_clear()


def test_a_light_orbit_turns_the_default_environment_with_the_key():
    """skinviewer turntable --light-orbit: the environment's yaw turns in the key light's sense (the
    brightest SH irradiance direction follows the key's rotation)."""
    import math

    from skinviewer.cli import turntable as tt
    from skinviewer.physics import environment as env
    from skinviewer.scene.environment import environment_image
    s = Settings()
    frames = tt.orbit(s, 4, light_orbit=True)
    assert [f.lights[1].yaw - s.lights[1].yaw for f in frames] == [0, 90, 180, 270]
    n = np.random.default_rng(0).normal(size=(4000, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    img = environment_image("studio", "auto")

    def brightest(yaw):
        E = env.sh_irradiance(env.sh_irradiance_coefficients(env.sh_project(img, yaw)), n).mean(1)
        return n[np.argmax(E)]

    x, y, z = brightest(0.0)
    c, sn = math.cos(math.radians(90)), math.sin(math.radians(90))
    assert np.dot(brightest(90.0), [c * x + sn * z, y, -sn * x + c * z]) > 0.99
