"""The viewer's start (issue 34): the window and its start-up screen come before the heavy modules, the
panel before the first image, and the texture-space tables of a known mesh come from the cache.
Structure, not timing (the times are benchmarks/bench_startup.py's)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("scipy", "matplotlib", "trimesh", "embreex", "pyembree", "xatlas", "numba", "adjustText")


def _modules_after(code: str, env: dict | None = None) -> dict:
    """Run ``code`` in a fresh interpreter (this checkout first on the path); the modules it left."""
    probe = code + "\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", probe], cwd=ROOT, capture_output=True, text=True, timeout=300,
                         env={**os.environ, "PYTHONPATH": os.pathsep.join(
                             [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]), **(env or {})})
    assert out.returncode == 0, out.stderr[-2000:]
    return set(json.loads(out.stdout.strip().splitlines()[-1]))


def test_the_viewer_and_the_command_line_import_no_heavy_library():
    """scipy, matplotlib, trimesh and the ray tracers load when a computation needs them (a fit, the
    ground truth, a mesh file), not when the viewer or the command line start: each cost the start a
    second or more on a loaded machine."""
    pytest.importorskip("imgui_bundle")  # the viewer's app needs its packages (the GPU check carries none)
    mods = _modules_after("import skinviewer.cli, skinviewer.ui.app, skinviewer.techniques")
    assert "skinviewer.ui.app" in mods and "skinviewer.techniques.deon" in mods
    loaded = [m for m in HEAVY if m in mods]
    assert not loaded, f"imported at start: {loaded}"
    # nor the truth and its windows' heavy half
    assert "skinviewer.physics.ground_truth" not in mods


def test_the_launcher_needs_only_the_standard_library():
    mods = _modules_after("import skinviewer.launch, skinviewer.ui.startup")
    assert "numpy" not in mods and "moderngl_window" not in mods
    assert not any(m.startswith("skinviewer.") and m not in ("skinviewer.launch", "skinviewer.ui", "skinviewer.ui.startup")
                   for m in mods)


def test_which_launches_open_the_window_first(monkeypatch):
    from skinviewer.launch import early_window_size
    from skinviewer.ui.startup import DEFAULT_WINDOW
    monkeypatch.setenv("DISPLAY", ":99")
    assert early_window_size([]) == DEFAULT_WINDOW
    assert early_window_size(["view", "--technique", "phong"]) == DEFAULT_WINDOW
    assert early_window_size(["--size", "640x480", "--scene", "laser"]) == (640, 480)
    assert early_window_size(["--size=800x600"]) == (800, 600)
    assert early_window_size(["--size", "bad"]) == DEFAULT_WINDOW  # the command line's own check says why
    for argv in (["render", "--out", "x.png"], ["--frames", "3"], ["--screenshot", "a.png"], ["-h"], ["--version"],
                 ["settings", "--list"], ["rendr"]):
        assert early_window_size(argv) is None, argv
    monkeypatch.delenv("DISPLAY")
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    if sys.platform.startswith("linux"):
        assert early_window_size([]) is None  # no display: the viewer's one-line error, no window attempt


def test_the_window_opens_before_the_viewer_loads():
    """The launcher's window shows its start-up screen with only moderngl-window, glfw, numpy and Pillow
    loaded: nothing of the settings, the techniques or imgui yet."""
    if not os.environ.get("DISPLAY"):
        pytest.skip("no DISPLAY")
    code = ("from skinviewer.ui import startup\n"
            "sp = startup.open_early((320, 200))\n"
            "assert sp is not None and sp.frames >= 1 and startup.MARKS[0][0] == 'window'\n")
    mods = _modules_after(code)
    early = [m for m in ("skinviewer.ground.settings", "skinviewer.techniques", "skinviewer.cli", "imgui_bundle",
                         "pydantic", "scipy") if m in mods]
    assert not early, f"loaded before the window: {early}"


def test_bad_arguments_close_the_early_window_with_one_line():
    if not os.environ.get("DISPLAY"):
        pytest.skip("no DISPLAY")
    out = subprocess.run([sys.executable, "-m", "skinviewer", "--scene", "heads", "--size", "320x200"], cwd=ROOT,
                         capture_output=True, text=True, timeout=300, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "did you mean 'head'" in lines[0], out.stderr


def test_the_panel_comes_before_the_first_image(tmp_path):
    """create_app takes the launcher's window over; the first frame of the viewer is the panel beside
    the start-up screen (no render yet), and the screen gives the view back to the first complete image."""
    if not os.environ.get("DISPLAY"):
        pytest.skip("no DISPLAY")
    pytest.importorskip("imgui_bundle")
    from skinviewer.ground.settings import Settings, with_values
    from skinviewer.scene.scenes import scene_overrides
    from skinviewer.ui import startup
    from skinviewer.ui.app import create_app, destroy_app
    from skinviewer.ui.splash import StartupView
    sp = startup.open_early((480, 320))
    if sp is None:
        pytest.skip("cannot open a window")
    early_wnd = sp.wnd
    s = with_values(Settings(), {"scene.name": "shadow-edge", **scene_overrides("shadow-edge"), "technique": "phong",
                                 "shadow.map_size": 256})
    app = create_app(s, size=(480, 320), vsync=False, splash=True)
    try:
        assert app.wnd is early_wnd  # one window, its screen continued
        view = app.ui.window(StartupView)
        assert view.splash is not None
        app.ui_frame()
        assert app.frame.report is None and app.frame.frames == 0  # the panel, and nothing rendered
        assert "ui" in app._marked
        app.frame.set_frame_budget(None)
        app.step(1)
        assert app.frame.report is not None and app.frame.report.complete
        assert view.splash is None  # the image has the view
        assert "image" in app._marked
    finally:
        destroy_app(app)


def test_texel_tables_come_from_the_cache(tmp_path, monkeypatch):
    from skinviewer.passes.texture_space import stored_table
    monkeypatch.setenv("SKINVIEWER_CACHE", str(tmp_path))
    covered = np.zeros((8, 8), bool)
    covered[2:6, 3:7] = True
    calls = []

    def compute():
        calls.append(1)
        return np.arange(8 * 8 * 4, dtype=np.float32).reshape(8, 8, 4)

    like = ((8, 8, 4), np.float32)
    a = stored_table(["seam", 24.0], (covered,), like, compute)
    (mine,) = list((tmp_path / "texel-tables").glob("*.npy"))
    b = stored_table(["seam", 24.0], (covered,), like, compute)
    assert len(calls) == 1 and np.array_equal(a, b)
    other = covered.copy()
    other[0, 0] = True  # other inputs (a mesh, a coverage): another table
    stored_table(["seam", 24.0], (other,), like, compute)
    stored_table(["seam", 12.0], (covered,), like, compute)  # another parameter
    assert len(calls) == 3
    files = list((tmp_path / "texel-tables").glob("*.npy"))
    assert len(files) == 3 and not list((tmp_path / "texel-tables").glob(".*"))  # no temporaries left
    mine.write_bytes(b"not a table")  # corrupt: made again, never trusted
    c = stored_table(["seam", 24.0], (covered,), like, compute)
    assert len(calls) == 4 and np.array_equal(c, a)
    np.save(mine, np.zeros((2, 2), np.float32))  # a table of the wrong shape: made again
    d = stored_table(["seam", 24.0], (covered,), like, compute)
    assert len(calls) == 5 and np.array_equal(d, a)


def test_the_panel_is_drawn_before_the_mesh_is_loaded(monkeypatch):
    """Issue 34 ("never a black window"): with the start-up screen, the viewer's first UI frame (the
    "ui" mark) comes before the scene is built and uploaded (Renderer.ensure_scene); the scene then
    loads and the first render is complete. Order of events, not time."""
    if not os.environ.get("DISPLAY"):
        pytest.skip("no DISPLAY")
    pytest.importorskip("imgui_bundle")
    from skinviewer.engine.renderer import Renderer
    from skinviewer.ground.settings import Settings, with_values
    from skinviewer.scene.scenes import scene_overrides
    from skinviewer.ui import startup
    from skinviewer.ui.app import create_app, destroy_app
    events: list[str] = []
    ensure = Renderer.ensure_scene
    monkeypatch.setattr(Renderer, "ensure_scene", lambda self, s: (events.append("scene"), ensure(self, s))[1])
    mark = startup.mark
    monkeypatch.setattr(startup, "mark", lambda event, **info: (events.append(event), mark(event, **info))[1])
    s = with_values(Settings(), {"scene.name": "shadow-edge", **scene_overrides("shadow-edge"), "technique": "phong",
                                 "shadow.map_size": 256})
    app = create_app(s, size=(480, 320), vsync=False, splash=True)
    try:
        assert "ui" in events and "scene" in events and events.index("ui") < events.index("scene"), events
        assert app.state.scene is not None
        app.frame.set_frame_budget(None)
        app.step(1)
        assert app.frame.report is not None and app.frame.report.complete
    finally:
        destroy_app(app)


def test_a_state_made_before_its_scene_loads_it_on_an_edit_or_when_asked_with_the_fallback():
    """ViewerState(defer_scene=True), the panel-first start: no scene until load_initial_scene (or an
    edit, which loads it itself; the later call is then a no-op); a scene that cannot be loaded gives
    the fallback scene's settings, and the presets' baseline is theirs (no "unsaved" at start)."""
    pytest.importorskip("imgui_bundle")
    from types import SimpleNamespace

    from skinviewer.ground.settings import Settings, with_values
    from skinviewer.ui.state import FALLBACK_SCENE, ViewerState
    loads: list[str] = []

    def load(s):
        loads.append(s.scene.name)
        if s.scene.name == "head":
            raise OSError("no head here")
        return SimpleNamespace(notes=[], description=s.scene.name)

    st = ViewerState(with_values(Settings(), {"scene.name": "shadow-edge"}), load, defer_scene=True)
    assert st.scene is None and loads == []
    assert st.apply({"render.exposure": 1.5})  # an edit before the scene: it loads it
    assert st.scene is not None and loads == ["shadow-edge"]
    st.load_initial_scene()
    assert loads == ["shadow-edge"]  # already there: not loaded twice
    bad = ViewerState(Settings(), load, defer_scene=True)  # the head cannot be loaded
    bad.load_initial_scene()
    assert loads[-2:] == ["head", FALLBACK_SCENE] and bad.settings.scene.name == FALLBACK_SCENE
    assert any("not available" in n for n in bad.notices) and not bad.presets.dirty(bad.settings)
