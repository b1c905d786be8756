"""The interactive viewer, under a real (Xvfb) display. Most tests drive one in-process app
(skinviewer.ui.app.create_app) with a small window; one runs the CLI as a subprocess."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from helpers import settings_fields

pytestmark = pytest.mark.viewer

W, H = 560, 360
SCENE = "shadow-edge"


@pytest.fixture(scope="session")
def display():
    # conftest.py starts a private Xvfb when there is no display (and xvfb is installed)
    if not os.environ.get("DISPLAY"):
        pytest.skip("no DISPLAY and no Xvfb: install xvfb (apt-get install xvfb) to run the viewer tests")
    return os.environ["DISPLAY"]


@pytest.fixture(scope="module")
def shader_dir(tmp_path_factory):
    from skinviewer.ground import paths
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
def user_presets(tmp_path_factory):
    """Presets the viewer saves without a path go to a private user folder, never ~/.config."""
    d = tmp_path_factory.mktemp("user_presets")
    old = os.environ.get("SKINVIEWER_USER_PRESETS")
    os.environ["SKINVIEWER_USER_PRESETS"] = str(d)
    yield d
    if old is None:
        os.environ.pop("SKINVIEWER_USER_PRESETS", None)
    else:
        os.environ["SKINVIEWER_USER_PRESETS"] = old


@pytest.fixture(scope="module")
def app(display, shader_dir, user_presets):
    pytest.importorskip("imgui_bundle")
    from skinviewer.ground.settings import Settings, with_values
    from skinviewer.scene.scenes import scene_overrides
    from skinviewer.ui.app import create_app, destroy_app
    s = with_values(Settings(), {"scene.name": SCENE, **scene_overrides(SCENE), "shadow.map_size": 256,
                                 "gosselin.light_map_size": 256, "deon.irradiance_size": 256, "deon.tsm_size": 256})
    from skinviewer.ui.app import WindowUnavailableError
    try:
        a = create_app(s, size=(W, H), vsync=False)
    except WindowUnavailableError as exc:  # no window at all (display or GL driver); a start-up bug fails
        pytest.skip(f"cannot open a window: {exc}")
    a.frame.set_frame_budget(None)  # one complete frame per step (spreading is tested on its own)
    assert str(a.shaders.root) == str(shader_dir)
    a.step(2)
    yield a
    destroy_app(a)


def _screen(app) -> np.ndarray:
    from skinviewer.ui.screenshot import read_screen
    return read_screen(app.ctx, (app.state.settings.render.width, app.state.settings.render.height)).astype(np.float32)


def _screen_view(app) -> np.ndarray:
    """The 3D view region of the window's back buffer."""
    from skinviewer.ui.screenshot import read_screen
    fb = app.frame.layout.view_fb
    return read_screen(app.ctx, fb[2:], origin=fb[:2]).astype(np.float32)


def _view_image(app) -> np.ndarray:
    return app.renderer.image(app.state.settings).astype(np.float32)


def _view_hw(app) -> tuple[int, int]:
    """(height, width) of the 3D view region in framebuffer pixels."""
    return app.frame.layout.view_fb[3], app.frame.layout.view_fb[2]


def _key(app, key, ctrl=False):
    from moderngl_window.context.base.keys import KeyModifiers
    mods = KeyModifiers()
    mods.ctrl = ctrl
    app.on_key_event(key, app.wnd.keys.ACTION_PRESS, mods)
    app.on_key_event(key, app.wnd.keys.ACTION_RELEASE, mods)


def _settle(app, max_frames: int = 30) -> None:
    """Step until imgui has consumed the queued input: its event queue spreads a drag's press, moves
    and release over several frames, and until then the widget it hit holds the keyboard."""
    from imgui_bundle import imgui
    for _ in range(max_frames):
        app.step(1)
        if not imgui.get_io().want_capture_keyboard and not imgui.internal.get_active_id():
            return


def _in_view(app) -> tuple[float, float]:
    vx, vy, vw, vh = app.frame.layout.view
    return vx + vw * 0.7, vy + vh * 0.6


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
    assert app.frame.report is not None and not app.frame.render_error
    img = _view_image(app)
    assert img.shape == (*_view_hw(app), 3) and img.std() > 10
    app.state.set_expand_all(True)  # draw every section and widget once: no imgui misuse anywhere
    try:
        app.step(2)
    finally:
        app.state.set_expand_all(False)
    assert "UI:" not in app.frame.render_error


def test_orbit_changes_image_texture_space_cached(app):
    g = app.renderer.graph(app.state.settings.technique)
    app.step(1)
    before = _view_image(app)
    yaw0 = app.state.settings.camera.yaw
    _drag(app, W - 40, H - 40, 30, 10, app.wnd.mouse.left)
    assert app.state.settings.camera.yaw != yaw0
    app.step(1)
    rep = app.frame.report
    after = _view_image(app)
    assert np.abs(after - before).mean() > 0.5
    view_dep = {p.name for p in g.passes if p.view_dependent}
    assert set(rep.ran) <= view_dep | {"output"}, rep.table()
    assert set(rep.ran) & view_dep
    texture_space = [p.name for p in g.passes if not p.view_dependent and p.name != "output"]
    assert all(rep.passes[[q.name for q in rep.passes].index(n)].status in ("cached", "pruned")
               for n in texture_space), rep.table()
    # wheel zoom, middle-drag pan, right-drag key light, R reset
    d0 = app.state.settings.camera.distance
    app.on_mouse_position_event(W - 40, H - 40, 0, 0)
    app.on_mouse_scroll_event(0, 1)
    assert app.state.settings.camera.distance != d0
    _drag(app, W - 40, H - 40, 10, 5, app.wnd.mouse.middle)
    assert app.state.settings.camera.target is not None
    dir0 = app.state.settings.lights[0].direction
    _drag(app, W - 40, H - 40, 25, 0, app.wnd.mouse.right)
    assert app.state.settings.lights[0].direction != dir0
    app.on_key_event(app.wnd.keys.R, app.wnd.keys.ACTION_PRESS, app.wnd.modifiers)
    assert app.state.settings.camera.model_dump(mode="json") == app.state.home_camera
    app.step(1)


def test_drag_over_panel_does_not_orbit(app):
    app.step(1)
    yaw0 = app.state.settings.camera.yaw
    _drag(app, 20, 120, 40, 0, app.wnd.mouse.left)  # on the settings panel
    assert app.state.settings.camera.yaw == yaw0


def test_switch_technique_changes_image(app):
    from skinviewer import techniques
    names = techniques.names()
    other = next(t for t in names if t != "phong")
    assert app.state.set_technique("phong")
    app.step(1)
    phong = _view_image(app)
    assert app.state.set_technique(other)
    app.step(1)
    img = _view_image(app)
    assert np.abs(img - phong).mean() > 0.5
    assert app.state.set_technique("phong")
    app.step(1)
    assert app.frame.report.ran == [], "switching back should find the phong graph cached"
    assert not app.state.set_technique("nonexistent-technique") and app.state.errors


def test_broken_preset_refused_state_kept(app, tmp_path):
    from skinviewer.ground.settings import to_dict
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"schema_version": 1, "lights": [{"intensity": -3}], "render": {"exposure": 0},
                               "nonsense": 1}))
    before = to_dict(app.state.settings)
    assert not app.state.load_preset(str(bad))
    assert app.state.presets.errors and any("intensity" in p for p, _ in app.state.presets.errors)
    assert to_dict(app.state.settings) == before
    broken = tmp_path / "broken.json"
    broken.write_text("{ not json")
    assert not app.state.load_preset(str(broken)) and app.state.presets.errors[0][0] == "<json>"
    assert to_dict(app.state.settings) == before
    app.step(1)  # the panel draws the errors without crashing
    # a good preset round-trips; the unsaved marker follows edits
    good = tmp_path / "good.json"
    assert app.state.presets.save(app.state.settings, str(good))
    assert not app.state.presets.dirty(app.state.settings)
    assert app.state.apply({"render.exposure": 1.7})
    assert app.state.presets.dirty(app.state.settings)
    assert app.state.load_preset(str(good)) and not app.state.presets.dirty(app.state.settings)
    # an invalid edit shows a message and keeps the state
    assert not app.state.apply({"shadow.pcf": 99}) and app.state.errors[0][0].startswith("shadow.pcf")
    app.step(1)


def test_shader_error_keeps_rendering_and_recovers(app, shader_dir):
    frag = shader_dir / "output.frag"
    good = frag.read_text()
    app.step(1)
    try:
        frag.write_text(good.replace("void main", "this is not glsl;\nvoid main", 1))
        deadline = time.monotonic() + 5
        while not app.frame.watcher.errors and time.monotonic() < deadline:
            time.sleep(0.2)
            app.step(1)
        errs = [e for es in app.frame.watcher.errors.values() for e in es]
        assert errs, "the broken shader was not reported"
        assert any(e.file.endswith("output.frag") and e.line > 0 for e in errs), errs
        assert app.frame.report is not None and not app.frame.render_error
        assert _view_image(app).std() > 10  # last good program still renders
    finally:
        # fixed, and different from the running program (identical source would need no re-run)
        frag.write_text(good + "\n// fixed\n")
        st = frag.stat()
        os.utime(frag, ns=(st.st_atime_ns, st.st_mtime_ns + 2_000_000_000))
    deadline = time.monotonic() + 5
    ran_output = False
    while time.monotonic() < deadline:
        time.sleep(0.2)
        app.step(1)
        ran_output |= "output" in app.frame.report.ran
        if not app.frame.watcher.errors and ran_output:
            break
    assert not app.frame.watcher.errors
    assert ran_output, "the fixed program did not re-run its pass"


def test_screenshots_written_where_asked(app, tmp_path):
    from PIL import Image
    app.state.set_screenshot_options(folder=str(tmp_path / "shots"))
    app.state.set_screenshot_options(save_linear_npy=True, save_linear_exr=True)
    p = app.frame.request_screenshot()
    app.step(1)
    assert p.exists() and p.parent == tmp_path / "shots"
    img = np.asarray(Image.open(p))
    assert img.shape == (*_view_hw(app), 3) and img.std() > 10  # the 3D view region, no panel
    lin = np.load(p.with_suffix(".npy"))
    assert lin.dtype == np.float32 and lin.shape[:2] == _view_hw(app)
    from skinviewer.ground.files import load_exr
    assert np.array_equal(load_exr(p.with_suffix(".exr")), lin)  # the same linear image, as OpenEXR
    app.state.set_screenshot_options(save_linear_npy=False, save_linear_exr=False)
    n = len(list((tmp_path / "shots").glob("*.png")))
    app.on_key_event(app.wnd.keys.F12, app.wnd.keys.ACTION_PRESS, app.wnd.modifiers)
    app.step(1)
    assert len(list((tmp_path / "shots").glob("*.png"))) == n + 1
    q = app.frame.request_screenshot(tmp_path / "with_ui.png", include_ui=True)
    app.step(1)
    fw, fh = app.wnd.buffer_size
    assert np.asarray(Image.open(q)).shape == (fh, fw, 3)  # with UI: the whole window


def test_ab_compare_split_and_pass_inspector(app):
    cmp = app.state.compare
    exposure_a = app.state.settings.render.exposure
    app.state.capture_slot("A")
    assert app.state.apply({"render.exposure": 4.0})
    app.state.capture_slot("B")
    cmp.set_mode("split")
    cmp.set_divider(0.5)
    app.state.set_show_ui(False)
    try:
        app.step(1)
        scr = _screen(app)
        assert not cmp.a.error and not cmp.b.error
        left, right = scr[:, : W // 2 - 2], scr[:, W // 2 + 2:]
        # B (brighter exposure) on the right: the right half is brighter than a plain A frame's right half
        cmp.set_mode("off")
        assert app.state.apply({"render.exposure": exposure_a})  # back to A's state
        app.step(1)
        plain = _screen(app)[:, W // 2 + 2:]
        assert right.mean() > plain.mean() + 1.0
        assert np.abs(left - _screen(app)[:, : W // 2 - 2]).mean() < 1.0  # A on the left
        cmp.set_mode("difference")
        app.step(1)
        assert _screen(app).std() > 1.0
        # inspector: a pass output full-window
        cmp.set_mode("off")
        app.state.set_inspect("shadow_map_0" if "shadow_map_0" in app.renderer.graph(app.state.settings.technique).resources() else "image")
        app.state.set_inspect_channel("R")
        app.step(1)
        assert not app.frame.render_error
    finally:
        app.state.set_inspect(None)
        cmp.set_mode("off")
        app.state.set_show_ui(True)
        app.state.apply({"render.exposure": 1.0})


def test_resize_follows_framebuffer(app):
    import glfw
    w0, h0 = app.wnd.buffer_size
    app.wnd.size = (W + 64, H + 32)
    deadline = time.monotonic() + 5
    while tuple(app.wnd.buffer_size) == (w0, h0) and time.monotonic() < deadline:
        glfw.poll_events()
        time.sleep(0.05)
    app.step(1)
    fw, fh = app.wnd.buffer_size
    try:
        if (fw, fh) == (w0, h0):
            pytest.skip("the X server did not resize the window")
        vx, vy, vw, vh = app.frame.layout.view_fb
        assert (app.state.settings.render.width, app.state.settings.render.height) == (vw, vh)
        assert vw == fw - round(app.frame.layout.panel[2] * fw / app.wnd.size[0])
        assert _view_image(app).shape == (vh, vw, 3)
        assert not app.frame.render_error
    finally:
        app.wnd.size = (W, H)
        deadline = time.monotonic() + 5
        while tuple(app.wnd.buffer_size) != (w0, h0) and time.monotonic() < deadline:
            glfw.poll_events()
            time.sleep(0.05)
        app.step(1)


def test_profile_lab_fit_applies_to_deon_gaussians(app):
    from skinviewer.ui.panel import Panel
    lab = app.ui.window(Panel).lab
    assert lab is not None, "the profile lab did not start (skinviewer.physics.profiles / fitting)"
    old = app.state.settings.deon.gaussians
    lab.k = 3
    lab.start_fit(wait=True)
    assert not lab.fit_error and lab.fit is not None
    try:
        assert lab.apply()
        gs = app.state.settings.deon.gaussians
        assert len(gs) == 3 and all(g.variance > 0 for g in gs)
        app.step(1)
        assert not app.frame.render_error
    finally:
        app.state.apply({"deon.gaussians": [g.model_dump(mode="json") for g in old]})


# -- layout, input regions, shortcuts, scheduling ---------------------------------------------------

def test_layout_pure_hidpi_and_sides():
    from skinviewer.ui.layout import compute_layout
    lo = compute_layout((1000, 700), (2000, 1400), True, 300.0, "left", status_h=20.0)
    assert lo.panel == (0.0, 0.0, 300.0, 680.0) and lo.view == (300.0, 0.0, 700.0, 680.0)
    assert lo.view_fb == (600, 40, 1400, 1360)  # framebuffer pixels, bottom-left origin (HiDPI x2)
    assert lo.in_view(500, 100) and not lo.in_view(100, 100) and not lo.in_view(500, 690)
    r = compute_layout((1000, 700), (1000, 700), True, 300.0, "right", status_h=20.0)
    assert r.panel[0] == 700.0 and r.view_fb == (0, 20, 700, 680)
    assert compute_layout((1000, 700), (1000, 700), True, 5000.0).panel[2] == 500.0  # at most half
    hidden = compute_layout((1000, 700), (2000, 1400), False, 300.0)
    assert hidden.view_fb == (0, 0, 2000, 1400) and hidden.panel is None


def test_view_region_excludes_panel(app):
    app.step(1)
    lo = app.frame.layout
    fw, fh = app.wnd.buffer_size
    sx, sy = lo.scale
    panel_fb, status_fb = round(lo.panel[2] * sx), round(lo.status[3] * sy)
    assert panel_fb > 0 and status_fb > 0
    assert _view_image(app).shape == (fh - status_fb, fw - panel_fb, 3)
    assert (app.state.settings.render.width, app.state.settings.render.height) == (fw - panel_fb, fh - status_fb)
    # the user widens the panel by dragging its edge: the view (and the render size) shrink
    app.state.set_panel_width(W * 0.45)  # the narrowest this window allows
    app.step(1)
    pw0 = app.frame.layout.panel[2]
    x0 = pw0 - 1
    w0 = app.state.settings.render.width
    app.on_mouse_position_event(x0, 150, 0, 0)
    app.step(1)
    app.on_mouse_press_event(x0, 150, app.wnd.mouse.left)
    app.step(1)
    for k in range(1, 5):
        app.on_mouse_drag_event(x0 + 5 * k, 150, 5, 0)
        app.step(1)
    app.on_mouse_release_event(x0 + 20, 150, app.wnd.mouse.left)
    app.step(1)
    try:
        assert app.state.view.panel_width > pw0 + 10, "dragging the panel edge did not resize it"
        assert app.state.settings.render.width < w0 and _view_image(app).shape[1] == app.state.settings.render.width
    finally:
        app.state.set_panel_width(lo.panel[2])
        app.step(1)
    # F1 hides the UI: the view fills the window
    _key(app, app.wnd.keys.F1)
    app.step(1)
    try:
        assert not app.state.view.show_ui and _view_image(app).shape == (fh, fw, 3)
    finally:
        _key(app, app.wnd.keys.F1)
        app.step(1)
    assert app.state.view.show_ui


def test_orbit_and_zoom_only_in_view_region(app):
    app.step(1)
    cam0 = app.state.settings.camera.model_dump(mode="json")
    sx, sy, sw, sh = app.frame.layout.status
    _drag(app, sx + sw - 30, sy + sh / 2, 40, -5, app.wnd.mouse.left)  # on the status bar, under the view
    px, py, pw, ph = app.frame.layout.panel
    _drag(app, px + pw - 12, py + ph - 30, -30, 0, app.wnd.mouse.left)  # on the panel
    app.on_mouse_position_event(px + 20, py + 40, 0, 0)
    app.on_mouse_scroll_event(0, 2)  # wheel over the panel: scrolls the panel, no zoom
    assert app.state.settings.camera.model_dump(mode="json") == cam0
    x, y = _in_view(app)
    _drag(app, x, y, 30, 0, app.wnd.mouse.left)
    assert app.state.settings.camera.yaw != cam0["yaw"]
    app.on_mouse_position_event(x, y, 0, 0)
    app.on_mouse_scroll_event(0, 1)
    assert app.state.settings.camera.distance is not None
    app.step(1)
    assert app.frame.last_change.section() == "camera"
    assert app.frame.last_change.texture_ms == 0.0 and app.frame.last_change.view_ms > 0  # orbit: view-dependent only
    app.state.reset_camera()
    _settle(app)


def test_shortcuts_switch_technique_and_save(app, tmp_path):
    from skinviewer import techniques
    keys = app.wnd.keys
    start = app.state.settings.technique
    try:
        _key(app, keys.NUMBER_1)
        assert app.state.settings.technique == "phong"
        if "deon" in techniques.names():
            _key(app, keys.NUMBER_3)
            assert app.state.settings.technique == "deon"
        if "gosselin" in techniques.names():
            _key(app, keys.NUMBER_2)
            assert app.state.settings.technique == "gosselin"
        app.step(1)
        # Ctrl+S saves the preset (to the current preset file)
        target = tmp_path / "ctrl_s.json"
        app.state.presets.set_path(str(target))
        assert app.state.apply({"render.exposure": 1.3}) and app.state.presets.dirty(app.state.settings)
        _key(app, keys.S, ctrl=True)
        assert target.exists() and not app.state.presets.dirty(app.state.settings)
        assert "saved" in app.state.message[0] and not app.state.message[1]
        # Space flips A/B while comparing
        cmp = app.state.compare
        app.state.capture_slot("A")
        app.state.capture_slot("B")
        cmp.set_mode("toggle")
        cmp.set_show_b(False)
        _key(app, keys.SPACE)
        assert cmp.show_b
        _key(app, keys.SPACE)
        assert not cmp.show_b
    finally:
        app.state.compare.mode = "off"
        app.state.presets.set_path(None)
        app.state.apply({"render.exposure": 1.0})
        app.state.set_technique(start)
        app.step(1)


def test_idle_frames_run_no_passes(app):
    from skinviewer.ui.status_bar import StatusBar
    app.step(2)
    assert app.frame.report.ran == [], app.frame.report.table()
    app.state.set_expand_all(True)  # every widget drawn: none of them may edit the settings by itself
    try:
        s0 = app.state.settings
        app.step(2)
        assert app.frame.report.ran == [], app.frame.report.table()
        assert app.state.settings == s0
    finally:
        app.state.set_expand_all(False)
    # the status bar names scene, triangles, technique, render size and timing mode
    text = " | ".join(t for t, _ in app.ui.window(StatusBar).fields())
    for part in (SCENE, "tris", app.state.settings.technique, f"{app.state.settings.render.width}x{app.state.settings.render.height}",
                 "timing"):
        assert part in text, text


def test_expensive_change_waits_for_release(app):
    from skinviewer.ui.scheduler import RenderScheduler
    sch = RenderScheduler(budget_ms=100.0, rest_s=0.3)
    sch.note_change(now=10.0)
    assert sch.should_defer(True, True, 500.0, now=10.1)  # dragging, expensive: wait
    assert not sch.should_defer(True, True, 50.0, now=10.1)  # cheap (real GPU): live
    assert not sch.should_defer(True, False, 500.0, now=10.1)  # released: render
    assert not sch.should_defer(True, True, 500.0, now=10.5)  # held still: render
    # in the app: a texture-space edit while a widget is held (simulated) keeps the last image
    app.state.set_show_ui(False)  # the UI is not built: _ui_active stays as set here
    app.frame.set_schedule(mode="on release")
    from skinviewer import techniques
    old = app.state.settings.model_dump(mode="json")
    tech = next(t for t in ("deon", "gosselin") if t in techniques.names())
    path = {"deon": "deon.mix", "gosselin": "gosselin.scale_x"}[tech]
    try:
        assert app.state.set_technique(tech)
        app.step(1)
        app.frame.set_widget_active(True)
        assert app.state.apply({path: 0.2 if tech == "deon" else 3.0})
        app.step(1)
        assert app.frame.render_deferred and app.frame.report.ran == []
        app.frame.set_widget_active(False)  # released
        app.step(1)
        assert not app.frame.render_deferred and app.frame.report.ran
        ch = app.frame.last_change
        assert ch.source == path and ch.section() == tech and ch.texture_ms > 0 and ch.passes
    finally:
        app.frame.set_widget_active(False)
        app.frame.set_schedule(mode="adaptive")
        app.state.set_show_ui(True)
        from skinviewer.ground.settings import validate
        app.state.set_settings(validate(old))
        app.step(1)


def test_tooltips_say_what_an_edit_costs(app):
    """Hovering a control tells which passes editing it would re-run, from the live graph."""
    from skinviewer.ui import widgets
    app.step(1)
    hint = app.frame.cost_hint("render.exposure")
    assert "output" in hint and "ms" in hint
    tech_passes = app.frame.cost_hint("shadow.map_size")
    assert "shadow_map_0" in tech_passes
    # the tooltip of a control carries it (through the frame's UI context, not a module global)
    field = type(app.state.settings.render).model_fields["exposure"]
    assert hint in widgets.tooltip_text(field, "render.exposure", app.frame.cost_hint)


def test_orbit_renders_smaller_while_dragging_when_slow(app):
    """On slow GL the view is rendered at a lower resolution during a camera drag (texture-space
    passes stay cached), and at full size again on release."""
    full = (app.state.settings.render.width, app.state.settings.render.height)
    app.frame.set_drag_budget(1e-3)  # any measured cost is over budget
    x0, y0 = app.frame.layout.view[0] + app.frame.layout.view[2] * 0.5, app.frame.layout.view[1] + app.frame.layout.view[3] * 0.5
    button = app.wnd.mouse.left
    app.on_mouse_position_event(x0, y0, 0, 0)
    app.on_mouse_press_event(x0, y0, button)
    app.on_mouse_drag_event(x0 + 20, y0, 20, 0)
    app.step(1)
    small = (app.state.settings.render.width, app.state.settings.render.height)
    assert small[0] < full[0] and small[1] < full[1]
    assert all(p not in app.frame.report.ran for p in ("shadow_map_0",))
    app.on_mouse_release_event(x0 + 20, y0, button)
    app.step(1)
    assert (app.state.settings.render.width, app.state.settings.render.height) == full
    assert "orbit" in app.frame.last_change.source  # the cost line names the orbit, not a resize
    app.frame.set_drag_budget(60.0)


def test_every_settings_field_has_a_widget(app, monkeypatch):
    """The generic panel draws every field of every section of the model (sections added later
    included), optional ones included (auto / value): each field drawn once, by a widget of its kind
    (not the read-only fallback) that leaves a visible imgui item."""
    from imgui_bundle import imgui
    from pydantic import BaseModel

    from skinviewer.ui import widgets
    drawn: dict[str, tuple[str, int]] = {}
    real = widgets.edit_field

    def spy(name, field, value, path, ui):
        real(name, field, value, path, ui)
        assert path not in drawn, f"{path} drawn twice"
        drawn[path] = (widgets.classify(field)[0], imgui.get_item_rect_size().x)

    monkeypatch.setattr(widgets, "edit_field", spy)
    expected = set()
    sections = [name for name, value in app.state.settings if isinstance(value, BaseModel)]
    assert {"scene", "camera", "render", "deon", "burley", "burley2", "penner"} <= set(sections)
    for section in sections:
        model = getattr(app.state.settings, section)
        expected |= {f"{section}.{n}" for n, f in type(model).model_fields.items() if widgets.classify(f)[0] != "other"}
        ui = widgets.UiContext(layout=app.frame.layout)
        imgui.new_frame()
        try:
            widgets.edit_model(model, section, ui)
        finally:
            imgui.end_frame()
    assert set(drawn) == expected, set(drawn) ^ expected
    assert len(expected) > 100
    assert all(kind in widgets._WIDGETS for kind, _ in drawn.values())
    assert all(w > 0 for _, w in drawn.values()), [p for p, (_, w) in drawn.items() if w <= 0]  # something drawn


def test_long_frames_are_spread_and_shown_once_complete(app):
    """With a frame budget, a change whose passes take longer is spread over several frames: the
    UI keeps drawing, the image on screen changes once, complete, and the change's cost adds up."""
    app.state.set_technique("gosselin")
    app.step(1)
    before = _view_image(app)
    app.frame.set_frame_budget(1e-6)  # one pass (or band) per frame
    try:
        app.state.apply({"lights.0.direction": [0.6, 0.3, 0.7]}, "test light move")
        frames = 0
        while True:
            app.step(1)
            frames += 1
            if app.frame.report is not None and app.frame.report.complete:
                break
            assert np.array_equal(_view_image(app), before)  # the old image until it is complete
            assert frames < 2000  # one pass, or one row band of a tileable pass, per frame
        assert frames > 1
        assert np.abs(_view_image(app) - before).mean() > 0.5
        ran = {name for name, _ in app.frame.last_change.passes}
        assert {"gosselin_light_map", "gosselin_blur", "gosselin_final", "output"} <= ran
    finally:
        app.frame.set_frame_budget(None)


def test_switching_back_to_a_cached_technique_reports_zero_cost(app):
    app.state.set_technique("phong")
    app.step(1)
    app.state.set_technique("gosselin")
    app.step(1)
    app.state.set_technique("phong")  # all of phong's passes are still cached
    app.step(1)
    assert app.frame.report.ran == [] and app.frame.last_change.source == "technique"
    assert app.frame.last_change.total_ms == 0.0


def test_preset_refused_after_loading_keeps_the_current_preset(app, tmp_path):
    """A preset that parses but cannot be shown (its mesh does not load) leaves the current preset
    file, its saved baseline and the state alone: Ctrl+S must not write the current state over the
    file that was refused."""
    from skinviewer.ground.settings import to_dict
    current = tmp_path / "current.json"
    assert app.state.presets.save(app.state.settings, str(current))
    bad = tmp_path / "missing_mesh.json"
    text = json.dumps({"schema_version": 1, "scene": {"mesh": str(tmp_path / "no-such-mesh.obj")}})
    bad.write_text(text)
    before = to_dict(app.state.settings)
    try:
        assert not app.state.load_preset(str(bad))
        assert to_dict(app.state.settings) == before
        assert app.state.presets.path == str(current) and not app.state.presets.dirty(app.state.settings)
        assert app.state.presets.errors and app.state.presets.message.startswith("refused")
        assert app.state.save_preset()  # Ctrl+S: the current file, not the refused one
        assert bad.read_text() == text
    finally:
        app.state.presets.set_path(None)
        app.step(1)


def test_resizes_do_not_pile_up_textures(app):
    """The render pools keep every texture handed back to them; the viewer gives back to GL the ones
    of sizes no longer rendered, so resizing the panel (or orbiting at a reduced resolution) does
    not leave a full set of view-sized textures behind each time."""
    pw0 = app.state.view.panel_width
    pool = app.renderer.pool
    try:
        for w in range(int(W * 0.3), int(W * 0.45), 6):
            app.state.set_panel_width(float(w))
            app.step(1)
        assert sum(len(v) for v in pool._free.values()) == 0
    finally:
        app.state.set_panel_width(pw0)
        app.step(1)


def test_click_in_view_keeps_full_resolution(app):
    """A click in the view (no drag) neither orbits nor drops to the orbit resolution."""
    full = (app.state.settings.render.width, app.state.settings.render.height)
    app.frame.set_drag_budget(1e-3)
    try:
        x, y = _in_view(app)
        app.on_mouse_position_event(x, y, 0, 0)
        app.on_mouse_press_event(x, y, app.wnd.mouse.left)
        app.step(1)
        assert (app.state.settings.render.width, app.state.settings.render.height) == full
        app.on_mouse_release_event(x, y, app.wnd.mouse.left)
        app.step(1)
        assert app.frame.report.ran == []
    finally:
        app.frame.set_drag_budget(60.0)


def test_deferred_scene_edit_does_not_reload_the_old_scene(app):
    """A scene edit while a widget is held (the render would otherwise wait for the release) is
    rendered at once: the new scene is already loaded, and showing the old image meant loading the
    old scene back, then the new one again."""
    old = app.state.settings
    app.state.set_show_ui(False)
    app.frame.set_schedule(mode="on release")
    try:
        app.step(1)
        v0 = app.renderer.scene_version
        app.frame.set_widget_active(True)
        mm = app.state.settings.scene.mm_per_unit
        assert app.state.apply({"scene.mm_per_unit": (mm or 1.0) * 1.5})
        app.step(2)
        assert app.renderer.scene_version == v0 + 1
        assert not app.frame.render_deferred
    finally:
        app.frame.set_widget_active(False)
        app.frame.set_schedule(mode="adaptive")
        app.state.set_show_ui(True)
        app.state.set_settings(old)
        app.step(1)


def test_profile_lab_discards_a_fit_of_an_edited_model(app, monkeypatch):
    """The fit runs in a thread: if the model is edited meanwhile, its result is not shown (or
    applied) as the fit of the new model."""
    import threading

    from skinviewer.ui.panel import Panel
    lab = app.ui.window(Panel).lab
    assert lab is not None, "the profile lab did not start (skinviewer.physics.profiles / fitting)"
    from skinviewer.physics import fitting
    release = threading.Event()
    real = fitting.fit_gaussians

    def slow_fit(*a, **k):
        release.wait(10)
        return real(*a, **k)

    monkeypatch.setattr(fitting, "fit_gaussians", slow_fit)
    model0 = lab.model
    try:
        lab.fit = None
        lab.start_fit()
        assert lab.busy
        lab.model = "burley" if model0 != "burley" else "dipole"
        release.set()
        lab._thread.join(30)
        lab._collect()
        assert lab.fit is None and "changed" in lab.fit_error
        assert lab.rows() == [] and not lab.apply()
    finally:
        release.set()
        lab.model = model0
        lab.fit_error = ""


def test_shader_file_in_another_encoding_is_listed_not_fatal(app, shader_dir):
    """Hot reload of a shader file that is not UTF-8 shows an error; the session goes on and the
    error goes once the file is fixed."""
    frag = shader_dir / "output.frag"
    good = frag.read_bytes()
    app.step(1)
    try:
        frag.write_bytes(good.replace(b"void main", "// caf\u00e9\nvoid main".encode("latin-1"), 1))
        st = frag.stat()
        os.utime(frag, ns=(st.st_atime_ns, st.st_mtime_ns + 2_000_000_000))
        app.frame.watcher.poll(force=True)
        app.step(1)
        assert any(e.file == "output.frag" and "UTF-8" in e.message
                   for es in app.frame.watcher.errors.values() for e in es), app.frame.watcher.errors
        assert app.frame.report is not None and _view_image(app).std() > 10
    finally:
        frag.write_bytes(good)
        st = frag.stat()
        os.utime(frag, ns=(st.st_atime_ns, st.st_mtime_ns + 2_000_000_000))
    app.frame.watcher.poll(force=True)
    app.step(1)
    assert not app.frame.watcher.errors


# -- the split viewer: state, controllers, windows; panel; presets ------------------------------

def test_a_registered_window_draws_and_owns_its_area(app):
    """A window is one registration: it gets the state and the frame controller, draws itself with
    the frame's UI context, and the area it claims is the UI's (a drag there does not orbit)."""
    from imgui_bundle import imgui
    seen = {}

    class Probe:
        def __init__(self, state, frame):
            self.state, self.frame = state, frame

        def draw(self, ui):
            vx, vy, vw, vh = ui.layout.view
            self.rect = (vx, vy, vw * 0.5, vh)  # the left half of the 3D view
            imgui.set_next_window_pos(imgui.ImVec2(vx, vy))
            imgui.set_next_window_size(imgui.ImVec2(vw * 0.5, vh))
            imgui.begin("probe###probe")
            imgui.text(self.state.settings.technique)
            imgui.end()
            ui.claim(self.rect)
            seen["hint"] = ui.cost_hint("render.exposure")
            seen["report"] = self.frame.report

        def draw_view(self, viewport):  # its own view mode: here, nothing but the background
            seen["viewport"] = viewport
            return seen.get("take_view", False)

    probe = app.ui.add_window(Probe)
    try:
        app.step(2)
        assert "output" in seen["hint"] and seen["report"] is not None
        assert seen["viewport"] == app.frame.layout.view_fb
        app.state.set_show_ui(False)  # the view alone on screen (its view mode works without the UI too)
        app.step(1)
        assert _screen_view(app).std() > 10
        seen["take_view"] = True
        app.step(1)
        assert _screen_view(app).std() < 1.0  # the window drew the view (the plain background)
        seen["take_view"] = False
        app.state.set_show_ui(True)
        app.step(1)
        yaw0 = app.state.settings.camera.yaw
        x, y, w, h = probe.rect
        _drag(app, x + w * 0.5, y + h * 0.5, 30, 0, app.wnd.mouse.left)
        assert app.state.settings.camera.yaw == yaw0
        _drag(app, x + w * 1.5, y + h * 0.5, 30, 0, app.wnd.mouse.left)  # the free half still orbits
        assert app.state.settings.camera.yaw != yaw0
    finally:
        app.state.set_show_ui(True)
        app.ui.windows.remove(probe)
        app.state.reset_camera()
        _settle(app)


def test_technique_keys_beyond_the_registry_do_nothing(app):
    from skinviewer import techniques
    n = len(techniques.names())
    start = app.state.settings.technique
    key = getattr(app.wnd.keys, f"NUMBER_{n + 1}", None)
    if key is None:
        pytest.skip("no key beyond the registry")
    _key(app, key)
    assert app.state.settings.technique == start and not app.state.errors
    _key(app, app.wnd.keys.NUMBER_1)
    assert app.state.settings.technique == techniques.names()[0]
    app.state.set_technique(start)
    app.step(1)


def test_wheel_over_the_profile_plot_scrolls_the_panel(app):
    """The r·R(r) plot takes no mouse input: the wheel over it scrolls the panel (it used to zoom
    the plot and leave the panel where it was)."""
    from skinviewer.ui.panel import Panel
    from skinviewer.ui.sections.shading import DeonSection
    panel = app.ui.window(Panel)
    deon = panel.section(DeonSection)
    assert app.state.set_technique("deon")  # its section (with the plot) opens by default
    try:
        app.step(2)
        top = app.frame.layout.panel[1]
        panel.scroll_to(panel.scroll_y + deon.plot_rect[1] - top - 40)  # the plot near the top
        app.step(2)
        x, y, w, h = deon.plot_rect
        assert top <= y and y + h <= app.frame.layout.panel[3], "the plot is not on screen"
        scroll0 = panel.scroll_y
        cx, cy = x + w * 0.5, y + h * 0.5
        app.on_mouse_position_event(cx, cy, 0, 0)
        app.step(2)
        for _ in range(3):
            app.on_mouse_scroll_event(0, -1)  # wheel down
            app.step(1)
        app.step(1)
        assert panel.scroll_y > scroll0 + 10, (scroll0, panel.scroll_y)
    finally:
        panel.scroll_to(0)
        app.on_mouse_position_event(*_in_view(app), 0, 0)
        _settle(app)


def test_every_label_fits_the_label_column(app):
    """Labels (with units) of every settings field fit the panel's label column: none clipped."""
    from imgui_bundle import imgui

    from skinviewer.ui.fielddocs import LABEL_MAX_PX, label_with_unit
    imgui.set_current_context(app.ui.imgui_ctx)
    app.step(1)
    too_long = []
    imgui.new_frame()
    try:
        for path, name, _ in settings_fields():
            lab = label_with_unit(name, path)
            if imgui.calc_text_size(lab).x > LABEL_MAX_PX:
                too_long.append((path, lab, imgui.calc_text_size(lab).x))
    finally:
        imgui.end_frame()
    assert not too_long, too_long


def test_ctrl_s_on_a_shipped_preset_saves_a_copy(app, tmp_path, monkeypatch, user_presets):
    """Ctrl+S used to overwrite the shipped presets/deon.json (with the window size and float noise):
    shipped presets are read-only, Ctrl+S writes a copy into the user folder."""
    from skinviewer.ground import paths
    shipped = tmp_path / "shipped"
    shutil.copytree(paths.presets_dir(), shipped)
    monkeypatch.setenv("SKINVIEWER_PRESETS", str(shipped))
    deon = shipped / "deon.json"
    before = deon.read_bytes()
    old = app.state.settings
    try:
        assert app.state.load_preset(str(deon))
        assert app.state.apply({"render.exposure": 0.1 + 0.2})
        _key(app, app.wnd.keys.S, ctrl=True)
        assert deon.read_bytes() == before
        copy = Path(app.state.presets.path)
        assert copy.parent == user_presets and copy.name.startswith("deon")
        data = json.loads(copy.read_text())
        assert data["render"]["exposure"] == 0.3 and "width" not in data["render"]
        assert not app.state.presets.dirty(app.state.settings) and not app.state.message[1]
        # "save as" onto a shipped file is refused with the reason
        assert not app.state.save_preset(str(deon)) and app.state.message[1]
        assert deon.read_bytes() == before
        app.step(1)
    finally:
        app.state.presets.set_path(None)
        app.state.set_settings(old)
        app.step(1)


def test_loading_over_unsaved_changes_asks_first(app, tmp_path):
    """One click on a preset name used to load it and discard unsaved changes: it asks first."""
    from imgui_bundle import imgui

    from skinviewer.ui.sections.tools import CONFIRM_POPUP
    other = tmp_path / "other.json"
    assert app.state.presets.save(with_exposure(app, 2.5), str(other))
    current = tmp_path / "current.json"
    assert app.state.save_preset(str(current))
    old = app.state.settings
    try:
        assert app.state.apply({"render.exposure": 1.9})  # an unsaved change
        edited = app.state.settings
        assert not app.state.request_preset(str(other))
        assert app.state.presets.pending_load == str(other) and app.state.settings is edited
        app.step(2)  # the panel shows the question
        assert imgui.is_popup_open(CONFIRM_POPUP, imgui.PopupFlags_.any_popup_id.value)
        assert not app.state.answer_pending("cancel")
        assert app.state.settings is edited and app.state.presets.pending_load is None
        app.step(1)
        assert not app.state.request_preset(str(other))
        assert app.state.answer_pending("discard")
        assert app.state.settings.render.exposure == 2.5 and app.state.presets.path == str(other)
        # "save, then load": the edit is kept in its file first
        assert app.state.apply({"render.exposure": 1.1})
        assert not app.state.request_preset(str(current))
        assert app.state.answer_pending("save")
        assert json.loads(other.read_text())["render"]["exposure"] == 1.1
        assert app.state.presets.path == str(current)
        # without unsaved changes a click loads at once
        assert app.state.request_preset(str(other)) and app.state.presets.pending_load is None
        app.step(1)
    finally:
        app.state.presets.cancel_pending()
        app.state.presets.set_path(None)
        app.state.set_settings(old)
        _settle(app)


def with_exposure(app, v):
    from skinviewer.ground.settings import with_values
    return with_values(app.state.settings, {"render.exposure": v})


def test_burley2_in_the_viewer_shows_extra_samples_and_the_gpu_count(app):
    """burley2 live: the passes window's report carries the GPU sample count, and the 'extra' view mode
    changes the image."""
    assert app.state.set_technique("burley2")
    app.step(1)
    plain = _view_image(app)
    rec = next(p for p in app.frame.report.passes if p.name == "burley_count")
    assert rec.figures["samples"] > 0 and "samples on the GPU" in rec.note
    assert app.state.apply({"burley.view": "extra"}, "burley.view")
    app.step(1)
    assert np.abs(_view_image(app) - plain).mean() > 0.5
    assert app.state.apply({"burley.view": "image"}, "burley.view")
    assert app.state.set_technique("phong")
    app.step(1)


def test_temporal_refines_in_the_viewer_without_hiding_the_change(app):
    """burley2.temporal: the viewer keeps rendering while the running mean fills (nothing changed), then
    idles; the cost line keeps the change that started it, not a refinement frame."""
    try:
        assert app.state.apply({"technique": "burley2", "burley2.mode": "beyond", "burley2.temporal": 4,
                                "render.width": 96, "render.height": 96})
        app.step(1)
        first = app.frame.last_change
        assert first is not None and any(n == "burley_temporal" for n, _ in first.passes)
        frames = []
        for _ in range(6):
            app.step(1)
            rec = {p.name: p for p in app.frame.report.passes}["burley_temporal"]
            frames.append((rec.status, rec.figures.get("frames")))
        assert ("ran", 4) in frames and frames[-1][0] == "cached"  # refined to 4 frames, then idle
        assert app.frame.last_change is first  # refinement frames are not changes
    finally:
        app.state.apply({"technique": "phong", "burley2.temporal": 0, "burley2.mode": "thesis"})
        app.step(1)


def test_a_resized_view_keeps_the_last_image_while_its_frame_is_spread(app):
    """The view shows the last complete image until the next one is complete, also when the render
    size changed (its textures are reallocated, then made in row bands over many frames): never a
    black or half-made view (hiding the UI, a governed preview's smaller size, a window resize)."""
    from skinviewer.ui.screenshot import read_screen
    app.state.set_technique("phong")
    for _ in range(3):
        app.step(1)

    def view():
        vp = app.frame.layout.view_fb
        return read_screen(app.ctx, vp[2:], origin=vp[:2]).astype(np.float32)

    shown = view()
    assert shown.std() > 10
    app.frame.set_frame_budget(1e-6)  # one band per frame
    try:
        app.state.set_show_ui(False)  # the view is the whole window now: a new render size
        app.step(1)
        assert app.frame.report is not None and not app.frame.report.complete
        now = view()
        assert now.shape != shown.shape and now.std() > 10  # the last image, stretched, not black
        for _ in range(4000):
            app.step(1)
            if app.frame.report.complete:
                break
        assert app.frame.report.complete and view().std() > 10
    finally:
        app.frame.set_frame_budget(None)
        app.state.set_show_ui(True)
        app.step(1)


def test_a_still_frame_spread_over_several_renders_without_presenting_until_complete(app):
    """While a still view's frame is made in row bands and no input comes, frames only render (no
    UI, no swap: presenting costs tens of ms a frame on llvmpipe); the frame that completes is
    presented, and any input event presents the next frame at once."""
    app.state.set_technique("phong")
    app.step(2)
    app.frame.set_frame_budget(1e-6)  # one band per frame
    presented = []
    real = app.frame.run
    app.frame.run = lambda *a, **k: (presented.append(k.get("present", True)), real(*a, **k))[1]
    try:
        app.state.apply({"lights.0.direction": [0.4, 0.5, 0.8]}, "test light move")
        app._events = 0
        for _ in range(4000):
            app.step(1)
            if app.frame.report.complete:
                break
        assert app.frame.report.complete
        assert False in presented, "no frame skipped presenting"
        assert presented[0] is True  # the change's first frame shows the UI's own edit at once
        # the frame that completed used up its budget: the UI and presenting on top would stall
        # the loop past it, so the next frame shows it (rendering nothing more)
        assert not app.frame.presented
        app.step(1)
        assert app.frame.presented and app.frame.report.complete and not app.frame.report.ran
        # input while a spread frame runs: the next frame presents
        app.state.apply({"lights.0.direction": [0.3, 0.5, 0.8]}, "test light move")
        app.step(1)
        presented.clear()
        app.on_mouse_position_event(10, 10, 1, 1)
        app.step(1)
        assert presented == [True]
    finally:
        app.frame.run = real
        app.frame.set_frame_budget(None)
        for _ in range(4000):
            app.step(1)
            if app.frame.report.complete:
                break
