"""Settings model, presets (round trip, errors by path, atomic save) and --set parsing."""
from __future__ import annotations

import json
import os

import pytest

from skinviewer.ground import paths
from skinviewer.ground.settings import (
    Settings,
    SettingsError,
    load_preset,
    parse_assignments,
    profile_warnings,
    save_preset,
    to_dict,
    validate,
    with_values,
)


def test_round_trip(tmp_path):
    s = with_values(Settings(), {"technique": "gosselin", "lights.0.intensity": 4.5, "deon.mix": 0.25,
                                 "gosselin.regions.ears.kernel_size": 3.0, "specular.per_region.lips": {"m": 0.2}})
    p = tmp_path / "p.json"
    save_preset(s, p)
    assert load_preset(p) == s
    assert json.loads(p.read_text())["schema_version"] == 1


def test_bad_preset_lists_every_invalid_field(tmp_path):
    p = tmp_path / "bad.json"
    p.write_text(json.dumps({"schema_version": 1, "technique": "raytrace", "lights": [{"intensity": -1}],
                             "deon": {"mix": 2.0, "gaussians": [{"variance": 1.0, "weights": [1, 1, "x"]}]},
                             "camera": {"pitch": 120}, "nonsense": 3}))
    with pytest.raises(SettingsError) as exc:
        load_preset(p)
    got = {path for path, _ in exc.value.errors}
    assert {"technique", "lights.0.intensity", "deon.mix", "deon.gaussians.0.weights.2", "camera.pitch",
            "nonsense"} <= got, got
    assert str(p) in str(exc.value)


@pytest.mark.parametrize("text,where", [("{not json", "<json>"), ("[1, 2]", "<root>"), ('{"technique": "deon"}', "schema_version"),
                                        ('{"schema_version": 99}', "schema_version")])
def test_malformed_presets(tmp_path, text, where):
    p = tmp_path / "m.json"
    p.write_text(text)
    with pytest.raises(SettingsError) as exc:
        load_preset(p)
    assert any(where in path or where in msg for path, msg in exc.value.errors), exc.value.errors


def test_missing_preset_file(tmp_path):
    with pytest.raises(SettingsError, match="cannot read"):
        load_preset(tmp_path / "nope.json")


def test_partial_preset_overrides_defaults(tmp_path):
    p = tmp_path / "partial.json"
    p.write_text(json.dumps({"schema_version": 1, "deon": {"mix": 0.1}}))
    s = load_preset(p)
    assert s.deon.mix == 0.1 and s.deon.gaussians == Settings().deon.gaussians


def test_save_is_atomic(tmp_path, monkeypatch):
    p = tmp_path / "keep.json"
    save_preset(Settings(), p)
    before = p.read_text()

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", boom)
    with pytest.raises(OSError):
        save_preset(with_values(Settings(), {"deon.mix": 0.9}), p)
    assert p.read_text() == before
    assert [f.name for f in tmp_path.iterdir()] == ["keep.json"]  # no temporary left behind


def test_set_parsing_and_errors():
    a = parse_assignments(["lights.0.intensity=2", "deon.tsm=off", "camera.target=1,2,3", "technique=phong"])
    assert a == {"lights.0.intensity": 2, "deon.tsm": False, "camera.target": [1, 2, 3], "technique": "phong"}
    s = with_values(Settings(), a)
    assert s.camera.target == (1.0, 2.0, 3.0)
    with pytest.raises(SettingsError, match="no such setting"):
        with_values(Settings(), {"lights.0.nope": 1})
    with pytest.raises(SettingsError, match="lights.0.intensity"):
        with_values(Settings(), {"lights.0.intensity": "bright"})
    with pytest.raises(SettingsError):
        parse_assignments(["novalue"])


@pytest.mark.parametrize("assign", [{"lights.0.intensity": float("nan")}, {"render.width": 10**6},
                                    {"lights.0.direction": [0, 0, 0]}, {"deon.gaussians": []},
                                    {"shadow.map_size": 3}, {"specular.m": -0.1}])
def test_absurd_values_refused(assign):
    with pytest.raises(SettingsError):
        with_values(Settings(), assign)


def test_profile_warnings():
    s = with_values(Settings(), {"deon.gaussians": [{"variance": 1.0, "weights": [2, 0.5, 1]},
                                                    {"variance": 0.5, "weights": [0, 0.5, 0]}]})
    w = profile_warnings(s.deon)
    assert any("ascending" in x for x in w) and any("channel R" in x and "gains" in x for x in w)
    assert profile_warnings(Settings().deon) == []  # the d'Eon table is normalised per channel


def test_shipped_presets_are_valid():
    files = sorted(paths.presets_dir().glob("*.json"))
    assert files, "presets/ is empty"
    for f in files:
        s = load_preset(f)
        assert validate(to_dict(s)) == s


def test_saved_files_get_ordinary_permissions(tmp_path):
    """Atomic writes go through a private temporary file; the result is readable like a plain write."""
    p = tmp_path / "perm.json"
    save_preset(Settings(), p)
    umask = os.umask(0)
    os.umask(umask)
    assert p.stat().st_mode & 0o777 == 0o666 & ~umask
    p.chmod(0o640)
    save_preset(Settings(), p)  # replacing keeps the file's own mode
    assert p.stat().st_mode & 0o777 == 0o640
