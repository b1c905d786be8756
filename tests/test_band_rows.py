"""Issue 27: the rows each triangle reaches (kernel/gpu.band_rows: which triangles a row band draws) made per
corner instead of from a (T, 3) gather reduced along its rows (24-29 ms -> ~6 ms a view on the default head,
in the first band of every banded view pass): the same values as the direct formula, behind-eye vertices
included, for the camera and the unwrap."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from skinviewer.kernel.gpu import band_rows


def reference(positions, uvs, indices, space, matrix, rows):
    """The direct formula: project every vertex, gather each triangle's three rows, min and max."""
    if space == "uv":
        y = uvs[:, 1] * rows
        ok = np.ones(len(y), bool)
    else:
        h = np.c_[positions, np.ones(len(positions))] @ matrix.T
        ok = h[:, 3] > 1e-6
        y = (h[:, 1] / np.where(ok, h[:, 3], 1.0) * 0.5 + 0.5) * rows
    ty = y[indices]
    out = np.stack([ty.min(axis=1), ty.max(axis=1)], axis=1)
    out[~ok[indices].all(axis=1)] = (-np.inf, np.inf)
    return out


def test_band_rows_equal_the_direct_formula():
    rng = np.random.default_rng(7)
    n = 500
    positions = rng.normal(0.0, 3.0, (n, 3))
    uvs = rng.uniform(0.0, 1.0, (n, 2))
    indices = rng.integers(0, n, (900, 3))
    mesh = SimpleNamespace(positions=positions, uvs=uvs, indices=indices)
    scene = SimpleNamespace(lod_mesh=lambda lod: mesh)
    for k in range(6):
        matrix = rng.normal(0.0, 1.0, (4, 4))
        matrix[3] = (0.0, 0.0, 0.4 * (k - 2), 1.0)  # w = 0.4 (k - 2) z + 1: some vertices behind the eye
        got = band_rows(scene, 0, "camera", matrix, 240, {})
        want = reference(positions, uvs, indices, "camera", matrix, 240)
        assert np.isinf(want).any() == (k != 2)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)
        assert np.array_equal(np.isinf(got), np.isinf(want))
    got = band_rows(scene, 0, "uv", None, 1024, {})
    assert np.array_equal(got, reference(positions, uvs, indices, "uv", None, 1024))
