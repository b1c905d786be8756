"""Hypothesis preset fuzz (issue 13): arbitrary JSON, mutated valid presets and raw bytes given to
``load_preset`` either load as valid Settings or raise SettingsError (one clear error list) — never
another exception. Bounded examples so CI stays fast; derandomized so failures reproduce."""
from __future__ import annotations

import json
import math

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from skinviewer.ground.settings import (
    Settings,
    SettingsError,
    load_preset,
    save_preset,
    to_dict,
)

FUZZ = settings(max_examples=150, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

_scalars = st.one_of(st.none(), st.booleans(), st.integers(min_value=-10**30, max_value=10**30),
                     st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=20),
                     st.sampled_from(["deon", "point", "a\x00b", "\ud800", "../x.obj", "", "-1"]))
_json = st.recursive(_scalars, lambda kids: st.one_of(st.lists(kids, max_size=5),
                                                     st.dictionaries(st.text(max_size=12), kids, max_size=5)),
                     max_leaves=25)


def _paths(d, prefix=()):
    if isinstance(d, dict):
        for k, v in d.items():
            yield prefix + (k,)
            yield from _paths(v, prefix + (k,))
    elif isinstance(d, list):
        for i, v in enumerate(d):
            yield prefix + (i,)
            yield from _paths(v, prefix + (i,))


BASE = to_dict(Settings())
BASE_PATHS = [p for p in _paths(BASE) if p[0] != "schema_version"]


def _set(d, path, value):
    cur = d
    for k in path[:-1]:
        cur = cur[k]
    cur[path[-1]] = value


def _load(tmp_path, raw: bytes):
    p = tmp_path / "fuzz.json"
    p.write_bytes(raw)
    try:
        s = load_preset(p)
    except SettingsError as exc:
        assert exc.errors and all(isinstance(m, str) and m for _, m in exc.errors)
        str(exc).encode("utf-8", "backslashreplace")  # printable as one line
        return None
    assert isinstance(s, Settings)
    # what loads is finite where it must be, and saves and loads back the same
    assert all(math.isfinite(c) for c in s.render.background)
    assert s.camera.target is None or all(math.isfinite(c) for c in s.camera.target)
    save_preset(s, tmp_path / "again.json")
    assert load_preset(tmp_path / "again.json") == s
    return s


@FUZZ
@given(mutations=st.lists(st.tuples(st.sampled_from(BASE_PATHS), _json), min_size=1, max_size=4))
def test_mutated_presets_load_or_are_refused(tmp_path, mutations):
    data = json.loads(json.dumps(BASE))
    for path, value in mutations:
        try:
            _set(data, path, value)
        except (KeyError, IndexError, TypeError):
            pass  # an earlier mutation replaced the parent
    _load(tmp_path, json.dumps(data, allow_nan=True).encode("utf-8", "surrogatepass"))


@FUZZ
@given(doc=_json)
def test_arbitrary_json_is_refused_cleanly(tmp_path, doc):
    raw = json.dumps({"schema_version": 1, "scene": doc, "lights": doc} if isinstance(doc, dict) else doc)
    _load(tmp_path, raw.encode("utf-8", "surrogatepass"))


@FUZZ
@given(raw=st.binary(max_size=200), keep=st.integers(min_value=0, max_value=400))
def test_arbitrary_bytes_and_truncations_are_refused_cleanly(tmp_path, raw, keep):
    good = json.dumps(BASE).encode()
    _load(tmp_path, raw)
    _load(tmp_path, good[:keep] + raw[:8])
