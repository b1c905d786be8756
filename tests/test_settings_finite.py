"""NaN and +-Inf are refused in every numeric setting. The paths are generated from the pydantic model
(every field of every section, list item and dict entry, optional fields left at None included), so a
field added later is covered without editing this file (issue 36: removing one isfinite check from
settings.py let a NaN Gaussian weight through 108 tests)."""
from __future__ import annotations

import math
import types
import typing

import pytest
from pydantic import BaseModel

from skinviewer.ground.settings import Settings, SettingsError, to_dict, validate


def _has_float(ann) -> bool:
    """Whether a field's annotation holds a float somewhere (float, Vec3, Optional[...], lists, dicts)."""
    if ann is float:
        return True
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return any(_has_float(f.annotation) for f in ann.model_fields.values())
    return any(_has_float(a) for a in typing.get_args(ann))


def _float_leaf(ann) -> int | None:
    """For an Optional float or vec3 left at None: how many components to set (1 or 3), else None."""
    args = [a for a in typing.get_args(ann) if a is not type(None)]
    if typing.get_origin(ann) not in (typing.Union, types.UnionType) or len(args) != 1:
        return None
    a = args[0]
    if a is float:
        return 1
    if typing.get_origin(a) is tuple and all(x is float for x in typing.get_args(a)):
        return len(typing.get_args(a))
    return None


def numeric_paths() -> list[tuple[str, str]]:
    """(dotted path, kind) of every float-valued leaf of the default Settings: kind 'leaf' for a value
    present in the defaults, 'none1' / 'none3' for an optional float / vec3 left at None."""
    out: list[tuple[str, str]] = []

    def walk(model: BaseModel, data, prefix: str):
        for name, f in type(model).model_fields.items():
            value, raw = getattr(model, name), data[name]
            path = f"{prefix}{name}"
            if isinstance(value, BaseModel):
                walk(value, raw, path + ".")
            elif value is None:
                n = _float_leaf(f.annotation)
                if n:
                    out.append((path, f"none{n}"))
            elif _has_float(f.annotation):
                leaves(value, raw, path, f.annotation)

    def leaves(value, raw, path, ann):
        if isinstance(value, BaseModel):
            walk(value, raw, path + ".")
        elif isinstance(value, dict):
            for k in value:
                leaves(value[k], raw[k], f"{path}.{k}", ann)
        elif isinstance(value, (list, tuple)):
            for i, v in enumerate(value):
                leaves(v, raw[i], f"{path}.{i}", ann)
        elif isinstance(value, (int, float)) and not isinstance(value, bool) and _has_float(ann):
            # a float field (a default written as 1 is an int here): int-only fields refuse NaN by type
            out.append((path, "leaf"))

    s = Settings()
    walk(s, to_dict(s), "")
    return out


PATHS = numeric_paths()


def _assign(data: dict, path: str, value) -> None:
    parts = path.split(".")
    cur = data
    for p in parts[:-1]:
        cur = cur[int(p)] if isinstance(cur, list) else cur[p]
    last = parts[-1]
    if isinstance(cur, list):
        cur[int(last)] = value
    else:
        cur[last] = value


def test_the_walk_reaches_every_section_lists_and_dicts():
    names = {p for p, _ in PATHS}
    sections = {p.split(".")[0] for p in names}
    # every section of the model that has a float field is reached (a new section is picked up)
    with_floats = {n for n, f in Settings.model_fields.items() if _has_float(f.annotation)}
    assert with_floats <= sections, with_floats - sections
    assert "deon.gaussians.0.weights.1" in names and "lights.0.intensity" in names  # list items
    assert any(p.startswith("specular.per_region.") for p in names)  # dict entries
    assert len(PATHS) > 100


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf], ids=["nan", "inf", "-inf"])
def test_every_numeric_setting_refuses_nan_and_inf(bad):
    accepted = []
    for path, kind in PATHS:
        data = to_dict(Settings())
        if kind == "leaf":
            _assign(data, path, bad)
        else:
            n = int(kind[4:])
            _assign(data, path, bad if n == 1 else [bad] + [0.5] * (n - 1))
        try:
            validate(data)
        except SettingsError as exc:
            # the one-line error names the field
            assert any(p == path or p.startswith(path.rsplit(".", 1)[0]) for p, _ in exc.errors), (path, exc.errors)
            continue
        accepted.append(path)
    assert not accepted, f"{bad} accepted at: " + ", ".join(accepted)
