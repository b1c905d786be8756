"""Issue 28: each technique declares its settings section in its own module
(``ground/sections/<technique>.py``: every field's default, range, label, unit and tooltip together),
``TechniqueSections`` composes them into ``Settings`` (its field names are the techniques), the panel
shows the labels and tooltips from those declarations, and every preset keeps loading."""
from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest

from skinviewer.ground import sections
from skinviewer.ground.sections import TECHNIQUE_NAMES, TechniqueSections
from skinviewer.ground.sections.base import field_doc
from skinviewer.ground.settings import Settings, get_path, load_preset, save_preset, to_dict
from skinviewer.techniques import REGISTRY
from skinviewer.ui.fielddocs import FIELD_DOCS, LABELS, doc, label

ROOT = Path(__file__).resolve().parents[1]
PRESETS = sorted((ROOT / "presets").glob("*.json"))
# a full preset saved by the model before the sections moved out of settings.py (its key order)
BEFORE = Path(__file__).resolve().parent / "data" / "preset_schema1_before_sections.json"


def _leaves(data, prefix=""):
    """(dotted path, value) of every leaf of a preset's JSON (a partial light is filled in from the
    defaults, so each of its given keys is a leaf); other lists and per-region tables whole."""
    for k, v in data.items():
        path = f"{prefix}{k}"
        if isinstance(v, dict) and k not in ("regions", "per_region"):
            yield from _leaves(v, path + ".")
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v) and k == "lights":
            yield f"{path}.#", len(v)
            for i, x in enumerate(v):
                yield from _leaves(x, f"{path}.{i}.")
        else:
            yield path, v


def _jsonable(v):
    return json.loads(json.dumps(to_dict(v) if isinstance(v, Settings) else v, default=lambda m: m.model_dump(mode="json")))


@pytest.mark.parametrize("preset", PRESETS + [BEFORE], ids=lambda p: p.name)
def test_every_preset_loads_with_its_values(preset):
    data = json.loads(preset.read_text())
    s = load_preset(preset)
    for path, value in _leaves(data):
        assert _jsonable(get_path(s, path)) == value, f"{preset.name}: {path}"


def test_a_preset_saved_now_loads_back_the_same(tmp_path):
    s = load_preset(BEFORE)
    save_preset(s, tmp_path / "again.json")
    assert to_dict(load_preset(tmp_path / "again.json")) == to_dict(s) == json.loads(BEFORE.read_text())


def test_the_techniques_are_the_registry_sections():
    assert set(REGISTRY) == set(TECHNIQUE_NAMES)  # a technique's settings are the section of its name
    assert TECHNIQUE_NAMES == tuple(TechniqueSections.model_fields)
    for name in TECHNIQUE_NAMES:
        assert Settings.model_fields[name].annotation is TechniqueSections.model_fields[name].annotation
        cls = TechniqueSections.model_fields[name].annotation
        assert cls.__module__ == f"{sections.__name__}.{name}", f"{name}: declare its section in its own module"
    with pytest.raises(ValueError):
        Settings(technique="nope")


def test_settings_py_defines_no_technique_section():
    tree = ast.parse((ROOT / "skinviewer" / "ground" / "settings.py").read_text())
    classes = {n.name for n in ast.walk(tree) if isinstance(n, ast.ClassDef)}
    defined_here = classes & {TechniqueSections.model_fields[n].annotation.__name__ for n in TECHNIQUE_NAMES}
    assert not defined_here


def _section_fields():
    """(generic path, FieldInfo) of every field of the techniques' sections and their sub-models."""
    out = []

    def walk(model, prefix):
        for name, info in model.model_fields.items():
            out.append((f"{prefix}{name}", info))
            ann = info.annotation
            inner = [a for a in getattr(ann, "__args__", ()) if isinstance(a, type) and hasattr(a, "model_fields")]
            for m in inner:
                walk(m, f"{prefix}{name}.*.")
    for name in TECHNIQUE_NAMES:
        walk(TechniqueSections.model_fields[name].annotation, f"{name}.")
    return out


def test_the_panel_shows_what_the_sections_declare():
    declared = 0
    for path, info in _section_fields():
        d = field_doc(info)
        assert path not in FIELD_DOCS and path not in LABELS, f"{path}: declare it in its section, not in fielddocs"
        if d is None:
            continue
        declared += 1
        concrete = path.replace("*", "0" if path.startswith("deon.gaussians") else "ears")
        assert doc(concrete) == (d.unit, d.tip)
        assert label(concrete, path.rsplit(".", 1)[-1]) == (d.label or path.rsplit(".", 1)[-1].replace("_", " "))
    assert declared >= 36  # the fields fielddocs described when issue 28 moved them to their sections
    assert label("gosselin.regions.ears.kernel_size") == "kernel size"
    assert doc("deon.gaussians.3.variance")[0] == "mm²"
