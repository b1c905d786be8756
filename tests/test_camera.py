"""Light-space matrices of seed 000 eq. (1)-(6), the eq. (7) test, and the orbit camera."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from skinviewer.ground.settings import CameraSettings
from skinviewer.scene.camera import (
    light_basis,
    light_projection_rowvec,
    light_space,
    light_view_rowvec,
    orbit_view,
)


def test_light_basis_is_orthonormal_and_looks_at_target():
    L = np.array([3.0, 4.0, 5.0])
    X, Y, Z = light_basis(L, np.zeros(3))
    M = np.stack([X, Y, Z])
    assert np.allclose(M @ M.T, np.eye(3), atol=1e-12)
    assert np.allclose(Z, -L / np.linalg.norm(L))  # eq. (2)
    # eq. (1): the light's own position maps to the origin of light space
    v = np.append(L, 1.0) @ light_view_rowvec(L, np.zeros(3))
    assert np.allclose(v[:3], 0, atol=1e-12)


def test_projection_eq5_depth_range():
    near, far = 2.0, 10.0
    P = light_projection_rowvec(math.radians(60), 1.0, 1.0, near, far)
    for z, expect in ((near, 0.0), (far, 1.0)):
        p = np.array([0.0, 0.0, z, 1.0]) @ P
        assert math.isclose(p[2] / p[3], expect, abs_tol=1e-12)


def _light(kind, **kw):
    return SimpleNamespace(kind=kind, direction=kw.get("direction", (0, 0, 1)), position=kw.get("position", (0, 0, 50)))


def test_shadow_matrices_fit_bounds_and_order_depths():
    center, radius = np.zeros(3), 10.0
    for light in (_light("point", position=(0, 0, 40)), _light("directional", direction=(0.2, 0.3, 1.0))):
        ls = light_space(light, center, radius)
        # points on the bounding sphere project inside the map and inside [0, 1] depth
        rng = np.random.default_rng(1)
        d = rng.normal(size=(500, 3))
        pts = center + radius * d / np.linalg.norm(d, axis=1, keepdims=True)
        clip = np.hstack([pts, np.ones((500, 1))]) @ ls.gl_matrix.T
        ndc = clip[:, :3] / clip[:, 3:]
        assert np.all(np.abs(ndc[:, :2]) <= 1.0 + 1e-9)
        depth = ls.depth(pts)
        assert np.all((depth >= 0) & (depth <= 1))
        # closer to the light -> smaller stored depth (what eq. 7 compares)
        towards = ls.position - center
        towards /= np.linalg.norm(towards)
        near_pt, far_pt = center + towards * 5, center - towards * 5
        assert ls.depth(near_pt[None])[0] < ls.depth(far_pt[None])[0]


def test_point_light_inside_bounds_is_backed_off():
    ls = light_space(_light("point", position=(0, 0, 1)), np.zeros(3), 10.0)
    assert np.linalg.norm(ls.position) > 10.0
    assert np.all(np.isfinite(ls.gl_matrix))


def test_point_light_frustum_narrows_to_the_vertices():
    """A point light beside a mesh that fills only part of its bounding sphere (a 2 x 20 x 2 rod, radius
    ~10): the frustum is the cone that holds the vertices, so its texels are finer, and every vertex
    still projects inside the map."""
    rng = np.random.default_rng(3)
    pts = rng.uniform(-1.0, 1.0, (400, 3)) * np.array([1.0, 10.0, 1.0])
    center, radius = np.zeros(3), float(np.linalg.norm(pts, axis=1).max())
    light = _light("point", position=(0, 0, 12))
    wide, tight = light_space(light, center, radius), light_space(light, center, radius, pts)
    assert tight.extent < 0.7 * wide.extent
    clip = np.hstack([pts, np.ones((len(pts), 1))]) @ tight.gl_matrix.T
    ndc = clip[:, :3] / clip[:, 3:]
    assert np.all(np.abs(ndc[:, :2]) <= 1.0) and np.abs(ndc[:, :2]).max() > 0.9


def test_orbit_view_frames_the_mesh():
    cam = CameraSettings(yaw=30, pitch=10)
    v = orbit_view(cam, np.array([1.0, 2.0, 3.0]), 5.0, (200, 100))
    clip = v.view_proj @ np.array([1.0, 2.0, 3.0, 1.0])
    assert np.allclose(clip[:2] / clip[3], 0, atol=1e-5)  # the centre is in the middle of the frame
    assert -1 < clip[2] / clip[3] < 1
    assert v.key() != orbit_view(CameraSettings(yaw=31, pitch=10), np.array([1.0, 2.0, 3.0]), 5.0, (200, 100)).key()


def _bust(shoulder_width: float = 400.0):
    """A head (sphere r 100 at y 0) on a neck (cylinder r 50) on shoulders (a wide box), in mm."""
    import trimesh
    head = trimesh.creation.icosphere(subdivisions=4, radius=100.0)
    neck = trimesh.creation.cylinder(radius=50.0, height=120.0, sections=48)
    neck.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    neck.apply_translation([0, -140.0, 0])
    shoulders = trimesh.creation.box(extents=[shoulder_width, 150.0, 200.0])
    shoulders.apply_translation([0, -260.0, 0])
    parts = [head, trimesh.remesh.subdivide_to_size(neck.vertices, neck.faces, 10.0),
             trimesh.remesh.subdivide_to_size(shoulders.vertices, shoulders.faces, 20.0)]
    return np.concatenate([p.vertices if hasattr(p, "vertices") else p[0] for p in parts])


def test_portrait_frame_finds_the_head_above_the_shoulders():
    from skinviewer.scene.mesh import portrait_frame
    pts = _bust()
    centre, radius = portrait_frame(pts)
    whole_r = np.linalg.norm(pts - 0.5 * (pts.min(0) + pts.max(0)), axis=1).max()
    # framed on the head (and the neck slice under it), not on the shoulders
    assert radius < 0.6 * whole_r
    assert -60.0 < centre[1] < 10.0 and abs(centre[0]) < 1e-6
    assert 100.0 <= radius <= 160.0
    # the head fills the frame much more than with the bounding sphere
    cam = CameraSettings(yaw=0, pitch=0)
    whole_c = 0.5 * (pts.min(0) + pts.max(0))
    v = orbit_view(cam, whole_c, whole_r, (100, 100), frame=(centre, radius))
    clip = v.view_proj @ np.array([0.0, 100.0, 0.0, 1.0])     # top of the head: in the upper frame
    assert 0.4 < clip[1] / clip[3] < 1.0
    clip = v.view_proj @ np.array([0.0, -300.0, 0.0, 1.0])    # bottom of the shoulders: out of the frame
    assert clip[1] / clip[3] < -1.0


def test_portrait_frame_leaves_compact_meshes_alone():
    import trimesh

    from skinviewer.scene.mesh import portrait_frame
    for pts in (trimesh.creation.icosphere(subdivisions=4, radius=3.0).vertices,
                trimesh.creation.box(extents=[4.0, 2.0, 3.0]).vertices,
                np.stack(np.meshgrid(np.linspace(-1, 1, 30), np.linspace(-1, 1, 30), [0.0]), -1).reshape(-1, 3)):
        centre, radius = portrait_frame(pts)
        c = 0.5 * (pts.min(0) + pts.max(0))
        assert np.allclose(centre, c) and radius == pytest.approx(np.linalg.norm(pts - c, axis=1).max())


def test_orbit_view_frames_the_frame_not_the_bounds():
    cam = CameraSettings(yaw=0, pitch=0)
    v = orbit_view(cam, np.zeros(3), 10.0, (100, 100), frame=(np.array([0.0, 4.0, 0.0]), 3.0))
    clip = v.view_proj @ np.array([0.0, 4.0, 0.0, 1.0])
    assert np.allclose(clip[:2] / clip[3], 0, atol=1e-5)
    # an explicit target and distance still win
    cam = CameraSettings(yaw=0, pitch=0, target=(1.0, 2.0, 3.0), distance=50.0)
    v = orbit_view(cam, np.zeros(3), 10.0, (100, 100), frame=(np.array([0.0, 4.0, 0.0]), 3.0))
    assert np.allclose(v.eye, [1.0, 2.0, 53.0])


def test_shared_scan_opens_as_a_portrait():
    from conftest import LPS_GLB

    from skinviewer.scene.mesh import load_mesh
    if not LPS_GLB.is_file():
        pytest.skip(f"shared Lee Perry-Smith scan not present at {LPS_GLB}")
    m = load_mesh(LPS_GLB)
    centre, radius = m.frame
    assert radius < 0.6 * m.radius                       # the bust's shoulders are left out
    nose = m.positions[np.argmax(m.positions[:, 2])]
    crown = m.positions[np.argmax(m.positions[:, 1])]
    assert np.linalg.norm(nose - centre) < radius and np.linalg.norm(crown - centre) <= radius + 1e-6
    v = orbit_view(CameraSettings(yaw=0, pitch=5), m.center, m.radius, (100, 100), frame=m.frame)
    lo = m.positions[np.argmin(m.positions[:, 1])]
    clip = v.view_proj @ np.append(lo, 1.0)
    assert clip[1] / clip[3] < -1.0                      # the bottom of the shoulders is out of frame
