"""Mesh loading (glTF/GLB/OBJ/PLY), UVs, normals, tangents, framing, and the shared head scan."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh
from conftest import LPS_GLB, NEEDS_SCAN

from skinviewer.scene.mesh import (
    MeshData,
    MeshError,
    compute_tangents,
    load_mesh,
    load_texture_maps,
    smooth_seam_normals,
    vertex_normals,
)


def _quad_with_uv(tmp_path, ext):
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    uv = v[:, :2].copy()
    tm = trimesh.Trimesh(v, f, visual=trimesh.visual.TextureVisuals(uv=uv), process=False)
    p = tmp_path / f"quad.{ext}"
    tm.export(p)
    return p


@pytest.mark.parametrize("ext", ["obj", "glb", "ply"])
def test_formats_with_uvs(tmp_path, ext):
    p = _quad_with_uv(tmp_path, ext)
    m = load_mesh(p)
    assert m.indices.shape == (2, 3)
    assert m.uvs.min() >= 0 and m.uvs.max() <= 1
    assert np.allclose(np.abs(m.normals[:, 2]), 1, atol=1e-5)
    assert np.all(np.isfinite(m.tangents))
    # tangent follows +u: the quad's u runs along +x
    assert np.allclose(np.abs(m.tangents[:, 0]), 1, atol=1e-4)


def test_mesh_without_uvs_gets_an_atlas_or_is_refused(tmp_path):
    tm = trimesh.creation.icosphere(subdivisions=2)
    p = tmp_path / "ball.ply"
    tm.export(p)
    with pytest.raises(MeshError, match="no texture coordinates"):
        load_mesh(p, auto_uv=False)
    m = load_mesh(p)
    assert any("xatlas" in n for n in m.notes)
    assert m.uvs.shape[0] == m.positions.shape[0] and m.uvs.min() >= 0 and m.uvs.max() <= 1


def test_unreadable_and_empty_files(tmp_path):
    with pytest.raises(MeshError, match="not found"):
        load_mesh(tmp_path / "missing.glb")
    bad = tmp_path / "bad.glb"
    bad.write_bytes(b"not a mesh at all")
    with pytest.raises(MeshError):
        load_mesh(bad)


def test_degenerate_uvs_give_finite_tangents():
    p = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], np.float32)
    uv = np.zeros((4, 2), np.float32)  # every UV triangle has zero area
    idx = np.array([[0, 1, 2], [1, 3, 2]])
    n = vertex_normals(p, idx)
    t = compute_tangents(p, n, uv, idx)
    assert np.all(np.isfinite(t)) and np.allclose(np.linalg.norm(t[:, :3], axis=1), 1, atol=1e-5)
    assert np.allclose(np.sum(t[:, :3] * n, axis=1), 0, atol=1e-5)


def test_bad_texture_map_is_refused(tmp_path):
    m = MeshData(np.zeros((3, 3)), np.tile([0, 0, 1.0], (3, 1)), np.zeros((3, 2)), np.array([[0, 1, 2]]))
    bad = tmp_path / "albedo.png"
    bad.write_bytes(b"garbage")
    with pytest.raises(MeshError, match="cannot read image"):
        load_texture_maps(m, albedo=bad)


def test_normals_split_along_a_uv_seam_are_made_continuous():
    """Two copies of a vertex (a UV seam) whose normals differ by 20 deg take their mean; copies 90 deg
    apart (a cube's edge: a modelled crease) keep theirs; single vertices are untouched."""
    tilt = np.radians(10.0)
    P = np.array([[0, 0, 0], [0, 0, 0], [1, 0, 0], [2, 0, 0], [2, 0, 0]], float)
    N = np.array([[np.sin(tilt), 0, np.cos(tilt)], [-np.sin(tilt), 0, np.cos(tilt)], [0, 0, 1],
                  [1, 0, 0], [0, 0, 1]], float)
    out, changed = smooth_seam_normals(P, N)
    assert np.allclose(out[0], [0, 0, 1]) and np.allclose(out[1], [0, 0, 1]) and changed == 2
    assert np.allclose(out[2:], N[2:])


@NEEDS_SCAN
def test_lee_perry_smith_has_no_normal_step_along_its_seams():
    """The shared scan's file splits its normals along every UV seam (6 deg median, 34 at most: a
    shading line down the back of the head in every technique); loaded, each point has one normal."""
    from skinviewer.scene.mesh import position_ids
    m = load_mesh(LPS_GLB)
    ids = position_ids(m.positions)
    order = np.argsort(ids, kind="stable")
    same = ids[order][1:] == ids[order][:-1]
    a, b = m.normals[order][1:][same], m.normals[order][:-1][same]
    assert same.sum() > 400 and (a * b).sum(1).min() > 0.9999
    assert any("UV seams" in n for n in m.notes)


@NEEDS_SCAN
def test_lee_perry_smith_loads():
    m = load_mesh(LPS_GLB)
    assert m.positions.shape == (9279, 3) and m.indices.shape == (17684, 3)
    assert 0 <= m.uvs.min() and m.uvs.max() <= 1
    lo, hi = m.bounds
    # Y up, facing +Z: the nose tip is the frontmost point and sits in the upper half
    nose = m.positions[np.argmax(m.positions[:, 2])]
    assert nose[1] > (lo[1] + hi[1]) / 2 - 0.5
    assert np.all(np.isfinite(m.tangents)) and np.all(np.isfinite(m.normals))


@NEEDS_SCAN
def test_lee_perry_smith_renders(renderer):
    from helpers import assert_all_finite

    from skinviewer.ground.settings import Settings, with_values
    s = with_values(Settings(), {"scene.mesh": str(LPS_GLB), "scene.mm_per_unit": 48.0, "technique": "phong",
                                 "render.width": 96, "render.height": 96, "shadow.map_size": 256})
    renderer.render(s)
    img = renderer.image(s).astype(float)
    assert img.std() > 10  # a lit head, not a blank frame
    assert_all_finite(renderer, s)


def test_embedded_textures_are_used(tmp_path):
    from PIL import Image
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    img = np.zeros((8, 8, 3), np.uint8)
    img[0] = (255, 0, 0)  # the image's top row: v = 1 in glTF's flipped convention
    mat = trimesh.visual.material.PBRMaterial(baseColorTexture=Image.fromarray(img),
                                              normalTexture=Image.fromarray(np.full((8, 8, 3), [128, 128, 255], np.uint8)))
    tm = trimesh.Trimesh(v, f, visual=trimesh.visual.TextureVisuals(uv=v[:, :2], material=mat), process=False)
    p = tmp_path / "textured.glb"
    tm.export(p)
    m = load_mesh(p)
    assert m.albedo is not None and m.albedo.shape == (8, 8, 3) and m.normal_map is not None
    assert m.albedo[-1, 0, 0] == 1.0 and m.albedo[0, 0, 0] == 0.0  # row 0 at v = 0
    assert any("base colour texture" in n for n in m.notes)
    # the red texel row maps to the vertices with v = 1 (the top edge of the quad)
    top = m.uvs[:, 1].max()
    assert np.isclose(top, 1.0)


def test_is_closed_welds_seams_and_finds_borders():
    """scene.back_faces = auto culls on closed meshes: vertices split at UV seams still close the
    surface (welded by position, also when two copies straddle a rounding boundary); one missing
    triangle opens it; the built-in slab is open, the default head is closed."""
    import trimesh

    from skinviewer.scene.mesh import culls_back_faces, is_closed
    from skinviewer.scene.scenes import build_scene
    sp = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    p, f = np.asarray(sp.vertices, np.float64), np.asarray(sp.faces)
    assert is_closed(p, f) and not is_closed(p, f[1:])
    # split every vertex of the first 40 faces (a UV seam), copies off by less than a float32 step
    q = p.copy()
    extra = f[:40].ravel()
    p2 = np.vstack([q, q[extra] + 3e-8])
    f2 = f.copy()
    f2[:40] = len(q) + np.arange(120).reshape(40, 3)
    assert is_closed(p2, f2)
    laser = build_scene("laser").mesh
    assert not is_closed(laser.positions, laser.indices)
    head = build_scene("head", 1).mesh  # the default detail (detail 0's coarse ears leave 80 rim edges open)
    assert is_closed(head.positions, head.indices)
    assert culls_back_faces("auto", True) and not culls_back_faces("auto", False)
    assert culls_back_faces("cull", False) and not culls_back_faces("show", True)


def test_generated_uvs_keep_one_normal_per_point(tmp_path):
    """A mesh without UVs is cut into xatlas charts; the copies of a vertex on two charts must keep
    one normal (the welded surface's), else every chart border is a shading line in every technique."""
    import trimesh

    from skinviewer.scene.mesh import position_ids
    path = tmp_path / "s.obj"
    trimesh.creation.icosphere(3, 50.0).export(path)
    m = load_mesh(path)
    assert any("xatlas" in n for n in m.notes)
    ids = position_ids(m.positions)
    order = np.argsort(ids, kind="stable")
    same = ids[order][1:] == ids[order][:-1]
    a, b = m.normals[order][1:][same], m.normals[order][:-1][same]
    assert same.sum() > 20  # the atlas did split vertices along chart borders
    assert (a * b).sum(1).min() > 1.0 - 1e-6  # float32 normals
    radial = m.positions / np.linalg.norm(m.positions, axis=1, keepdims=True)
    assert (m.normals * radial).sum(1).min() > 0.99  # and that normal is the sphere's
