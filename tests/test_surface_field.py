"""physics.ground_truth.SurfaceField (issue 34: the truth session keeps the diffusion's wide part on a
surface lattice): the lattice reproduces a linear field exactly anywhere on the mesh (the interpolant is
linear and the lattice vertices are where they say), vertices shared by triangles are one point, and
Diffusion.exitance's local and wide parts add up to the whole."""
from __future__ import annotations

import numpy as np
import pytest

from skinviewer.physics import ground_truth as gt


def _grid(n: int = 6, size: float = 3.0) -> np.ndarray:
    xs, ys = np.meshgrid(np.linspace(0, size, n + 1), np.linspace(0, size, n + 1))
    V = np.stack([xs.ravel(), ys.ravel(), 0.1 * xs.ravel() * ys.ravel()], 1)
    F = []
    for i in range(n):
        for j in range(n):
            a = i * (n + 1) + j
            F += [[a, a + 1, a + n + 1], [a + 1, a + n + 2, a + n + 1]]
    return V[np.asarray(F)]


@pytest.mark.parametrize("h", [0.2, 0.37, 5.0])
def test_a_linear_field_is_reproduced_everywhere_including_edges_and_corners(h):
    tri = _grid()
    f = gt.SurfaceField(tri, h, channels=2)
    rng = np.random.default_rng(3)
    t = rng.integers(0, len(tri), 3000)
    b = rng.dirichlet([1, 1, 1], 3000)
    b[:7] = [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, 0.5, 0], [0, 0.5, 0.5], [0.5, 0, 0.5], [1 / 3, 1 / 3, 1 / 3]]
    ids, w = f.locate(t, b)
    assert np.allclose(w.sum(1), 1.0) and np.all(w >= 0)
    need = f.missing(ids)
    vt, vb = f.vertex_points(need)
    P = np.einsum("nk,nkd->nd", vb, tri[vt])
    A = np.array([[1.0, -2.0], [0.5, 3.0], [2.0, 0.25]])
    f.store(need, P @ A + 1.0)
    x = np.einsum("nk,nkd->nd", b, tri[t])
    assert np.allclose(f.interpolate(ids, w), x @ A + 1.0, atol=1e-12)
    assert len(f.missing(ids)) == 0  # nothing left to evaluate for these points


def test_shared_vertices_are_one_point_and_unevaluated_ones_are_refused():
    tri = _grid(n=4)
    f = gt.SurfaceField(tri, 0.5)
    welded = len(np.unique(f.canon))
    n = int(f.n[0])  # a 4 x 4 grid of squares cut in two: every triangle gets the same n
    assert np.all(f.n == n)
    assert welded == (4 * n + 1) ** 2 < len(f)  # the lattice of the whole square, each point once
    ids, w = f.locate(np.array([0]), np.array([[0.2, 0.3, 0.5]]))
    with pytest.raises(ValueError):
        f.interpolate(ids, w)
    f.store(f.missing(ids), np.ones((len(f.missing(ids)), 3)))
    assert f.evaluated == len(np.unique(f.canon[ids]))


def test_local_and_wide_parts_add_up_to_the_exitance():
    tri = _grid(n=8, size=6.0)
    el = gt.Elements(tri, np.abs(np.random.default_rng(0).normal(1.0, 0.3, (len(tri), 3))))
    v = [5e-5, 0.01, 0.2, 1.0, 4.0]
    w = np.full((5, 3), 0.2)
    d = gt.Diffusion(el, v, w, 0.75)
    kinds = [d.is_local(x) for x in v]
    assert kinds[0] and not kinds[-1]  # delta is local, the widest Gaussian is not
    x = np.einsum("nk,nkd->nd", np.full((len(tri), 3), 1 / 3), tri)[::5]
    ea = np.ones((len(x), 3))
    whole = d.exitance(x, ea)
    assert np.allclose(d.exitance(x, ea, only="local") + d.exitance(x, ea, only="wide"), whole, rtol=1e-12, atol=1e-15)
