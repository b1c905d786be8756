"""Issue 35: hypothesis fuzz of the mesh loaders' text inputs — OBJ and MTL text, glTF JSON. Every
example either loads as a MeshData that can be rendered as given (finite positions, unit normals,
UVs in [0, 1], indices in range) or raises MeshError with one line: never another exception, never
a hang. Derandomised, a bounded number of examples (seconds)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from helpers import quad_gltf
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from skinviewer.scene.mesh import MeshData, MeshError, load_mesh

FUZZ = settings(max_examples=60, derandomize=True, deadline=None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])

_num = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=32),
                 st.integers(-5, 5).map(float), st.sampled_from([1e39, -1e39, 1e15, 0.0, -0.0]))
_numtext = st.one_of(_num.map(repr), st.sampled_from(["nan", "inf", "-inf", "1e999", "0x10", "", "1,5", "--1"]))
_index = st.one_of(st.integers(-6, 12), st.sampled_from([0, 2**31, -2**31, 10**20]))
_name = st.sampled_from(["skin.mtl", "missing.mtl", "../up.mtl", "/etc/hostname", "a b.mtl", "tex.png",
                         "missing.png", "fifo.png", "..", "", "bad.png"])


_corner = st.tuples(_index, st.one_of(st.none(), _index), st.one_of(st.none(), _index)).map(
    lambda c: "/".join([str(c[0])] + ([] if c[1] is None and c[2] is None else
                                      [("" if c[1] is None else str(c[1]))] + ([] if c[2] is None else [str(c[2])]))))
_face = st.lists(_corner, min_size=1, max_size=5).map(lambda cs: "f " + " ".join(cs))


_obj_line = st.one_of(
    st.tuples(_numtext, _numtext, _numtext).map(lambda t: "v " + " ".join(t)),
    st.tuples(_numtext, _numtext).map(lambda t: "vt " + " ".join(t)),
    st.tuples(_numtext, _numtext, _numtext).map(lambda t: "vn " + " ".join(t)),
    _face, _name.map(lambda n: f"mtllib {n}"), st.sampled_from(["usemtl skin", "usemtl nope", "g a", "o b",
                                                                     "s 1", "#", "\\", "f", "v", "vt"]),
    st.text(max_size=30).map(lambda t: t.replace("\n", " ")),
)
_VALID = ["v 0 0 0", "v 1 0 0", "v 1 1 0", "v 0 1 0", "vt 0 0", "vt 1 0", "vt 1 1", "vt 0 1",
          "f 1/1 2/2 3/3", "f 1/1 3/3 4/4"]
_mtl_line = st.one_of(st.sampled_from(["newmtl skin", "newmtl", "Kd 1 1 1", "Kd nan", "map_Kd", "Ns 1e999",
                                       "d 0.5"]),
                      _name.map(lambda n: f"map_Kd {n}"), st.tuples(_numtext, _numtext, _numtext).map(
                          lambda t: "Kd " + " ".join(t)), st.text(max_size=20).map(lambda t: t.replace("\n", " ")))


def check(m: MeshData) -> None:
    assert isinstance(m, MeshData)
    assert np.isfinite(m.positions).all() and np.isfinite(m.normals).all() and np.isfinite(m.uvs).all()
    assert np.allclose(np.linalg.norm(m.normals, axis=1), 1.0, atol=1e-3)
    assert m.uvs.min() >= -1e-3 and m.uvs.max() <= 1.001
    assert m.indices.size and int(m.indices.max()) < len(m.positions)
    assert all(isinstance(n, str) and "\n" not in n for n in m.notes)


def _load(path) -> None:
    try:
        m = load_mesh(path)
    except MeshError as exc:
        assert "\n" not in str(exc).strip() and "Traceback" not in str(exc), str(exc)
        return
    check(m)


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz") / "meshes"
    d.mkdir()
    from PIL import Image
    Image.new("RGB", (4, 4), (200, 120, 100)).save(d / "tex.png")
    (d / "bad.png").write_bytes(b"\x89PNG\r\n\x1a\n garbage")
    import os
    os.mkfifo(d / "fifo.png")
    (d.parent / "up.mtl").write_text("newmtl skin\nmap_Kd tex.png\n")
    return d


@FUZZ
@given(lines=st.lists(_obj_line, max_size=25), keep_valid=st.booleans(), mtl=st.lists(_mtl_line, max_size=8))
def test_obj_and_mtl_text(folder, lines, keep_valid, mtl):
    (folder / "skin.mtl").write_text("\n".join(mtl) + "\n", encoding="utf-8", errors="surrogatepass")
    body = (_VALID if keep_valid else []) + lines
    (folder / "m.obj").write_bytes("\n".join(body).encode("utf-8", "surrogatepass"))
    _load(folder / "m.obj")


def _base_gltf() -> dict:
    d, _ = quad_gltf(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32))
    return {**d,
            "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
            "textures": [{"source": 0}], "images": [{"uri": "tex.png"}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2,
                                        "material": 0}]}],
            "nodes": [{"mesh": 0, "children": [1]}, {"mesh": 0, "translation": [1, 0, 0]}],
            "scenes": [{"nodes": [0]}], "scene": 0}


_json = st.recursive(st.one_of(st.none(), st.booleans(), st.integers(-3, 2**33), _num.filter(math.isfinite),
                               _name, st.text(max_size=8)),
                     lambda kids: st.one_of(st.lists(kids, max_size=3), st.dictionaries(st.text(max_size=6), kids,
                                                                                        max_size=3)),
                     max_leaves=8)


def _paths(d, prefix=()):
    yield prefix
    if isinstance(d, dict):
        for k, v in d.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(d, list):
        for i, v in enumerate(d):
            yield from _paths(v, prefix + (i,))


@FUZZ
@given(data=st.data())
def test_gltf_json(folder, data):
    tree = _base_gltf()
    paths = [p for p in _paths(tree) if p]
    for _ in range(data.draw(st.integers(1, 4))):
        path = data.draw(st.sampled_from(paths))
        parent = tree
        try:
            for k in path[:-1]:
                parent = parent[k]
            if data.draw(st.booleans()) and isinstance(parent, dict):
                parent.pop(path[-1], None)
            else:
                parent[path[-1]] = data.draw(_json)
        except (KeyError, IndexError, TypeError):
            continue
    (folder / "m.gltf").write_text(json.dumps(tree))
    _load(folder / "m.gltf")
