"""Settings paths, assignments and preset files (skinviewer/ground/settings.py): the exact messages and
rules the CLI, the viewer and presets rely on. Written against the survivors of the mutation run
(benchmarks/mutation.py ground.settings, notes/mutation.md)."""
from __future__ import annotations

import json
import os

import pytest
from conftest import SHARED

from skinviewer.ground import settings as S
from skinviewer.ground.settings import (
    Settings,
    SettingsError,
    load_preset,
    save_preset,
    with_values,
)


def _errors(fn, *a):
    with pytest.raises(SettingsError) as ei:
        fn(*a)
    return ei.value


def test_default_skin_profile_is_the_published_table():
    """d'Eon & Luebke 2007's six Gaussians (seed 000 Tabela 2), read from ../shared/reference."""
    ref = SHARED / "reference" / "deon2007_skin_profile.json"
    if not ref.is_file():
        pytest.skip(f"needs ../shared/reference ({ref})")
    table = json.loads(ref.read_text())["gaussians"]
    got = Settings().deon.gaussians
    assert [g.variance for g in got] == [t["variance"] for t in table]
    assert [list(g.weights) for g in got] == [t["weights_rgb"] for t in table]


def test_default_region_tables():
    sp = Settings().specular.per_region
    assert {k: (v.m, v.rho_s) for k, v in sp.items()} == {
        "forehead": (0.32, 0.20), "nose": (0.28, 0.24), "lips": (0.30, 0.22), "cheeks": (0.38, 0.15),
        "chin": (0.35, 0.17)}
    g = Settings().gosselin.regions
    assert {k: (v.kernel_size, v.scale_x, v.scale_y) for k, v in g.items()} == {
        k: (ks, 1.0, 0.0) for k, ks in {"other": 1.0, "forehead": 1.0, "nose": 1.6, "cheeks": 0.7, "lips": 1.0,
                                        "chin": 1.0, "ears": 2.0, "neck": 1.2, "scalp": 1.0}.items()}
    e = _errors(with_values, Settings(), {"specular.per_region.elbow": {"m": 0.3}})
    assert "unknown region(s) ['elbow']; known: [" in str(e) and "'forehead'" in str(e)


def test_get_path_value_key_and_indices():
    s = Settings()
    assert S.get_path(s, "lights.0.intensity") == s.lights[0].intensity
    assert S.get_path(s, "lights.#") == len(s.lights)
    assert S.get_path(s, "") is s
    assert S.get_path({"a": [1, {"b": 2}]}, "a.1.b") == 2
    with pytest.raises(KeyError):
        S.get_path(s, "render.nope")
    for bad in ("-1", "x", "1234567", "١"):
        with pytest.raises(IndexError):
            S.get_path(s, f"lights.{bad}")
    assert S.value_key(s, "camera.target") == "null"
    assert S.value_key(s, "deon.gaussians.0") == '{"variance": 0.0064, "weights": [0.233, 0.455, 0.649]}'
    assert json.loads(S.value_key(s, "lights.0.color")) == list(s.lights[0].color)


def test_with_values_lists_dicts_and_unknown_paths():
    s = Settings()
    n = len(s.lights)
    more = with_values(s, {f"lights.{n}": S.to_dict(s)["lights"][0]})  # index == len appends
    assert len(more.lights) == n + 1 and more.lights[n] == s.lights[0]
    s2 = with_values(s, {"specular.per_region.nose.m": 0.5, "gosselin.regions.ears.kernel_size": 3.0})
    assert s2.specular.per_region["nose"].m == 0.5 and s2.gosselin.regions["ears"].kernel_size == 3.0
    e = _errors(with_values, s, {f"lights.{n + 1}": {}, "render.nope": 1, "render.width.x": 1,
                                 "lights.x.intensity": 1})
    assert e.errors == [(f"lights.{n + 1}", "no such setting"), ("render.nope", "no such setting"),
                        ("render.width.x", "no such setting"), ("lights.x.intensity", "no such setting")]
    assert str(e).startswith(f"lights.{n + 1}: no such setting; render.nope: no such setting")
    e = _errors(with_values, s, {"render.width": "wide"})
    assert e.errors[0][0] == "render.width" and not e.errors[0][1].startswith("Value error")
    e = _errors(with_values, s, {"camera.target": [0, float("nan"), 0]})
    assert e.errors == [("camera.target", "components must be finite numbers")]
    e = _errors(with_values, s, {"render.background": [0, float("inf"), 0]})
    assert e.errors == [("render.background", "components must be finite numbers")]
    assert str(SettingsError([("a", "b")], "f.json")) == "f.json: a: b"


def test_parse_value_and_assignments():
    assert S.parse_value("1.5") == 1.5 and S.parse_value("[1, 2]") == [1, 2] and S.parse_value("true") is True
    assert S.parse_value("on") is True and S.parse_value("YES") is True
    assert S.parse_value("off") is False and S.parse_value("no") is False
    assert S.parse_value("1,2,3") == [1, 2, 3] and S.parse_value("a,b") == "a,b"
    assert S.parse_value("head") == "head"
    e = _errors(S.parse_value, "9" * 5000)
    assert e.errors[0][0] == "<value>" and "digits" in e.errors[0][1] and ";" not in e.errors[0][1]
    assert S.parse_assignments(["render.width = 64", "technique=deon"]) == {"render.width": 64, "technique": "deon"}
    e = _errors(S.parse_assignments, ["novalue", "x=" + "9" * 5000])
    assert e.errors[0] == ("novalue", "expected key=value") and e.errors[1][0] == "x"
    assert S._json_problem(RecursionError()) == "nested too deeply"


def test_scene_file_paths_are_checked():
    for bad, msg in (("a\x00b", "path contains a NUL byte"), ("  ", "path is empty"),
                     ("bad\ud800", "path is not valid text for this file system (lone surrogate?)")):
        e = _errors(with_values, Settings(), {"scene.mesh": bad})
        assert e.errors == [("scene.mesh", msg)], e.errors
    assert with_values(Settings(), {"scene.mesh": "x.glb"}).scene.mesh == "x.glb"


def test_preset_paths_are_relative_to_the_preset(tmp_path):
    d = tmp_path / "p" / "q"
    d.mkdir(parents=True)
    mesh = tmp_path / "p" / "m.glb"
    s = with_values(Settings(), {"scene.mesh": str(mesh), "scene.albedo_map": "/abs/a.png"})
    save_preset(s, d / "x.json")
    raw = json.loads((d / "x.json").read_text())
    assert raw["scene"]["mesh"] == os.path.join("..", "m.glb")
    assert raw["scene"]["albedo_map"] == os.path.relpath("/abs/a.png", d)
    back = load_preset(d / "x.json")
    assert back.scene.mesh == str(mesh) and back.scene.albedo_map == "/abs/a.png"
    # a preset written by hand: relative to its own folder, absolute kept, bad values reported by validation
    (d / "y.json").write_text(json.dumps({"schema_version": 1, "scene": {"mesh": "sub/../n.glb",
                                                                         "normal_map": "/n.png"}}))
    y = load_preset(d / "y.json")
    assert y.scene.mesh == str(d / "n.glb") and y.scene.normal_map == "/n.png"
    (d / "z.json").write_text(json.dumps({"schema_version": 1, "scene": {"mesh": "a\u0000b"}}))
    assert _errors(load_preset, d / "z.json").errors == [("scene.mesh", "path contains a NUL byte")]


def test_preset_merges_over_a_base_and_replaces_region_tables(tmp_path):
    base = with_values(Settings(), {"render.exposure": 2.0, "gosselin.regions.nose.kernel_size": 3.0})
    p = tmp_path / "a.json"
    p.write_text(json.dumps({"schema_version": 1, "render": {"width": 64}, "gosselin": {"regions": {"ears": {}}}}))
    s = load_preset(p, base)
    assert s.render.width == 64 and s.render.exposure == 2.0  # merged over the base
    assert set(s.gosselin.regions) == {"ears"}  # a region table is replaced, not merged


@pytest.mark.parametrize("raw,where,msg", [
    (b"\xff\xfe{\x00}\x00", "<file>", "UTF-16 text: save the preset as UTF-8"),
    (b'{"schema_version": 1,\n  "render": }', "<json>", "line 2 column 13: Expecting value"),
    (b"\xef\xbb\xbf" + b'{"schema_version": 1, "render": {"width": 48}}', None, None),
    (b'{"a": \xe9}', "<file>", "not UTF-8 text (byte 0xe9 at offset 6)"),
    (b"[1, 2]", "<root>", "a preset is a JSON object"),
    (b'{"render": {"width": 48}}', "schema_version", "missing"),
    (b"[" * 100000 + b"]" * 100000, "<json>", "nested too deeply"),
])
def test_preset_file_errors_are_one_clear_line(tmp_path, raw, where, msg):
    p = tmp_path / "bad\udcff.json" if where == "<root>" else tmp_path / "bad.json"
    try:
        p.write_bytes(raw)
    except (UnicodeEncodeError, OSError):
        p = tmp_path / "bad.json"
        p.write_bytes(raw)
    if where is None:
        assert load_preset(p).render.width == 48  # a UTF-8 byte-order mark is fine
        return
    e = _errors(load_preset, p)
    assert e.errors == [(where, msg)], e.errors
    assert "\n" not in str(e) and str(e).startswith(str(p).encode("utf-8", "backslashreplace").decode())
    assert _errors(load_preset, tmp_path / "missing.json").errors[0][0] == "<file>"


def test_profile_warnings_name_the_problem():
    g = lambda v, w: {"variance": v, "weights": w}
    d = with_values(Settings(), {"deon.gaussians": [g(0.0, [0.5, 1.0, 0.5]), g(0.0, [0.49, 0.0, 0.49])]}).deon
    assert S.profile_warnings(d) == [  # R and B sum to 0.99: within the 2 % that is not warned about
        "variances are not strictly ascending: the hierarchical blur clamps v_i - v_(i-1) to 0",
        "a variance is 0: that Gaussian is the irradiance itself"]
    d = with_values(Settings(), {"deon.gaussians": [g(0.1, [1.019, 1.021, 0.97]), g(0.2, [0.0, 0.0, 0.0])]}).deon
    assert S.profile_warnings(d) == ["channel G weights sum to 1.021: the profile gains energy",
                                     "channel B weights sum to 0.970: the profile loses energy"]
    assert S.profile_warnings(Settings().deon) == []


def test_more_rules_the_mutation_run_found_unpinned(tmp_path):
    s = Settings()
    e = _errors(with_values, s, {"ssss.taps": 8})
    assert e.errors == [("ssss.taps", "must be odd (a centre tap)")]
    e = _errors(S.validate, [1, 2])
    assert e.errors[0][0] == "<root>" and str(e).startswith("<root>: ")
    e = SettingsError([("a", "b")], "f.json")
    assert e.source == "f.json" and e.errors == [("a", "b")]
    with pytest.raises(KeyError) as ki:
        S.get_path(s, "render.nope")
    assert ki.value.args == ("render.nope",)
    # value_key: sorted keys, dict values converted
    assert S.value_key(s, "lights.0") == json.dumps(S.to_dict(s)["lights"][0], sort_keys=True)
    keys = list(json.loads(S.value_key(s, "lights.0")))
    assert keys == sorted(keys) and len(keys) > 3  # sorted, not the model's field order
    assert json.loads(S.value_key(s, "specular.per_region"))["nose"] == {"m": 0.28, "rho_s": 0.24}
    # replacing a list item; a new key in a region table; values containing '='
    light = dict(S.to_dict(s)["lights"][0], intensity=0.25)
    assert with_values(s, {"lights.0": light}).lights[0].intensity == 0.25
    few = load_preset_text(tmp_path, {"schema_version": 1, "gosselin": {"regions": {"ears": {}}}})
    assert set(with_values(few, {"gosselin.regions.nose": {"kernel_size": 2.0}}).gosselin.regions) == {"ears", "nose"}
    assert S.parse_assignments(["scene.mesh=a=b.glb"]) == {"scene.mesh": "a=b.glb"}
    msg = _errors(S.parse_value, "9" * 5000).errors[0][1]
    assert msg.startswith("Exceeds the limit") and ";" not in msg


def load_preset_text(tmp_path, data, name="p.json"):
    p = tmp_path / name
    p.write_text(json.dumps(data))
    return load_preset(p)


def test_preset_edge_cases_found_by_mutation(tmp_path):
    # per-region tables are replaced by a preset's, not merged
    s = load_preset_text(tmp_path, {"schema_version": 1, "specular": {"per_region": {"nose": {"m": 0.5}}}})
    assert set(s.specular.per_region) == {"nose"}
    # empty and non-text scene paths reach validation (not a crash, not the preset's folder)
    e = _errors(load_preset_text, tmp_path, {"schema_version": 1, "scene": {"mesh": ""}})
    assert e.errors == [("scene.mesh", "path is empty")]
    e = _errors(load_preset_text, tmp_path, {"schema_version": 1, "scene": {"mesh": 5}})
    assert e.errors[0][0] == "scene.mesh"
    # UTF-16 big-endian too; a missing file names the preset and its path
    (tmp_path / "be.json").write_bytes(b"\xfe\xff\x00{\x00}")
    assert _errors(load_preset, tmp_path / "be.json").errors == [("<file>", "UTF-16 text: save the preset as UTF-8")]
    e = _errors(load_preset, tmp_path / "missing.json")
    assert e.source == str(tmp_path / "missing.json") and "preset" in e.errors[0][1]
    # save_preset writes the payload it is given, indented by two spaces
    save_preset(Settings(), tmp_path / "t.json", data={"schema_version": 1, "render": {"width": 64}})
    assert (tmp_path / "t.json").read_text() == '{\n  "schema_version": 1,\n  "render": {\n    "width": 64\n  }\n}\n'
