"""The viewer's parts that need no window: the preset rules (shipped presets read-only, what a saved
preset holds), the profile plot's math (one copy, in physics), the technique keys, tooltips and
labels, and the shape of the UI code (windows change other objects only through their methods; no
module-global hooks)."""
from __future__ import annotations

import ast
import json
import math
from pathlib import Path

import numpy as np
import pytest
from helpers import settings_fields

from skinviewer.ground.settings import Settings, load_preset, to_dict, with_values

UI = Path(__file__).resolve().parents[1] / "skinviewer" / "ui"
# modules that draw windows: they may assign only to their own fields (self.x)
WINDOW_MODULES = ("panel.py", "passes_window.py", "status_bar.py", "profile_lab.py", "accuracy_window.py",
                  "sections/status.py", "sections/scene.py", "sections/shading.py", "sections/tools.py",
                  "sections/common.py")


# -- the shape of the UI code ---------------------------------------------------------------------

def _attribute_writes(path: Path) -> list[str]:
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, (ast.Assign, ast.AugAssign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            flat = []
            for t in targets:
                flat += list(t.elts) if isinstance(t, (ast.Tuple, ast.List)) else [t]
            for t in flat:
                if isinstance(t, ast.Attribute) and not (isinstance(t.value, ast.Name) and t.value.id == "self"):
                    out.append(f"{path.name}:{node.lineno}: {ast.unparse(t)}")
    return out


def test_windows_change_other_objects_only_through_methods():
    writes = [w for name in WINDOW_MODULES if (UI / name).exists() for w in _attribute_writes(UI / name)]
    assert writes == [], "a window assigns into another object's fields:\n" + "\n".join(writes)


def test_state_and_controllers_do_not_write_into_each_other():
    # the state, the controllers and the thin window talk through methods too (GL / imgui / window
    # library objects aside: a viewport, imgui's io and style, the window's title are set directly)
    library = ("ctx.", "io.", "st.", "self.ctx.", "self.wnd.", "wnd.")
    writes = [w for name in ("state.py", "frame.py", "input.py", "app.py", "windows.py", "compare.py", "presets.py", "view.py")
              for w in _attribute_writes(UI / name)
              if not w.split(": ", 1)[1].startswith(library)]
    assert writes == [], "\n".join(writes)


def test_no_module_global_hooks_in_the_ui():
    pytest.importorskip("imgui_bundle")
    from skinviewer.ui import widgets
    assert not hasattr(widgets, "cost_hint") and not hasattr(widgets, "EXPAND_ALL")
    for p in UI.rglob("*.py"):
        src = p.read_text(encoding="utf-8")
        assert "sys.argv" not in src, f"{p.name} reads sys.argv: pass options through ViewerOptions"
        tree = ast.parse(src)
        mutable = {t.id for node in tree.body if isinstance(node, ast.Assign)
                   and isinstance(node.value, (ast.Dict, ast.List, ast.Set)) for t in node.targets
                   if isinstance(t, ast.Name)}
        for node in ast.walk(tree):
            assert not isinstance(node, ast.Global), f"{p.name}:{node.lineno}: global statement"
            if isinstance(node, (ast.Assign, ast.AugAssign)):
                for t in (node.targets if isinstance(node, ast.Assign) else [node.target]):
                    assert not (isinstance(t, ast.Subscript) and isinstance(t.value, ast.Name)
                                and t.value.id in mutable), f"{p.name}:{node.lineno}: writes module state"
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) \
                    and isinstance(node.func.value, ast.Name) and node.func.value.id in mutable:
                assert node.func.attr in ("get", "items", "keys", "values", "index", "count"), \
                    f"{p.name}:{node.lineno}: mutates module state {node.func.value.id}"


def test_no_second_copy_of_the_gaussian_profile_math():
    for name in ("panel.py", "profile_plot.py", "profile_lab.py", "sections/shading.py"):
        src = (UI / name).read_text(encoding="utf-8")
        assert "2.0 * math.pi" not in src and "2 * np.pi" not in src and "np.exp(" not in src, name


def test_every_tooltip_goes_through_the_wrapping_helper():
    # imgui's set_tooltip / set_item_tooltip neither wrap nor stop at the window edge
    for name in WINDOW_MODULES:
        p = UI / name
        if p.exists():
            src = p.read_text(encoding="utf-8")
            assert "set_item_tooltip(" not in src and "imgui.set_tooltip(" not in src, name


def test_windows_are_registered_in_one_place():
    pytest.importorskip("imgui_bundle")
    from skinviewer.ui import windows
    from skinviewer.ui.panel import Panel
    from skinviewer.ui.passes_window import PassesWindow
    from skinviewer.ui.status_bar import StatusBar
    assert windows.WINDOWS[:3] == (Panel, StatusBar, PassesWindow)
    for factory in windows.WINDOWS:
        assert callable(getattr(factory, "draw", None))


# -- technique keys -------------------------------------------------------------------------------

def test_technique_keys_follow_the_registry_size():
    from skinviewer.ui.input import technique_keys
    keys = type("Keys", (), {**{f"NUMBER_{i}": 100 + i for i in range(1, 10)},
                             **{f"NUMPAD_{i}": 200 + i for i in range(1, 10)}})
    seven = technique_keys(keys, 7)
    assert seven[keys.NUMBER_1] == 0 and seven[keys.NUMBER_7] == 6 and seven[keys.NUMPAD_7] == 6
    assert keys.NUMBER_8 not in seven and len(seven) == 14
    assert max(technique_keys(keys, 20).values()) == 8  # keys 1..9 at most


# -- the profile plot -----------------------------------------------------------------------------

def test_profile_plot_uses_the_physics_profile_and_its_v0_guard():
    from skinviewer.physics.diffusion import profile
    from skinviewer.ui import profile_plot
    s = with_values(Settings(), {"deon.gaussians.0.variance": 0.0})  # a delta: no radial spread
    gs = s.deon.gaussians
    for log_r in (False, True):
        r, y = profile_plot.gaussian_curve(gs, log_r)
        assert np.isfinite(y).all()
        w = r * r if log_r else r
        np.testing.assert_allclose(y, w[:, None] * profile(r, gs))


def test_linear_plot_area_is_the_diffuse_response():
    """GPU Gems 3 §14.4.6: the area under r·R(r) is the total diffuse response, sum_i w_i / 2pi,
    and the radius range holds all of it but the tail."""
    from skinviewer.ui import profile_plot
    gs = Settings().deon.gaussians
    r, y = profile_plot.gaussian_curve(gs, log_r=False, n=4000)
    area = np.trapezoid(y, r, axis=0) if hasattr(np, "trapezoid") else np.trapz(y, r, axis=0)
    total = np.array([sum(g.weights[c] for g in gs) for c in range(3)]) / (2 * math.pi)
    np.testing.assert_allclose(area, total, rtol=0.01)
    r_min, r_max = profile_plot.radius_range(gs)
    assert 1.0 < r_max < 30.0 and 0 < r_min < 0.1


def test_log_plot_bump_height_is_the_weight_whatever_the_width():
    """On a log-r axis r²·R(r) of one Gaussian peaks at w / (pi e) for every variance: each row of the
    table is a bump as high as its weight."""
    from skinviewer.ui import profile_plot
    peaks = []
    for v in (0.01, 0.5, 5.0):
        s = with_values(Settings(), {"deon.gaussians": [{"variance": v, "weights": [0.6, 0.3, 0.1]}]})
        _, y = profile_plot.gaussian_curve(s.deon.gaussians, log_r=True, n=2000)
        peaks.append(y.max(axis=0))
    for p in peaks:
        np.testing.assert_allclose(p, np.array([0.6, 0.3, 0.1]) / (math.pi * math.e), rtol=0.01)


# -- labels and tooltips --------------------------------------------------------------------------

def _fields():
    return settings_fields()


def test_labels_are_words_not_field_names():
    pytest.importorskip("imgui_bundle")
    from skinviewer.ui.fielddocs import label, label_with_unit
    labels = {path: label_with_unit(name, path) for path, name, _ in _fields()}
    assert not any("@" in lab for lab in labels.values()), labels  # "scale y (texels @1024)"
    for path in ("deon.tsm_form", "deon.reuse_irradiance_below_texels", "gosselin.scale_y", "gosselin.scale_x",
                 "gosselin.regions.ears.scale_y", "specular.rho_s", "specular.m", "camera.fov_y", "shadow.tol",
                 "deon.mix", "deon.tsm"):
        field_name = path.rsplit(".", 1)[-1].replace("_", " ")
        assert label(path) != field_name, f"{path}: still labelled '{field_name}'"


def test_every_settings_group_has_a_section():
    """A settings group without a hand-built section (a new technique's) is drawn generically."""
    pytest.importorskip("imgui_bundle")
    from pydantic import BaseModel

    from skinviewer.ui.sections.shading import HAND_BUILT, generic_groups
    assert generic_groups() == [n for n, f in Settings.model_fields.items()
                                if n not in HAND_BUILT and isinstance(f.default_factory, type)
                                and issubclass(f.default_factory, BaseModel)]

    class Extra(BaseModel):
        radius_mm: float = 1.0

    class More(Settings):
        newtech: Extra = Extra()

    assert generic_groups(More)[-1] == "newtech"


def test_tooltips_say_each_line_once():
    pytest.importorskip("imgui_bundle")
    from skinviewer.ui.widgets import tooltip_text
    for path, _, f in _fields():
        lines = tooltip_text(f, path, lambda p: "editing it re-runs 1 pass(es): output").split("\n")
        assert len(lines) == len(set(lines)), (path, lines)
        assert lines[0], f"{path} has no tooltip text"
    # the d'Eon TSM falloff: the field description and the doc said the same thing twice
    f = type(Settings().deon).model_fields["tsm_form"]
    assert tooltip_text(f, "deon.tsm_form").count("exp(-d") == 2  # exact and printed, once each


# -- presets --------------------------------------------------------------------------------------

@pytest.fixture
def folders(tmp_path, monkeypatch):
    shipped = tmp_path / "shipped"
    shutil_src = Path(__file__).resolve().parents[1] / "presets"
    shipped.mkdir()
    for p in shutil_src.glob("*.json"):
        (shipped / p.name).write_bytes(p.read_bytes())
    user = tmp_path / "user"
    monkeypatch.setenv("SKINVIEWER_PRESETS", str(shipped))
    monkeypatch.setenv("SKINVIEWER_USER_PRESETS", str(user))
    return shipped, user


def test_saved_preset_has_no_window_size_and_no_float_noise(folders, tmp_path):
    from skinviewer.ui.presets import PresetState
    s = with_values(Settings(), {"render.width": 1234, "render.height": 567, "render.exposure": 0.1 + 0.2,
                                 "deon.mix": 0.30000000000000004})
    ps = PresetState(s)
    out = tmp_path / "mine.json"
    assert ps.save(s, out)
    text = out.read_text()
    data = json.loads(text)
    assert "width" not in data["render"] and "height" not in data["render"]
    assert "0.30000000000000004" not in text and data["render"]["exposure"] == 0.3
    back = load_preset(out)
    assert back.render.exposure == 0.3 and back.deon.mix == 0.3
    assert not ps.dirty(s)


def test_shipped_presets_are_read_only_ctrl_s_saves_a_copy(folders):
    from skinviewer.ui.presets import PresetState, is_shipped
    shipped, user = folders
    deon = shipped / "deon.json"
    before = deon.read_bytes()
    s = load_preset(deon)
    ps = PresetState(s, str(deon))
    assert ps.read_only and is_shipped(deon)
    edited = with_values(s, {"render.exposure": 1.7})
    assert not ps.save(edited, deon) and "read-only" in ps.errors[0][1]  # save as over it: refused
    target, note = ps.save_target()  # Ctrl+S: a copy in the user folder
    assert target == user / "deon.json" and "shipped" in note
    assert ps.save(edited, target, note)
    assert deon.read_bytes() == before
    assert ps.path == str(user / "deon.json") and not ps.read_only
    assert load_preset(user / "deon.json").render.exposure == 1.7
    # a second shipped save never overwrites the first copy
    ps2 = PresetState(s, str(deon))
    assert ps2.save_target()[0] == user / "deon-2.json"


def test_preset_listing_has_both_folders_and_no_temporaries(folders):
    from skinviewer.ui.presets import PresetState
    shipped, user = folders
    user.mkdir()
    (user / "mine.json").write_text(json.dumps({"schema_version": 1}))
    (user / ".mine.json.123.tmp").write_text("{")
    (user / ".hidden.json").write_text("{")
    (shipped_title, shipped_files), (user_title, user_files) = PresetState.listing()
    assert "read-only" in shipped_title and {p.name for p in shipped_files} >= {"deon.json", "phong.json"}
    assert str(user) in user_title and [p.name for p in user_files] == ["mine.json"]


def test_user_presets_folder_default_and_override(monkeypatch, tmp_path):
    from skinviewer.ui.presets import user_presets_dir
    monkeypatch.delenv("SKINVIEWER_USER_PRESETS", raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "cfg"))
    assert user_presets_dir() == tmp_path / "cfg" / "skinviewer" / "presets"
    monkeypatch.setenv("SKINVIEWER_USER_PRESETS", str(tmp_path / "x"))
    assert user_presets_dir() == tmp_path / "x"


def test_shipped_presets_do_not_hold_float_noise():
    for p in (Path(__file__).resolve().parents[1] / "presets").glob("*.json"):
        text = p.read_text()
        assert "0000000000" not in text and "9999999999" not in text, p.name
        assert to_dict(load_preset(p))  # and they load
