"""Light-space matrices of seed 000 eq. (1)-(6), the eq. (7) test, and the orbit camera."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from skinviewer.core.settings import CameraSettings
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


def test_orbit_view_frames_the_mesh():
    cam = CameraSettings(yaw=30, pitch=10)
    v = orbit_view(cam, np.array([1.0, 2.0, 3.0]), 5.0, (200, 100))
    clip = v.view_proj @ np.array([1.0, 2.0, 3.0, 1.0])
    assert np.allclose(clip[:2] / clip[3], 0, atol=1e-5)  # the centre is in the middle of the frame
    assert -1 < clip[2] / clip[3] < 1
    assert v.key() != orbit_view(CameraSettings(yaw=31, pitch=10), np.array([1.0, 2.0, 3.0]), 5.0, (200, 100)).key()
