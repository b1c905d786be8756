"""The interactive viewer, under a real (Xvfb) display. Most tests drive one in-process app
(skinviewer.app.create_app) with a small window; one runs the CLI as a subprocess."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest

pytestmark = pytest.mark.viewer

W, H = 320, 240
SCENE = "shadow-edge"


@pytest.fixture(scope="session")
def display():
    # conftest.py starts a private Xvfb when there is no display (and xvfb is installed)
    if not os.environ.get("DISPLAY"):
        pytest.skip("no DISPLAY and no Xvfb: install xvfb (apt-get install xvfb) to run the viewer tests")
    return os.environ["DISPLAY"]


@pytest.fixture(scope="module")
def shader_dir(tmp_path_factory):
    from skinviewer import paths
    src = paths.shaders_dir()
    dst = tmp_path_factory.mktemp("shaders") / "shaders"
    shutil.copytree(src, dst)
    old = os.environ.get("SKINVIEWER_SHADERS")
    os.environ["SKINVIEWER_SHADERS"] = str(dst)
    yield dst
    if old is None:
        os.environ.pop("SKINVIEWER_SHADERS", None)
    else:
        os.environ["SKINVIEWER_SHADERS"] = old


@pytest.fixture(scope="module")
def app(display, shader_dir):
    pytest.importorskip("imgui_bundle")
    from skinviewer.app import create_app, destroy_app
    from skinviewer.scenes import scene_overrides
    from skinviewer.settings import Settings, with_values
    s = with_values(Settings(), {"scene.name": SCENE, **scene_overrides(SCENE), "shadow.map_size": 256,
                                 "gosselin.light_map_size": 256, "deon.irradiance_size": 256, "deon.tsm_size": 256})
    try:
        a = create_app(s, size=(W, H), vsync=False)
    except RuntimeError as exc:
        pytest.skip(f"cannot open a window: {exc}")
    assert str(a.shaders.root) == str(shader_dir)
    a.step(2)
    yield a
    destroy_app(a)


def _screen(app) -> np.ndarray:
    from skinviewer.ui.screenshot import read_screen
    return read_screen(app.ctx, (app.settings.render.width, app.settings.render.height)).astype(np.float32)


def _view_image(app) -> np.ndarray:
    return app.renderer.image(app.settings).astype(np.float32)


def _drag(app, x0, y0, dx, dy, button):
    app.on_mouse_position_event(x0, y0, 0, 0)
    app.on_mouse_press_event(x0, y0, button)
    steps = 4
    for k in range(1, steps + 1):
        app.on_mouse_drag_event(x0 + dx * k / steps, y0 + dy * k / steps, dx / steps, dy / steps)
    app.on_mouse_release_event(x0 + dx, y0 + dy, button)


def test_cli_frames_screenshot_exits_with_image(display, tmp_path):
    out = tmp_path / "shot.png"
    env = dict(os.environ, DISPLAY=display)
    cmd = [sys.executable, "-m", "skinviewer.cli", "--scene", SCENE, "--size", f"{W}x{H}",
           "--set", "shadow.map_size=256", "--set", "gosselin.light_map_size=256",
           "--set", "deon.irradiance_size=256", "--set", "deon.tsm_size=256",
           "--frames", "2", "--screenshot", str(out)]
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    from PIL import Image
    img = np.asarray(Image.open(out)).astype(np.float32)
    assert img.shape[:2] == (H, W)
    assert img.std() > 10, "screenshot is a uniform background"


def test_window_renders_subject_and_ui(app):
    from skinviewer.ui import panel
    assert app.report is not None and not app.render_error
    img = _view_image(app)
    assert img.shape == (H, W, 3) and img.std() > 10
    panel.EXPAND_ALL["on"] = True  # draw every section and widget once: no imgui misuse anywhere
    try:
        app.step(2)
    finally:
        panel.EXPAND_ALL["on"] = False
    assert "UI:" not in app.render_error


def test_orbit_changes_image_texture_space_cached(app):
    g = app.renderer.graph(app.settings.technique)
    app.step(1)
    before = _view_image(app)
    yaw0 = app.settings.camera.yaw
    _drag(app, W - 40, H - 40, 30, 10, app.wnd.mouse.left)
    assert app.settings.camera.yaw != yaw0
    app.step(1)
    rep = app.report
    after = _view_image(app)
    assert np.abs(after - before).mean() > 0.5
    view_dep = {p.name for p in g.passes if p.view_dependent}
    assert set(rep.ran) <= view_dep | {"output"}, rep.table()
    assert set(rep.ran) & view_dep
    texture_space = [p.name for p in g.passes if not p.view_dependent and p.name != "output"]
    assert all(rep.passes[[q.name for q in rep.passes].index(n)].status in ("cached", "pruned")
               for n in texture_space), rep.table()
    # wheel zoom, middle-drag pan, right-drag key light, R reset
    d0 = app.settings.camera.distance
    app.on_mouse_position_event(W - 40, H - 40, 0, 0)
    app.on_mouse_scroll_event(0, 1)
    assert app.settings.camera.distance != d0
    _drag(app, W - 40, H - 40, 10, 5, app.wnd.mouse.middle)
    assert app.settings.camera.target is not None
    dir0 = app.settings.lights[0].direction
    _drag(app, W - 40, H - 40, 25, 0, app.wnd.mouse.right)
    assert app.settings.lights[0].direction != dir0
    app.on_key_event(app.wnd.keys.R, app.wnd.keys.ACTION_PRESS, app.wnd.modifiers)
    assert app.settings.camera.model_dump(mode="json") == app.home_camera
    app.step(1)


def test_drag_over_panel_does_not_orbit(app):
    app.step(1)
    yaw0 = app.settings.camera.yaw
    _drag(app, 20, 120, 40, 0, app.wnd.mouse.left)  # on the settings panel
    assert app.settings.camera.yaw == yaw0


def test_switch_technique_changes_image(app):
    from skinviewer import techniques
    names = techniques.names()
    other = next(t for t in names if t != "phong") if len(names) > 1 else None
    if other is None:
        pytest.skip("only one technique available")
    assert app.set_technique("phong")
    app.step(1)
    phong = _view_image(app)
    assert app.set_technique(other)
    app.step(1)
    img = _view_image(app)
    assert np.abs(img - phong).mean() > 0.5
    assert app.set_technique("phong")
    app.step(1)
    assert app.report.ran == [], "switching back should find the phong graph cached"
    assert not app.set_technique("nonexistent-technique") and app.errors


def test_broken_preset_refused_state_kept(app, tmp_path):
    from skinviewer.settings import to_dict
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"schema_version": 1, "lights": [{"intensity": -3}], "render": {"exposure": 0},
                               "nonsense": 1}))
    before = to_dict(app.settings)
    assert not app.load_preset(str(bad))
    assert app.presets.errors and any("intensity" in p for p, _ in app.presets.errors)
    assert to_dict(app.settings) == before
    broken = tmp_path / "broken.json"
    broken.write_text("{ not json")
    assert not app.load_preset(str(broken)) and app.presets.errors[0][0] == "<json>"
    assert to_dict(app.settings) == before
    app.step(1)  # the panel draws the errors without crashing
    # a good preset round-trips; the unsaved marker follows edits
    good = tmp_path / "good.json"
    assert app.presets.save(app.settings, str(good))
    assert not app.presets.dirty(app.settings)
    assert app.apply({"render.exposure": 1.7})
    assert app.presets.dirty(app.settings)
    assert app.load_preset(str(good)) and not app.presets.dirty(app.settings)
    # an invalid edit shows a message and keeps the state
    assert not app.apply({"shadow.pcf": 99}) and app.errors[0][0].startswith("shadow.pcf")
    app.step(1)


def test_shader_error_keeps_rendering_and_recovers(app, shader_dir):
    frag = shader_dir / "output.frag"
    good = frag.read_text()
    app.step(1)
    try:
        frag.write_text(good.replace("void main", "this is not glsl;\nvoid main", 1))
        deadline = time.time() + 5
        while not app.watcher.errors and time.time() < deadline:
            time.sleep(0.2)
            app.step(1)
        errs = [e for es in app.watcher.errors.values() for e in es]
        assert errs, "the broken shader was not reported"
        assert any(e.file.endswith("output.frag") and e.line > 0 for e in errs), errs
        assert app.report is not None and not app.render_error
        assert _view_image(app).std() > 10  # last good program still renders
    finally:
        # fixed, and different from the running program (identical source would need no re-run)
        frag.write_text(good + "\n// fixed\n")
        st = frag.stat()
        os.utime(frag, ns=(st.st_atime_ns, st.st_mtime_ns + 2_000_000_000))
    deadline = time.time() + 5
    ran_output = False
    while time.time() < deadline:
        time.sleep(0.2)
        app.step(1)
        ran_output |= "output" in app.report.ran
        if not app.watcher.errors and ran_output:
            break
    assert not app.watcher.errors
    assert ran_output, "the fixed program did not re-run its pass"


def test_screenshots_written_where_asked(app, tmp_path):
    from PIL import Image
    app.shot_options.folder = str(tmp_path / "shots")
    app.shot_options.save_linear_npy = True
    p = app.request_screenshot()
    app.step(1)
    assert p.exists() and p.parent == tmp_path / "shots"
    img = np.asarray(Image.open(p))
    assert img.shape == (H, W, 3) and img.std() > 10
    lin = np.load(p.with_suffix(".npy"))
    assert lin.dtype == np.float32 and lin.shape[:2] == (H, W)
    app.shot_options.save_linear_npy = False
    n = len(list((tmp_path / "shots").glob("*.png")))
    app.on_key_event(app.wnd.keys.F12, app.wnd.keys.ACTION_PRESS, app.wnd.modifiers)
    app.step(1)
    assert len(list((tmp_path / "shots").glob("*.png"))) == n + 1
    q = app.request_screenshot(tmp_path / "with_ui.png", include_ui=True)
    app.step(1)
    assert q.exists()


def test_ab_compare_split_and_pass_inspector(app):
    cmp = app.compare
    cmp.a.settings = app.settings
    assert app.apply({"render.exposure": 4.0})
    cmp.b.settings = app.settings
    cmp.mode = "split"
    cmp.divider = 0.5
    app.show_ui = False
    try:
        app.step(1)
        scr = _screen(app)
        assert not cmp.a.error and not cmp.b.error
        left, right = scr[:, : W // 2 - 2], scr[:, W // 2 + 2:]
        # B (brighter exposure) on the right: the right half is brighter than a plain A frame's right half
        cmp.mode = "off"
        assert app.apply({"render.exposure": 1.0})  # back to A's state
        app.step(1)
        plain = _screen(app)[:, W // 2 + 2:]
        assert right.mean() > plain.mean() + 1.0
        assert np.abs(left - _screen(app)[:, : W // 2 - 2]).mean() < 1.0  # A on the left
        cmp.mode = "difference"
        app.step(1)
        assert _screen(app).std() > 1.0
        # inspector: a pass output full-window
        cmp.mode = "off"
        app.inspect = "shadow_map_0" if "shadow_map_0" in app.renderer.graph(app.settings.technique).resources() else "image"
        app.inspect_channel = "R"
        app.step(1)
        assert not app.render_error
    finally:
        app.inspect = None
        cmp.mode = "off"
        app.show_ui = True
        app.apply({"render.exposure": 1.0})


def test_resize_follows_framebuffer(app):
    import glfw
    w0, h0 = app.wnd.buffer_size
    app.wnd.size = (W + 64, H + 32)
    deadline = time.time() + 5
    while tuple(app.wnd.buffer_size) == (w0, h0) and time.time() < deadline:
        glfw.poll_events()
        time.sleep(0.05)
    app.step(1)
    fw, fh = app.wnd.buffer_size
    try:
        if (fw, fh) == (w0, h0):
            pytest.skip("the X server did not resize the window")
        assert (app.settings.render.width, app.settings.render.height) == (fw, fh)
        assert _view_image(app).shape == (fh, fw, 3)
        assert not app.render_error
    finally:
        app.wnd.size = (W, H)
        deadline = time.time() + 5
        while tuple(app.wnd.buffer_size) != (w0, h0) and time.time() < deadline:
            glfw.poll_events()
            time.sleep(0.05)
        app.step(1)


def test_profile_lab_fit_applies_to_deon_gaussians(app):
    lab = app.panel.lab
    if lab is None:
        pytest.skip("skinviewer.profiles / skinviewer.fitting not available")
    old = app.settings.deon.gaussians
    lab.k = 3
    lab.start_fit(wait=True)
    assert not lab.fit_error and lab.fit is not None
    try:
        assert lab.apply()
        gs = app.settings.deon.gaussians
        assert len(gs) == 3 and all(g.variance > 0 for g in gs)
        app.step(1)
        assert not app.render_error
    finally:
        app.apply({"deon.gaussians": [g.model_dump(mode="json") for g in old]})
